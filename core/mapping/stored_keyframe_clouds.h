// Keyframe clouds from what the store keeps of a keyframe (encoded colour + 16-bit depth PNG and
// its corrected pose): how a restarted server rebuilds its map layers, and how exports of one
// session are made.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/cancel_check.h"
#include "common/map_types.h"
#include "common/status.h"
#include "core/mapping/occupancy_map.h"
#include "storage/map_store.h"

namespace semmap {

struct StoredKeyframeCloud {
  int64_t session_id = 0;
  int64_t seq = 0;
  Eigen::Isometry3d T_world_keyframe = Eigen::Isometry3d::Identity();
  std::shared_ptr<const KeyframeCloud> cloud;
};

// Decodes one stored keyframe. INVALID_ARGUMENT when it has no depth, DATA_LOSS when its images
// do not decode or do not match the session's camera.
StatusOr<KeyframeCloud> KeyframeCloudFromRecord(const KeyframeRecord& record,
                                                const CameraCalibration& camera,
                                                const OccupancyMapOptions& options);

// A stored keyframe with depth, without its images: what the layers keep of a keyframe whose
// cloud they read back from the store when they need it (ReadStoredKeyframeCloud).
struct StoredKeyframeRef {
  int64_t session_id = 0;
  int64_t seq = 0;
  int64_t keyframe_id = 0;  // the store's
  Eigen::Isometry3d T_world_keyframe = Eigen::Isometry3d::Identity();
};

// Every keyframe with depth of the map's sessions, without images (session then seq order),
// and each session's camera. NOT_FOUND for an unknown map.
struct StoredKeyframeRefs {
  std::vector<StoredKeyframeRef> keyframes;
  std::map<int64_t, CameraCalibration> cameras;  // by session id
};
StatusOr<StoredKeyframeRefs> ListStoredKeyframes(MapStore& store, const std::string& map_name);

// One stored keyframe's cloud, read by its id. NOT_FOUND when the store no longer has it;
// otherwise as KeyframeCloudFromRecord.
StatusOr<KeyframeCloud> ReadStoredKeyframeCloud(MapStore& store, int64_t keyframe_id,
                                                const CameraCalibration& camera,
                                                const OccupancyMapOptions& options);

// The origin of a map's layer frame (layer_frame.h): the stored one, or for a map that has none
// yet (its layers were never persisted, or predate layer origins) the one its first stored
// keyframe gives; nullopt for a map without keyframes. DATA_LOSS for a damaged stored origin.
StatusOr<std::optional<Eigen::Vector3d>> ReadLayerOrigin(MapStore& store, int64_t map_id,
                                                         const std::string& map_name);
// The origin the map's first stored keyframe gives (nullopt without keyframes).
StatusOr<std::optional<Eigen::Vector3d>> FirstKeyframeLayerOrigin(MapStore& store,
                                                                  const std::string& map_name);

// Every keyframe with depth of the map's sessions (only `session_name` when not empty; NOT_FOUND
// for an unknown one), in session then seq order, all in memory at once (what an export of one
// session rebuilds from). Keyframes without depth are skipped. A keyframe whose stored images do
// not decode is DATA_LOSS. `cancel` is asked before each keyframe is decoded.
StatusOr<std::vector<StoredKeyframeCloud>> LoadKeyframeClouds(MapStore& store,
                                                              const std::string& map_name,
                                                              const std::string& session_name,
                                                              const OccupancyMapOptions& options,
                                                              const CancelCheck& cancel = {});

}  // namespace semmap
