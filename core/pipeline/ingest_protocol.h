// The ingest stream's protocol rules, apart from how frames are processed: what a start message
// must hold, and the order, size and presence checks every frame passes before anything is
// decoded or tracked. Pure logic (no threads, no store), so each rule has a unit test.
#pragma once

#include <cstdint>
#include <optional>

#include "core/pipeline/ingest_types.h"
#include "core/slam/keyframe_policy.h"

namespace semmap {

// Stored seqs are SQLite integers (int64).
inline constexpr uint64_t kMaxFrameSeq = static_cast<uint64_t>(INT64_MAX);

// Validates a start message: names, mode, calibration, and the keyframe options the session
// asks for on top of the server's `defaults`. INVALID_ARGUMENT naming the field.
StatusOr<KeyframePolicyOptions> ValidateStart(const IngestStartRequest& start,
                                              const KeyframePolicyOptions& defaults);

class FrameProtocol {
 public:
  explicit FrameProtocol(size_t max_frame_bytes) : max_frame_bytes_(max_frame_bytes) {}

  // Order, size and presence checks, in this order (the first failure wins): seq in range and
  // above the previous accepted one, payload within the limit (RESOURCE_EXHAUSTED), a stamp,
  // a colour image. They come before the decoded images' errors. Does not accept the frame.
  Status Check(const IngestFrame& frame) const;
  // A pose prior, when the frame has one, is a valid pose (checked after the images).
  static Status CheckPosePrior(const IngestFrame& frame);
  // The frame was processed: later frames must have a larger seq.
  void Accept(uint64_t seq) { last_seq_ = seq; }
  std::optional<uint64_t> last_seq() const { return last_seq_; }

 private:
  size_t max_frame_bytes_;
  std::optional<uint64_t> last_seq_;
};

}  // namespace semmap
