// Plain domain records exchanged between the pipeline, the store, the service and the client.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"

namespace semmap {

enum class SessionMode : int { kRgbd = 1, kMono = 2, kKnownPoses = 3 };
std::string_view SessionModeName(SessionMode mode);  // "rgbd", "mono", "known_poses"

enum class LinkKind : int { kOdometry = 1, kLoop = 2 };

// How a session ended (values as stored and on the wire).
enum class SessionEndReason : int {
  kUnspecified = 0,  // open, or ended before reasons were recorded
  kCompleted = 1,    // the client sent end; everything was stored
  kCancelled = 2,    // the client cancelled, hung up or hit its deadline
  kError = 3,        // the server refused a message or failed
  kServerStopped = 4,
  kIdleTimeout = 5,
  kCrashed = 6,  // the server stopped without ending it; marked at the next start
};
// "open/unknown", "completed", "cancelled", "error", "server stopped", "idle timeout", "crashed"
std::string_view SessionEndReasonName(SessionEndReason reason);

struct MapInfo {
  int64_t id = 0;
  std::string name;
  int64_t created_unix_ns = 0;
  int64_t session_count = 0;
  int64_t keyframe_count = 0;
};

struct SessionInfo {
  int64_t id = 0;
  int64_t map_id = 0;
  std::string map_name;
  std::string name;
  SessionMode mode = SessionMode::kKnownPoses;
  CameraCalibration camera;
  double depth_scale = 0;  // raw depth units per metre the session's depth used (0: no depth)
  int64_t started_unix_ns = 0;
  int64_t ended_unix_ns = 0;  // 0 while the session is open (or ended by a crash)
  int64_t frame_count = 0;
  int64_t keyframe_count = 0;
  SessionEndReason end_reason = SessionEndReason::kUnspecified;
  std::string end_message;  // the final status message when it did not complete
};

// What an administrative removal took with it.
struct RemovedCounts {
  int64_t map_id = 0;  // the map removed from, or removed
  int64_t sessions = 0;
  int64_t frames = 0;
  int64_t keyframes = 0;
};

// One pose of a session's trajectory: every frame has one, keyframes are flagged.
struct TrajectoryPose {
  int64_t seq = 0;
  int64_t stamp_ns = 0;  // sensor time stamp in nanoseconds
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool is_keyframe = false;
  // Visual tracking could not place this frame: the pose is the last good one (a guess).
  bool lost = false;
};

// An image as stored: encoded bytes ("png", "jpeg") so keyframes stay compact.
struct EncodedImage {
  std::string format;  // "png" or "jpeg"; empty when absent
  std::string bytes;
  bool empty() const { return bytes.empty(); }
};

struct KeyframeRecord {
  int64_t id = 0;  // assigned by the store
  int64_t session_id = 0;
  int64_t seq = 0;
  int64_t stamp_ns = 0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  EncodedImage colour;
  EncodedImage depth;      // 16-bit PNG; metres = value / depth_scale
  double depth_scale = 0;  // 0 when the keyframe has no depth
  // Encoded local features (keypoints, descriptors, 3D points) for relocalisation and loop
  // closure; opaque to the store, which checksums them. Empty when the mode keeps none.
  std::string features_format;  // e.g. "semmap-features-v1"
  std::string features;
  // Redundant (keyframe culling): its features are gone; its pose still chains the graph.
  // Set by the store when read; a culled keyframe is written as such through
  // WriteBatch::culled_keyframes.
  bool culled = false;
};

// A corrected pose for a frame (and its keyframe, when it is one) after the back end moved
// the map: loop closure / pose-graph optimisation re-anchors stored poses.
struct PoseUpdate {
  int64_t session_id = 0;
  int64_t seq = 0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
};

// Where the back end holds a keyframe (map frame), for layers built from keyframes.
struct KeyframePose {
  int64_t session_id = 0;
  int64_t seq = 0;
  Eigen::Isometry3d T_world_keyframe = Eigen::Isometry3d::Identity();
};

// A constraint between two keyframes of one map (odometry or loop closure).
struct LinkRecord {
  int64_t id = 0;
  int64_t map_id = 0;
  int64_t from_keyframe_id = 0;
  int64_t to_keyframe_id = 0;
  // A pipeline may not know a keyframe's row id yet (its batch is still queued): then it leaves
  // the id 0 and names the keyframe by (session_id, seq); the store resolves it on write.
  int64_t from_session_id = 0;
  int64_t from_seq = -1;
  int64_t to_session_id = 0;
  int64_t to_seq = -1;
  LinkKind kind = LinkKind::kOdometry;
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

// A keyframe keypoint that observes a map point: the keyframe by (session_id, seq) (its row id
// may not be known to the back end), the keypoint by its index in the keyframe's features.
struct MapPointObservationRecord {
  int64_t session_id = 0;
  int64_t seq = 0;
  int32_t keypoint = 0;
};

// A 3D point of a map's SLAM back end (bundle-adjusted), as stored: a restarted server tracks
// against and closes loops with them.
struct MapPointRecord {
  int64_t point_id = 0;    // the back end's id, unique within its map
  int64_t session_id = 0;  // the session whose keyframe created it
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  std::vector<MapPointObservationRecord> observations;
};

// A named binary layer of a map (OctoMap, point cloud, ...), checksummed in the store.
struct MapBlob {
  int64_t map_id = 0;
  std::string kind;  // e.g. "octomap.ot"
  std::string data;
  int64_t updated_unix_ns = 0;
};

}  // namespace semmap
