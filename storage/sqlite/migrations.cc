#include "storage/sqlite/migrations.h"

#include <string>

#include "storage/sqlite/transaction.h"

namespace semmap::sqlite {
namespace {

// Version 1. Poses are translation + unit quaternion (tx..qw, qw >= 0); times are Unix or
// sensor nanoseconds; links.information is the 6x6 information matrix as 36 little-endian
// doubles in row-major order. STRICT makes SQLite reject values of the wrong type.
constexpr char kSchemaV1[] = R"sql(
CREATE TABLE maps (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE,
  created_ns INTEGER NOT NULL
) STRICT;

CREATE TABLE sessions (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  name TEXT NOT NULL,
  mode INTEGER NOT NULL CHECK (mode IN (1, 2, 3)),
  width INTEGER NOT NULL,
  height INTEGER NOT NULL,
  fx REAL NOT NULL, fy REAL NOT NULL, cx REAL NOT NULL, cy REAL NOT NULL,
  k1 REAL NOT NULL, k2 REAL NOT NULL, p1 REAL NOT NULL, p2 REAL NOT NULL, k3 REAL NOT NULL,
  depth_scale REAL NOT NULL,
  started_ns INTEGER NOT NULL,
  ended_ns INTEGER,
  UNIQUE (map_id, name)
) STRICT;

CREATE TABLE frames (
  session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
  seq INTEGER NOT NULL,
  stamp_ns INTEGER NOT NULL,
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL, qw REAL NOT NULL,
  is_keyframe INTEGER NOT NULL CHECK (is_keyframe IN (0, 1)),
  PRIMARY KEY (session_id, seq)
) STRICT, WITHOUT ROWID;

CREATE TABLE keyframes (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
  seq INTEGER NOT NULL,
  stamp_ns INTEGER NOT NULL,
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL, qw REAL NOT NULL,
  colour_format TEXT NOT NULL,
  colour BLOB NOT NULL,
  depth_format TEXT NOT NULL,
  depth BLOB NOT NULL,
  depth_scale REAL NOT NULL,
  UNIQUE (session_id, seq)
) STRICT;

CREATE TABLE links (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  from_kf INTEGER NOT NULL REFERENCES keyframes(id) ON DELETE CASCADE,
  to_kf INTEGER NOT NULL REFERENCES keyframes(id) ON DELETE CASCADE,
  kind INTEGER NOT NULL CHECK (kind IN (1, 2)),
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL, qw REAL NOT NULL,
  information BLOB NOT NULL CHECK (length(information) = 288)
) STRICT;
-- ListLinks scans by map; the keyframe indexes keep foreign-key checks on keyframe deletion
-- from scanning the whole table.
CREATE INDEX links_by_map ON links (map_id, id);
CREATE INDEX links_by_from ON links (from_kf);
CREATE INDEX links_by_to ON links (to_kf);

CREATE TABLE blobs (
  map_id INTEGER NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  kind TEXT NOT NULL,
  data BLOB NOT NULL,
  length INTEGER NOT NULL,
  sha256 BLOB NOT NULL CHECK (length(sha256) = 32),
  updated_ns INTEGER NOT NULL,
  PRIMARY KEY (map_id, kind)
) STRICT;
)sql";

// Version 2: local features of keyframes (relocalisation, loop closure), checksummed like map
// blobs, one row per keyframe that has them; frames flagged where visual tracking was lost.
constexpr char kSchemaV2[] = R"sql(
ALTER TABLE frames ADD COLUMN lost INTEGER NOT NULL DEFAULT 0 CHECK (lost IN (0, 1));

CREATE TABLE keyframe_features (
  keyframe_id INTEGER PRIMARY KEY REFERENCES keyframes(id) ON DELETE CASCADE,
  format TEXT NOT NULL,
  data BLOB NOT NULL,
  length INTEGER NOT NULL,
  sha256 BLOB NOT NULL CHECK (length(sha256) = 32)
) STRICT;
)sql";

// Version 3: the semantic layer. Object types a user registers (global with map_id NULL, or one
// map's) with their photos and checksummed features; recognitions of a type in a keyframe (in
// the keyframe's camera frame, so they follow pose corrections); and the instances fused per map
// (map frame), indexed by an R*Tree of point boxes for radius queries.
constexpr char kSchemaV3[] = R"sql(
CREATE TABLE object_types (
  id INTEGER PRIMARY KEY,
  label TEXT NOT NULL,
  map_id INTEGER REFERENCES maps(id) ON DELETE CASCADE,
  r INTEGER NOT NULL CHECK (r BETWEEN 0 AND 255),
  g INTEGER NOT NULL CHECK (g BETWEEN 0 AND 255),
  b INTEGER NOT NULL CHECK (b BETWEEN 0 AND 255),
  created_ns INTEGER NOT NULL
) STRICT;
-- UNIQUE (label, map_id) would let global types (NULL) repeat a label; map ids start at 1, so
-- 0 stands for the global scope.
CREATE UNIQUE INDEX object_types_by_scope ON object_types (label, ifnull(map_id, 0));
CREATE INDEX object_types_by_map ON object_types (map_id);

CREATE TABLE object_views (
  id INTEGER PRIMARY KEY,
  type_id INTEGER NOT NULL REFERENCES object_types(id) ON DELETE CASCADE,
  image_format TEXT NOT NULL,
  image BLOB NOT NULL,
  width INTEGER NOT NULL,
  height INTEGER NOT NULL,
  features_format TEXT NOT NULL,
  features BLOB NOT NULL,
  features_length INTEGER NOT NULL,
  features_sha256 BLOB NOT NULL CHECK (length(features_sha256) = 32)
) STRICT;
CREATE INDEX object_views_by_type ON object_views (type_id, id);

CREATE TABLE object_observations (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  type_id INTEGER NOT NULL REFERENCES object_types(id) ON DELETE CASCADE,
  keyframe_id INTEGER NOT NULL REFERENCES keyframes(id) ON DELETE CASCADE,
  px REAL NOT NULL, py REAL NOT NULL, pz REAL NOT NULL,
  ex REAL NOT NULL, ey REAL NOT NULL, ez REAL NOT NULL,
  matches INTEGER NOT NULL,
  inliers INTEGER NOT NULL,
  xi REAL NOT NULL,
  stamp_ns INTEGER NOT NULL
) STRICT;
CREATE INDEX object_observations_by_map ON object_observations (map_id, keyframe_id);
CREATE INDEX object_observations_by_type ON object_observations (type_id);
CREATE INDEX object_observations_by_keyframe ON object_observations (keyframe_id);

-- session_ids: the sessions that saw the instance, ascending, comma-separated ("3,5").
-- AUTOINCREMENT: every replacement writes new rows, and an id a client saw must never come
-- back naming another instance.
CREATE TABLE object_instances (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  map_id INTEGER NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  type_id INTEGER NOT NULL REFERENCES object_types(id) ON DELETE CASCADE,
  label TEXT NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
  ex REAL NOT NULL, ey REAL NOT NULL, ez REAL NOT NULL,
  confidence REAL NOT NULL CHECK (confidence BETWEEN 0 AND 1),
  observations INTEGER NOT NULL,
  session_ids TEXT NOT NULL,
  first_seen_ns INTEGER NOT NULL,
  last_seen_ns INTEGER NOT NULL
) STRICT;
CREATE INDEX object_instances_by_map ON object_instances (map_id, label, confidence DESC);
CREATE INDEX object_instances_by_type ON object_instances (type_id);

-- One point box per instance (same id). A virtual table takes no part in foreign-key cascades,
-- so triggers keep it in step with object_instances, including rows that a cascade from
-- object_types, maps or a replaced map's instances deletes (triggers fire for cascades).
CREATE VIRTUAL TABLE object_instances_rtree USING rtree(id, min_x, max_x, min_y, max_y,
                                                        min_z, max_z);
CREATE TRIGGER object_instances_rtree_insert AFTER INSERT ON object_instances BEGIN
  INSERT INTO object_instances_rtree VALUES (new.id, new.x, new.x, new.y, new.y, new.z, new.z);
END;
CREATE TRIGGER object_instances_rtree_update AFTER UPDATE OF x, y, z ON object_instances BEGIN
  UPDATE object_instances_rtree SET min_x = new.x, max_x = new.x, min_y = new.y, max_y = new.y,
    min_z = new.z, max_z = new.z WHERE id = new.id;
END;
CREATE TRIGGER object_instances_rtree_delete AFTER DELETE ON object_instances BEGIN
  DELETE FROM object_instances_rtree WHERE id = old.id;
END;
)sql";

// Version 4: how each session ended (SessionEndReason 1..6; NULL while open and for sessions
// that ended before reasons were recorded) and the final status message.
constexpr char kSchemaV4[] = R"sql(
ALTER TABLE sessions ADD COLUMN end_reason INTEGER CHECK (end_reason BETWEEN 1 AND 6);
ALTER TABLE sessions ADD COLUMN end_message TEXT;
)sql";

// Version 5: the SLAM back end's map points, replaced per map as a whole (WriteBatch::
// map_points). observations names keyframes by (session_id, seq) in a count-prefixed BLOB
// (storage/sqlite/map_point_codec.h), not by foreign key: a point outlives a removed session
// that observed it (RemoveSession rewrites the blobs), and ListMapPoints drops observations of
// keyframes that are not stored. Removing the map cascades.
constexpr char kSchemaV5[] = R"sql(
CREATE TABLE map_points (
  map_id INTEGER NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  point_id INTEGER NOT NULL,
  session_id INTEGER NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
  observations BLOB NOT NULL,
  PRIMARY KEY (map_id, point_id)
) STRICT;
)sql";

// Version 6: keyframe culling (core/slam/keyframe_culling.h) marks a keyframe redundant: it
// keeps its row, images and pose (frames and links still chain through it) but its features
// are deleted, and a restarted back end restores it as culled, not as a full keyframe.
constexpr char kSchemaV6[] = R"sql(
ALTER TABLE keyframes ADD COLUMN culled INTEGER NOT NULL DEFAULT 0 CHECK (culled IN (0, 1));
)sql";

// One step a line: clang-format would pack them into columns.
// clang-format off
constexpr Migration kMigrations[] = {
    {1, "initial schema", kSchemaV1},
    {2, "keyframe features", kSchemaV2},
    {3, "objects", kSchemaV3},
    {4, "session end reasons", kSchemaV4},
    {5, "map points", kSchemaV5},
    {6, "culled keyframes", kSchemaV6},
};
// clang-format on

}  // namespace

std::span<const Migration> SchemaMigrations() { return kMigrations; }

int LatestSchemaVersion() { return SchemaMigrations().back().version; }

StatusOr<int> ReadSchemaVersion(Connection& connection) {
  SEMMAP_ASSIGN_OR_RETURN(int64_t version, connection.QueryInt64("PRAGMA user_version"));
  return static_cast<int>(version);
}

namespace {

Status CheckNotNewer(int current, int latest) {
  if (current <= latest) return OkStatus();
  return FailedPreconditionError("database schema version " + std::to_string(current) +
                                 " is newer than this semmapd supports (" + std::to_string(latest) +
                                 "); upgrade semmapd");
}

Status CheckSteps(std::span<const Migration> migrations) {
  for (size_t i = 0; i < migrations.size(); ++i) {
    if (migrations[i].version != static_cast<int>(i) + 1) {
      return InternalError("migration steps must be numbered 1, 2, 3, ... (step " +
                           std::to_string(i) + " has version " +
                           std::to_string(migrations[i].version) + ")");
    }
  }
  return OkStatus();
}

}  // namespace

Status ApplyMigrations(Connection& connection, std::span<const Migration> migrations) {
  SEMMAP_RETURN_IF_ERROR(CheckSteps(migrations));
  const int latest = migrations.empty() ? 0 : migrations.back().version;
  // Fast path without the write lock: a reader opening next to a busy writer must not wait.
  SEMMAP_ASSIGN_OR_RETURN(int current, ReadSchemaVersion(connection));
  SEMMAP_RETURN_IF_ERROR(CheckNotNewer(current, latest));
  if (current == latest) return OkStatus();

  SEMMAP_ASSIGN_OR_RETURN(Transaction transaction, Transaction::Begin(connection));
  // Another connection may have migrated between the check and the lock: read again.
  SEMMAP_ASSIGN_OR_RETURN(current, ReadSchemaVersion(connection));
  SEMMAP_RETURN_IF_ERROR(CheckNotNewer(current, latest));
  for (const Migration& step : migrations) {
    if (step.version <= current) continue;
    SEMMAP_RETURN_IF_ERROR(connection.Exec(step.sql).WithContext(
        "schema migration " + std::to_string(step.version) + " (" + step.description + ")"));
  }
  // PRAGMA takes no parameters; the value is our own integer.
  SEMMAP_RETURN_IF_ERROR(connection.Exec("PRAGMA user_version = " + std::to_string(latest)));
  return transaction.Commit();
}

}  // namespace semmap::sqlite
