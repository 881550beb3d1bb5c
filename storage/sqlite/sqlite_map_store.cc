// SqliteMapStore: opening, maps, sessions and maintenance. Row writes live in
// sqlite_map_store_write.cc, trajectory/keyframe/link/blob reads in sqlite_map_store_read.cc,
// object types, observations and instances in sqlite_map_store_objects.cc.
#include "storage/sqlite/sqlite_map_store.h"

#include <cmath>

#include "common/time_util.h"
#include "storage/sqlite/migrations.h"
#include "storage/sqlite/transaction.h"

namespace semmap {

using sqlite::StatementLease;

MapStoreOpener SqliteMapStore::Opener(std::string path, SqliteOptions options) {
  return [path = std::move(path), options]() -> StatusOr<std::unique_ptr<MapStore>> {
    SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<SqliteMapStore> store, Open(path, options));
    return std::unique_ptr<MapStore>(std::move(store));
  };
}

StatusOr<std::unique_ptr<SqliteMapStore>> SqliteMapStore::Open(const std::string& path,
                                                               const SqliteOptions& options) {
  if (path.empty()) return InvalidArgumentError("database path is empty");
  sqlite::ConnectionOptions connection_options;
  connection_options.busy_timeout_ms = options.busy_timeout_ms;
  connection_options.synchronous =
      options.synchronous_full ? sqlite::Synchronous::kFull : sqlite::Synchronous::kNormal;
  SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<sqlite::Connection> db,
                          sqlite::Connection::Open(path, connection_options));
  SEMMAP_RETURN_IF_ERROR(
      sqlite::ApplyMigrations(*db, sqlite::SchemaMigrations()).WithContext("database " + path));
  return std::unique_ptr<SqliteMapStore>(new SqliteMapStore(std::move(db)));
}

// --- maps ---

StatusOr<std::vector<MapInfo>> SqliteMapStore::QueryMaps(const std::string& where,
                                                         const std::string* name) {
  // Counts are computed, not maintained: they can never drift from the rows.
  const std::string sql =
      "SELECT m.id, m.name, m.created_ns,"
      " (SELECT COUNT(*) FROM sessions s WHERE s.map_id = m.id),"
      " (SELECT COUNT(*) FROM keyframes k JOIN sessions s ON s.id = k.session_id"
      "  WHERE s.map_id = m.id)"
      " FROM maps m " +
      where + " ORDER BY m.name";
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, db_->Prepare(sql));
  if (name != nullptr) SEMMAP_RETURN_IF_ERROR(stmt->BindText(1, *name));
  std::vector<MapInfo> maps;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    MapInfo& map = maps.emplace_back();
    map.id = stmt->ColumnInt64(0);
    map.name = stmt->ColumnText(1);
    map.created_unix_ns = stmt->ColumnInt64(2);
    map.session_count = stmt->ColumnInt64(3);
    map.keyframe_count = stmt->ColumnInt64(4);
  }
  return maps;
}

StatusOr<std::vector<MapInfo>> SqliteMapStore::ListMaps() { return QueryMaps("", nullptr); }

StatusOr<MapInfo> SqliteMapStore::GetMap(const std::string& name) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<MapInfo> maps, QueryMaps("WHERE m.name = ?1", &name));
  if (maps.empty()) return NotFoundError("map '" + name + "' not found");
  return maps.front();
}

StatusOr<MapInfo> SqliteMapStore::GetOrCreateMap(const std::string& name) {
  if (name.empty()) return InvalidArgumentError("map name is empty");
  {
    SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                            db_->Prepare("INSERT INTO maps (name, created_ns) VALUES (?1, ?2)"
                                         " ON CONFLICT (name) DO NOTHING"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindAll(name, UnixNowNs()));
    SEMMAP_RETURN_IF_ERROR(stmt->Run());
  }
  return GetMap(name);
}

StatusOr<std::string> SqliteMapStore::MapName(int64_t map_id) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, db_->Prepare("SELECT name FROM maps WHERE id = ?1"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, map_id));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) return NotFoundError("map id " + std::to_string(map_id) + " not found");
  return stmt->ColumnText(0);
}

// --- sessions ---

StatusOr<std::vector<SessionInfo>> SqliteMapStore::QuerySessions(
    const std::string& where, const std::vector<std::string>& args) {
  const std::string sql =
      "SELECT s.id, s.map_id, m.name, s.name, s.mode, s.width, s.height,"
      " s.fx, s.fy, s.cx, s.cy, s.k1, s.k2, s.p1, s.p2, s.k3, s.depth_scale,"
      " s.started_ns, s.ended_ns,"
      " (SELECT COUNT(*) FROM frames f WHERE f.session_id = s.id),"
      " (SELECT COUNT(*) FROM keyframes k WHERE k.session_id = s.id),"
      " s.end_reason, s.end_message"
      " FROM sessions s JOIN maps m ON m.id = s.map_id " +
      where + " ORDER BY m.name, s.id";
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, db_->Prepare(sql));
  for (size_t i = 0; i < args.size(); ++i) {
    SEMMAP_RETURN_IF_ERROR(stmt->BindText(static_cast<int>(i) + 1, args[i]));
  }
  std::vector<SessionInfo> sessions;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    SessionInfo& s = sessions.emplace_back();
    s.id = stmt->ColumnInt64(0);
    s.map_id = stmt->ColumnInt64(1);
    s.map_name = stmt->ColumnText(2);
    s.name = stmt->ColumnText(3);
    s.mode = static_cast<SessionMode>(stmt->ColumnInt64(4));  // CHECK keeps it a known value
    s.camera.width = static_cast<int>(stmt->ColumnInt64(5));
    s.camera.height = static_cast<int>(stmt->ColumnInt64(6));
    s.camera.fx = stmt->ColumnDouble(7);
    s.camera.fy = stmt->ColumnDouble(8);
    s.camera.cx = stmt->ColumnDouble(9);
    s.camera.cy = stmt->ColumnDouble(10);
    for (int k = 0; k < 5; ++k) s.camera.distortion[k] = stmt->ColumnDouble(11 + k);
    s.depth_scale = stmt->ColumnDouble(16);
    s.started_unix_ns = stmt->ColumnInt64(17);
    s.ended_unix_ns = stmt->ColumnIsNull(18) ? 0 : stmt->ColumnInt64(18);
    s.frame_count = stmt->ColumnInt64(19);
    s.keyframe_count = stmt->ColumnInt64(20);
    // CHECK keeps the reason in 1..6.
    if (!stmt->ColumnIsNull(21))
      s.end_reason = static_cast<SessionEndReason>(stmt->ColumnInt64(21));
    if (!stmt->ColumnIsNull(22)) s.end_message = stmt->ColumnText(22);
  }
  return sessions;
}

StatusOr<std::vector<SessionInfo>> SqliteMapStore::ListSessions(const std::string& map_name) {
  if (map_name.empty()) return QuerySessions("", {});
  {
    // NOT_FOUND for an unknown map rather than an empty list.
    SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                            db_->Prepare("SELECT 1 FROM maps WHERE name = ?1"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindText(1, map_name));
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) return NotFoundError("map '" + map_name + "' not found");
  }
  return QuerySessions("WHERE m.name = ?1", {map_name});
}

StatusOr<SessionInfo> SqliteMapStore::GetSession(const std::string& map_name,
                                                 const std::string& session_name) {
  SEMMAP_ASSIGN_OR_RETURN(
      std::vector<SessionInfo> sessions,
      QuerySessions("WHERE m.name = ?1 AND s.name = ?2", {map_name, session_name}));
  if (sessions.empty()) {
    return NotFoundError("map '" + map_name + "' has no session '" + session_name + "'");
  }
  return sessions.front();
}

namespace {

Status ValidateNewSession(const SessionInfo& s) {
  if (s.name.empty()) return InvalidArgumentError("session name is empty");
  if (s.mode != SessionMode::kRgbd && s.mode != SessionMode::kMono &&
      s.mode != SessionMode::kKnownPoses) {
    return InvalidArgumentError("session mode " + std::to_string(static_cast<int>(s.mode)) +
                                " is unknown");
  }
  // SQLite stores NaN as NULL, which the NOT NULL columns would reject with a vaguer message.
  const CameraCalibration& c = s.camera;
  bool finite = std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) &&
                std::isfinite(c.cy) && std::isfinite(s.depth_scale);
  for (double d : c.distortion) finite = finite && std::isfinite(d);
  if (!finite) return InvalidArgumentError("session camera or depth scale is not finite");
  return OkStatus();
}

}  // namespace

StatusOr<SessionInfo> SqliteMapStore::CreateSession(const SessionInfo& session) {
  SEMMAP_RETURN_IF_ERROR(ValidateNewSession(session));
  SEMMAP_ASSIGN_OR_RETURN(std::string map_name, MapName(session.map_id));
  SessionInfo created = session;
  created.map_name = map_name;
  if (created.started_unix_ns == 0) created.started_unix_ns = UnixNowNs();
  created.ended_unix_ns = 0;
  created.frame_count = 0;
  created.keyframe_count = 0;
  {
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("INSERT INTO sessions (map_id, name, mode, width, height,"
                     " fx, fy, cx, cy, k1, k2, p1, p2, k3, depth_scale, started_ns)"
                     " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14,"
                     " ?15, ?16)"));
    const CameraCalibration& c = created.camera;
    SEMMAP_RETURN_IF_ERROR(stmt->BindAll(
        created.map_id, created.name, static_cast<int>(created.mode), c.width, c.height, c.fx, c.fy,
        c.cx, c.cy, c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3],
        c.distortion[4], created.depth_scale, created.started_unix_ns));
    Status inserted = stmt->Run();
    if (inserted.code() == StatusCode::kAlreadyExists) {
      return AlreadyExistsError("map '" + map_name + "' already has a session named '" +
                                created.name + "'");
    }
    SEMMAP_RETURN_IF_ERROR(inserted);
  }
  created.id = db_->last_insert_rowid();
  return created;
}

Status SqliteMapStore::EndSession(int64_t session_id, int64_t ended_unix_ns,
                                  SessionEndReason reason, const std::string& message) {
  if (ended_unix_ns <= 0) return InvalidArgumentError("session end time must be positive");
  if (reason == SessionEndReason::kUnspecified || reason == SessionEndReason::kCrashed) {
    return InvalidArgumentError(
        "a session ends completed, cancelled, with an error, at a server "
        "stop or by the idle timeout");
  }
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("UPDATE sessions SET ended_ns = ?2, end_reason = ?3, end_message = ?4"
                   " WHERE id = ?1"));
  SEMMAP_RETURN_IF_ERROR(
      stmt->BindAll(session_id, ended_unix_ns, static_cast<int>(reason), message));
  SEMMAP_RETURN_IF_ERROR(stmt->Run());
  if (db_->changes() == 0) {
    return NotFoundError("session id " + std::to_string(session_id) + " not found");
  }
  return OkStatus();
}

StatusOr<int64_t> SqliteMapStore::MarkOpenSessionsCrashed() {
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("UPDATE sessions SET end_reason = ?1 WHERE ended_ns IS NULL AND"
                   " end_reason IS NULL"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, static_cast<int>(SessionEndReason::kCrashed)));
  SEMMAP_RETURN_IF_ERROR(stmt->Run());
  return static_cast<int64_t>(db_->changes());
}

Status SqliteMapStore::RunWithId(const char* sql, int64_t id) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, db_->Prepare(sql));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, id));
  return stmt->Run();
}

StatusOr<RemovedCounts> SqliteMapStore::CountRows(const std::string& where, int64_t id) {
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("SELECT COUNT(*),"
                   " (SELECT COUNT(*) FROM frames f JOIN sessions s ON s.id = f.session_id " +
                   where +
                   "),"
                   " (SELECT COUNT(*) FROM keyframes k JOIN sessions s ON s.id = k.session_id " +
                   where + ") FROM sessions s " + where));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, id));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  RemovedCounts counts;
  if (row) {
    counts.sessions = stmt->ColumnInt64(0);
    counts.frames = stmt->ColumnInt64(1);
    counts.keyframes = stmt->ColumnInt64(2);
  }
  return counts;
}

StatusOr<RemovedCounts> SqliteMapStore::RemoveSession(int64_t session_id) {
  SEMMAP_ASSIGN_OR_RETURN(sqlite::Transaction transaction, sqlite::Transaction::Begin(*db_));
  SEMMAP_ASSIGN_OR_RETURN(RemovedCounts counts, CountRows("WHERE s.id = ?1", session_id));
  if (counts.sessions == 0) {
    return NotFoundError("session id " + std::to_string(session_id) + " not found");
  }
  int64_t map_id = 0;
  {
    SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                            db_->Prepare("SELECT map_id FROM sessions WHERE id = ?1"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, session_id));
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (row) map_id = stmt->ColumnInt64(0);
  }
  counts.map_id = map_id;
  // Frames, keyframes (with their features, links and observations) follow by cascade; the
  // derived products of the map no longer match what is left. Map points stay, without the
  // session's observations.
  SEMMAP_RETURN_IF_ERROR(RunWithId("DELETE FROM sessions WHERE id = ?1", session_id));
  SEMMAP_RETURN_IF_ERROR(RunWithId("DELETE FROM object_instances WHERE map_id = ?1", map_id));
  SEMMAP_RETURN_IF_ERROR(RunWithId("DELETE FROM blobs WHERE map_id = ?1", map_id));
  SEMMAP_RETURN_IF_ERROR(DropSessionFromMapPoints(map_id, session_id));
  SEMMAP_RETURN_IF_ERROR(transaction.Commit());
  return counts;
}

StatusOr<RemovedCounts> SqliteMapStore::RemoveMap(int64_t map_id) {
  SEMMAP_ASSIGN_OR_RETURN(sqlite::Transaction transaction, sqlite::Transaction::Begin(*db_));
  SEMMAP_RETURN_IF_ERROR(MapName(map_id).status());
  SEMMAP_ASSIGN_OR_RETURN(RemovedCounts counts, CountRows("WHERE s.map_id = ?1", map_id));
  counts.map_id = map_id;
  // Sessions, links, blobs, the map's own object types, observations and instances cascade.
  SEMMAP_RETURN_IF_ERROR(RunWithId("DELETE FROM maps WHERE id = ?1", map_id));
  SEMMAP_RETURN_IF_ERROR(transaction.Commit());
  return counts;
}

Status SqliteMapStore::RequireSession(int64_t session_id) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                          db_->Prepare("SELECT 1 FROM sessions WHERE id = ?1"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, session_id));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) return NotFoundError("session id " + std::to_string(session_id) + " not found");
  return OkStatus();
}

// --- maintenance ---

Status SqliteMapStore::Checkpoint() {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, db_->Prepare("PRAGMA wal_checkpoint(TRUNCATE)"));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  // The row is (busy, wal frames, frames checkpointed); busy = 1 means a reader held it back.
  if (row && stmt->ColumnInt64(0) != 0) {
    return UnavailableError("checkpoint of " + db_->path() +
                            " incomplete: another connection is reading");
  }
  return OkStatus();
}

Status SqliteMapStore::IntegrityCheck() {
  std::string problems;
  {
    SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, db_->Prepare("PRAGMA integrity_check"));
    for (;;) {
      SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
      if (!row) break;
      const std::string line = stmt->ColumnText(0);
      if (line != "ok") problems += (problems.empty() ? "" : "; ") + line;
    }
  }
  {
    // Rows are (table, rowid, parent table, fk index) for every dangling reference.
    SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, db_->Prepare("PRAGMA foreign_key_check"));
    for (;;) {
      SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
      if (!row) break;
      // WITHOUT ROWID tables (frames) report a NULL rowid.
      const std::string rowid = stmt->ColumnIsNull(1) ? "?" : stmt->ColumnText(1);
      problems += (problems.empty() ? "" : "; ") + std::string("row ") + rowid + " of " +
                  stmt->ColumnText(0) + " references a missing row of " + stmt->ColumnText(2);
    }
  }
  if (!problems.empty()) {
    return DataLossError("integrity check of " + db_->path() + " failed: " + problems);
  }
  return OkStatus();
}

}  // namespace semmap
