// MapStore: durable storage of maps, sessions, per-frame poses, keyframes, links and map blobs.
// Implementations are not required to be thread-safe: the server gives the single storage
// writer thread its own instance and serialises reads on another (SQLite WAL lets them overlap).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/map_types.h"
#include "common/object_types.h"
#include "common/status.h"

namespace semmap {

// Everything one ingest step wants persisted; applied atomically (one transaction).
struct WriteBatch {
  std::vector<std::pair<int64_t, TrajectoryPose>> frames;  // (session_id, pose)
  std::vector<KeyframeRecord> keyframes;                   // ids assigned by the store, in order
  std::vector<LinkRecord> links;
  std::vector<MapBlob> blobs;  // replaces the blob of the same (map_id, kind)
  // Applied after frames and keyframes: moves the frame row (and the keyframe row when the
  // frame is a keyframe) of (session_id, seq). NOT_FOUND when the frame does not exist.
  std::vector<PoseUpdate> pose_updates;
  // Applied after keyframes: marks the keyframe (session_id, seq) culled and deletes its
  // features (KeyframeRecord::culled). NOT_FOUND when the keyframe does not exist.
  std::vector<std::pair<int64_t, int64_t>> culled_keyframes;
  // Applied after keyframes (an observation may name a keyframe of the same batch).
  std::vector<ObjectObservation> observations;
  // Each replaces every stored instance of its map (the fusion's current answer).
  std::vector<std::pair<int64_t, std::vector<ObjectInstance>>> instances;  // (map_id, all)
  // Each replaces every stored map point of its map (the back end's current points).
  std::vector<std::pair<int64_t, std::vector<MapPointRecord>>> map_points;  // (map_id, all)
  bool empty() const {
    return frames.empty() && keyframes.empty() && links.empty() && blobs.empty() &&
           pose_updates.empty() && culled_keyframes.empty() && observations.empty() &&
           instances.empty() && map_points.empty();
  }
  void Append(WriteBatch&& other);
};

// Counts of rows a batch wrote, for logs and benches.
struct WriteResult {
  std::vector<int64_t> keyframe_ids;  // same order as WriteBatch::keyframes
};

class MapStore {
 public:
  virtual ~MapStore() = default;

  // --- maps and sessions ---
  virtual StatusOr<std::vector<MapInfo>> ListMaps() = 0;
  virtual StatusOr<MapInfo> GetMap(const std::string& name) = 0;  // NOT_FOUND if absent
  virtual StatusOr<MapInfo> GetOrCreateMap(const std::string& name) = 0;
  // All sessions of a map, or of every map when map_name is empty; NOT_FOUND for an unknown map.
  virtual StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& map_name) = 0;
  virtual StatusOr<SessionInfo> GetSession(const std::string& map_name,
                                           const std::string& session_name) = 0;
  // ALREADY_EXISTS when the map has a session of that name. Fills id and map_name.
  virtual StatusOr<SessionInfo> CreateSession(const SessionInfo& session) = 0;
  // Records the end (reason kCompleted .. kIdleTimeout; `message` empty for kCompleted).
  virtual Status EndSession(int64_t session_id, int64_t ended_unix_ns, SessionEndReason reason,
                            const std::string& message) = 0;
  // At start-up, before any stream: every session still open was left so by a server that
  // stopped without ending it; marks them kCrashed and returns how many there were.
  virtual StatusOr<int64_t> MarkOpenSessionsCrashed() = 0;
  // Removes a session with its frames, keyframes, links and object observations, and the
  // map's derived products (layer blobs, object instances), which the caller rebuilds from
  // what is left. NOT_FOUND for an unknown session.
  virtual StatusOr<RemovedCounts> RemoveSession(int64_t session_id) = 0;
  // Removes a map with everything in it. NOT_FOUND for an unknown map.
  virtual StatusOr<RemovedCounts> RemoveMap(int64_t map_id) = 0;

  // --- trajectory and keyframes ---
  virtual StatusOr<WriteResult> Write(const WriteBatch& batch) = 0;
  // Poses in seq order; keyframes_only restricts to keyframes.
  virtual StatusOr<std::vector<TrajectoryPose>> GetTrajectory(int64_t session_id,
                                                              bool keyframes_only) = 0;
  // With images and features (DATA_LOSS when the stored features fail their checksum).
  virtual StatusOr<KeyframeRecord> GetKeyframe(int64_t keyframe_id) = 0;
  // Keyframes of a session in seq order, without image and feature bytes unless with_images.
  virtual StatusOr<std::vector<KeyframeRecord>> ListKeyframes(int64_t session_id,
                                                              bool with_images) = 0;
  // Keyframes of a session in seq order with their features but no images (what the SLAM back
  // end reloads); DATA_LOSS when stored features fail their checksum.
  virtual StatusOr<std::vector<KeyframeRecord>> ListKeyframeFeatures(int64_t session_id) = 0;
  // One keyframe with its features but no images (what the SLAM back end reads back for a
  // keyframe whose features it let go); features empty when it has none (culled, KNOWN_POSES).
  // NOT_FOUND when the session has no keyframe `seq`; DATA_LOSS as ListKeyframeFeatures.
  virtual StatusOr<KeyframeRecord> GetKeyframeFeatures(int64_t session_id, int64_t seq) = 0;
  virtual StatusOr<std::vector<LinkRecord>> ListLinks(int64_t map_id) = 0;
  // The map's stored map points (any order); observations of keyframes no longer stored (a
  // removed session) are left out, and points left without observations too.
  virtual StatusOr<std::vector<MapPointRecord>> ListMapPoints(int64_t map_id) = 0;
  // Replaces keyframe poses after an optimisation (ids must exist).
  virtual Status UpdateKeyframePoses(
      const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& T_world_keyframe) = 0;

  // --- objects ---
  // Stores a type with its views (ids filled in). ALREADY_EXISTS when its scope (global, or
  // the map) already has the label; NOT_FOUND for an unknown map_id.
  virtual StatusOr<ObjectType> CreateObjectType(const ObjectType& type) = 0;
  // Types visible in a map (global ones and the map's own) or, with nullopt, every type;
  // ordered by label. Views (with features) only when with_views; DATA_LOSS when stored
  // features fail their checksum.
  virtual StatusOr<std::vector<ObjectType>> ListObjectTypes(std::optional<int64_t> map_id,
                                                            bool with_views) = 0;
  // Removes the type of that label in that scope, with its views, observations and instances.
  // NOT_FOUND when there is none.
  virtual Status RemoveObjectType(const std::string& label, std::optional<int64_t> map_id) = 0;
  // A map's observations in keyframe order, with keyframe_id, session_id, seq and label filled.
  virtual StatusOr<std::vector<ObjectObservation>> ListObjectObservations(int64_t map_id) = 0;
  // Instances of a label (every label when empty) in one map or, with nullopt, every map;
  // ordered by map, label, then confidence (highest first).
  virtual StatusOr<std::vector<ObjectInstance>> FindObjectInstances(std::optional<int64_t> map_id,
                                                                    const std::string& label) = 0;
  // Instances of a map within `radius_m` of `centre` (Euclidean, map frame), nearest first,
  // distance_m filled; found through an R*Tree index. Only `label` when not empty.
  virtual StatusOr<std::vector<ObjectInstance>> ObjectInstancesNear(int64_t map_id,
                                                                    const Eigen::Vector3d& centre,
                                                                    double radius_m,
                                                                    const std::string& label) = 0;

  // --- map blobs (length + sha256 verified on read: DATA_LOSS on mismatch) ---
  virtual StatusOr<MapBlob> GetBlob(int64_t map_id, const std::string& kind) = 0;

  // Flushes the WAL into the main database (on clean shutdown).
  virtual Status Checkpoint() = 0;
};

}  // namespace semmap
