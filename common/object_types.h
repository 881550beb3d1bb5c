// Domain records of the semantic layer: object types a user registers (with photos and their
// features), observations of them in keyframes, and the object instances fused per map.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/map_types.h"

namespace semmap {

// One registered photo of an object type.
struct ObjectView {
  int64_t id = 0;      // assigned by the store
  EncodedImage image;  // as the user sent it (png / jpeg)
  int width = 0;
  int height = 0;
  // Encoded 2D features of the photo (keypoints + descriptors; FeatureCodec's format), opaque
  // to the store, which checksums them.
  std::string features_format;
  std::string features;
  // Keypoints in `features`: set when the view is built and by queries that drop the bytes.
  size_t feature_count = 0;
};

// A kind of object users want found ("laptop", "teddy"): global (every map) or one map's.
struct ObjectType {
  int64_t id = 0;                 // assigned by the store
  std::string label;              // a valid name (ValidateName), unique within its scope
  std::optional<int64_t> map_id;  // nullopt: global
  std::string map_name;           // filled on read for map-scoped types
  std::array<uint8_t, 3> rgb = {255, 128, 0};  // drawing colour (pictures, PLY boxes)
  int64_t created_unix_ns = 0;
  std::vector<ObjectView> views;  // filled on create and when read with views
};

// One recognition of an object type in one keyframe, in the keyframe's camera frame, so a
// pose-graph correction moves it with its keyframe.
struct ObjectObservation {
  int64_t id = 0;  // assigned by the store
  int64_t map_id = 0;
  int64_t type_id = 0;
  std::string label;  // filled on read
  // The keyframe, by row id or, with id 0, by (session_id, seq) as links name theirs.
  int64_t keyframe_id = 0;
  int64_t session_id = 0;
  int64_t seq = -1;
  Eigen::Vector3d p_keyframe = Eigen::Vector3d::Zero();  // robust centre of the inlier points
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();      // spread of the inlier points, metres
  int matches = 0;                                       // good (ratio-test) feature matches
  int inliers = 0;                                       // geometric-verification inliers
  double xi = 0;         // N_c / N_n against the neighbouring keyframes
  int64_t stamp_ns = 0;  // the keyframe's sensor time
};

// Observations of one type fused into one physical object of a map (map frame).
struct ObjectInstance {
  int64_t id = 0;  // assigned by the store
  int64_t map_id = 0;
  std::string map_name;  // filled on read
  int64_t type_id = 0;
  std::string label;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();  // full size per map axis, metres
  double confidence = 0;                             // in [0, 1]
  int observations = 0;
  std::vector<int64_t> session_ids;   // the sessions that saw it (written)
  std::vector<std::string> sessions;  // their names (filled on read)
  int64_t first_seen_ns = 0;          // sensor stamps of the first / last observation
  int64_t last_seen_ns = 0;
  double distance_m = 0;  // ObjectsNear: distance from the query point
};

}  // namespace semmap
