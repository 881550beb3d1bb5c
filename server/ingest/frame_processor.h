// Turns a decoded frame into a pose and a keyframe decision; one implementation per session mode.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>

#include "common/map_types.h"
#include "common/status.h"
#include "server/sensor/image_decoding.h"
#include "server/slam/keyframe_selector.h"

namespace semmap {

struct DecodedFrame {
  uint64_t seq = 0;
  int64_t stamp_ns = 0;
  cv::Mat colour;  // BGR8 or mono8
  std::optional<DecodedDepth> depth;
  std::optional<Eigen::Isometry3d> T_world_camera_prior;
};

struct FrameEstimate {
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool is_keyframe = false;
};

class FrameProcessor {
 public:
  virtual ~FrameProcessor() = default;
  virtual StatusOr<FrameEstimate> Process(const DecodedFrame& frame) = 0;
};

// KNOWN_POSES: the client's pose is the truth; only the keyframe decision is ours.
class KnownPosesProcessor final : public FrameProcessor {
 public:
  explicit KnownPosesProcessor(KeyframeSelectorOptions options) : selector_(options) {}
  StatusOr<FrameEstimate> Process(const DecodedFrame& frame) override;

 private:
  KeyframeSelector selector_;
};

// UNIMPLEMENTED for modes this server cannot run yet (never a faked pose).
StatusOr<std::unique_ptr<FrameProcessor>> MakeFrameProcessor(SessionMode mode,
                                                             const KeyframeSelectorOptions& kf);

}  // namespace semmap
