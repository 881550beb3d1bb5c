// MapStore on one SQLite database file (schema in migrations.cc). Each instance owns one
// connection and is used by one thread at a time; the server opens one for the writer thread
// and one for queries, which WAL lets run side by side.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/status.h"
#include "storage/map_store.h"
#include "storage/map_store_opener.h"
#include "storage/sqlite/connection.h"

namespace semmap {

struct SqliteOptions {
  int busy_timeout_ms = 5000;  // wait this long for the other connection's lock
  // true: synchronous=FULL (a commit survives power loss). false: NORMAL (faster; WAL still
  // survives a process crash, but the last commits may be lost if the machine loses power).
  bool synchronous_full = true;
};

class SqliteMapStore final : public MapStore {
 public:
  // Opens (creating if missing) the database at `path` and migrates it to the current schema.
  // The parent directory must exist. FAILED_PRECONDITION when the file cannot be opened for
  // writing or its schema is newer than this binary's.
  static StatusOr<std::unique_ptr<SqliteMapStore>> Open(const std::string& path,
                                                        const SqliteOptions& options);
  // Opens another connection to `path` on each call (read connections for pipeline stages'
  // restores, next to the writer's: WAL).
  static MapStoreOpener Opener(std::string path, SqliteOptions options);

  StatusOr<std::vector<MapInfo>> ListMaps() override;
  StatusOr<MapInfo> GetMap(const std::string& name) override;
  StatusOr<MapInfo> GetOrCreateMap(const std::string& name) override;
  StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& map_name) override;
  StatusOr<SessionInfo> GetSession(const std::string& map_name,
                                   const std::string& session_name) override;
  StatusOr<SessionInfo> CreateSession(const SessionInfo& session) override;
  Status EndSession(int64_t session_id, int64_t ended_unix_ns, SessionEndReason reason,
                    const std::string& message) override;
  StatusOr<int64_t> MarkOpenSessionsCrashed() override;
  // One transaction each. RemoveSession keeps the map's points but takes the session's
  // observations out of them (a point left without any goes); a point whose observations
  // blob is corrupt is left as it is (ListMapPoints keeps reporting it).
  StatusOr<RemovedCounts> RemoveSession(int64_t session_id) override;
  StatusOr<RemovedCounts> RemoveMap(int64_t map_id) override;

  // One transaction. Frames are upserted by (session_id, seq); links may name keyframes by id
  // or, with id 0, by (session_id, seq), including keyframes of the same batch. Map points are
  // stored as given: neither their session nor their observations' keyframes are checked (the
  // read leaves out observations of keyframes that are not stored).
  StatusOr<WriteResult> Write(const WriteBatch& batch) override;
  StatusOr<std::vector<TrajectoryPose>> GetTrajectory(int64_t session_id,
                                                      bool keyframes_only) override;
  StatusOr<KeyframeRecord> GetKeyframe(int64_t keyframe_id) override;
  // Without images the records keep their formats but no bytes.
  StatusOr<std::vector<KeyframeRecord>> ListKeyframes(int64_t session_id,
                                                      bool with_images) override;
  StatusOr<std::vector<KeyframeRecord>> ListKeyframeFeatures(int64_t session_id) override;
  StatusOr<KeyframeRecord> GetKeyframeFeatures(int64_t session_id, int64_t seq) override;
  StatusOr<std::vector<LinkRecord>> ListLinks(int64_t map_id) override;
  // Ordered by point id. NOT_FOUND for an unknown map; DATA_LOSS naming the point for an
  // observations blob that does not decode.
  StatusOr<std::vector<MapPointRecord>> ListMapPoints(int64_t map_id) override;
  // Also moves the frames (trajectory rows) of those keyframes, so a keyframe has one pose.
  Status UpdateKeyframePoses(
      const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& T_world_keyframe) override;

  // Objects (sqlite_map_store_objects.cc). Labels follow ValidateName's rules. Unknown map ids
  // are NOT_FOUND everywhere; a type or instance naming a type that belongs to another map is
  // INVALID_ARGUMENT.
  StatusOr<ObjectType> CreateObjectType(const ObjectType& type) override;
  // Ordered by label, the global type before map-scoped ones, those by map name.
  StatusOr<std::vector<ObjectType>> ListObjectTypes(std::optional<int64_t> map_id,
                                                    bool with_views) override;
  Status RemoveObjectType(const std::string& label, std::optional<int64_t> map_id) override;
  // Ordered by keyframe id (storage order), then observation id.
  StatusOr<std::vector<ObjectObservation>> ListObjectObservations(int64_t map_id) override;
  // Ordered by map name, label, confidence (highest first), then id. Session ids whose session
  // is no longer stored are left out of session_ids and sessions alike.
  StatusOr<std::vector<ObjectInstance>> FindObjectInstances(std::optional<int64_t> map_id,
                                                            const std::string& label) override;
  // INVALID_ARGUMENT for a negative or non-finite radius or a non-finite centre. Ties in
  // distance are ordered by id.
  StatusOr<std::vector<ObjectInstance>> ObjectInstancesNear(int64_t map_id,
                                                            const Eigen::Vector3d& centre,
                                                            double radius_m,
                                                            const std::string& label) override;

  StatusOr<MapBlob> GetBlob(int64_t map_id, const std::string& kind) override;
  // UNAVAILABLE when a reader kept the WAL from being fully checkpointed.
  Status Checkpoint() override;

  // PRAGMA integrity_check and foreign_key_check: DATA_LOSS with SQLite's findings unless clean.
  Status IntegrityCheck();

  sqlite::Connection& connection() { return *db_; }  // for tests and maintenance tools

 private:
  explicit SqliteMapStore(std::unique_ptr<sqlite::Connection> db) : db_(std::move(db)) {}

  // --- checks shared by the methods (NOT_FOUND when the row is absent) ---
  StatusOr<std::string> MapName(int64_t map_id);
  Status RequireSession(int64_t session_id);
  Status RunWithId(const char* sql, int64_t id);  // a statement binding ?1 = id
  // Sessions, frames and keyframes of the sessions `where` (on sessions s, binding ?1 = id).
  StatusOr<RemovedCounts> CountRows(const std::string& where, int64_t id);
  StatusOr<std::vector<SessionInfo>> QuerySessions(const std::string& where,
                                                   const std::vector<std::string>& args);
  StatusOr<std::vector<MapInfo>> QueryMaps(const std::string& where, const std::string* name);

  // --- Write, one row kind each (sqlite_map_store_write.cc) ---
  Status WriteFrame(int64_t session_id, const TrajectoryPose& pose);
  StatusOr<int64_t> WriteKeyframe(const KeyframeRecord& keyframe);
  Status WriteLink(const LinkRecord& link);
  Status WriteBlob(const MapBlob& blob);
  Status WriteKeyframeFeatures(int64_t keyframe_id, const KeyframeRecord& keyframe);
  Status ApplyPoseUpdate(const PoseUpdate& update);
  Status CullKeyframe(int64_t session_id, int64_t seq);  // WriteBatch::culled_keyframes
  // Map points (schema v5): the map's rows are deleted, then each point inserted.
  // INVALID_ARGUMENT for a non-finite position, a negative keypoint or a repeated point id.
  Status ReplaceMapPoints(int64_t map_id, const std::vector<MapPointRecord>& points);
  Status WriteMapPoint(int64_t map_id, const MapPointRecord& point);
  // Part of RemoveSession: takes the session's observations out of the map's points and deletes
  // the points left without any. Session ids can be reused once the largest is removed, so the
  // read-time filter of ListMapPoints alone could hand them to a later session's keyframes.
  Status DropSessionFromMapPoints(int64_t map_id, int64_t session_id);
  // Replaces a point's observations, or deletes the point when there are none.
  Status RewriteMapPointObservations(int64_t map_id, int64_t point_id,
                                     const std::vector<MapPointObservationRecord>& observations);
  // (session_id, seq) of the map's stored keyframes, sorted.
  using KeyframeKeys = std::vector<std::pair<int64_t, int64_t>>;
  StatusOr<KeyframeKeys> StoredKeyframeKeys(int64_t map_id);
  Status ReadKeyframeFeatures(KeyframeRecord& keyframe);
  // Observations and instances (sqlite_map_store_objects.cc).
  Status WriteObservation(const ObjectObservation& observation);
  Status ReplaceInstances(int64_t map_id, const std::vector<ObjectInstance>& instances);
  // The label of a type usable in `map_id` (global or that map's own).
  StatusOr<std::string> TypeLabelInMap(int64_t type_id, int64_t map_id);
  Status ReadObjectViews(ObjectType& type);
  // Resolves session_ids to names (ids whose session is gone are dropped).
  Status FillSessionNames(std::vector<ObjectInstance>& instances);
  // The keyframe a link end names, checked to belong to `map_id`.
  StatusOr<int64_t> ResolveLinkEnd(int64_t map_id, int64_t keyframe_id, int64_t session_id,
                                   int64_t seq, const char* end);

  std::unique_ptr<sqlite::Connection> db_;
};

}  // namespace semmap
