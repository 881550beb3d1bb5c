// SqliteMapStore: the write paths (Write and its row kinds, UpdateKeyframePoses).
#include <algorithm>
#include <cmath>

#include "common/sha256.h"
#include "common/time_util.h"
#include "storage/sqlite/map_point_codec.h"
#include "storage/sqlite/row_codec.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "storage/sqlite/transaction.h"

namespace semmap {

using sqlite::StatementLease;

StatusOr<WriteResult> SqliteMapStore::Write(const WriteBatch& batch) {
  WriteResult result;
  if (batch.empty()) return result;
  SEMMAP_ASSIGN_OR_RETURN(sqlite::Transaction transaction, sqlite::Transaction::Begin(*db_));

  // Each distinct session is checked once (NOT_FOUND names it) instead of once per row.
  std::vector<int64_t> sessions;
  for (const auto& [session_id, pose] : batch.frames) sessions.push_back(session_id);
  for (const KeyframeRecord& kf : batch.keyframes) sessions.push_back(kf.session_id);
  std::sort(sessions.begin(), sessions.end());
  sessions.erase(std::unique(sessions.begin(), sessions.end()), sessions.end());
  for (int64_t session_id : sessions) SEMMAP_RETURN_IF_ERROR(RequireSession(session_id));

  for (const auto& [session_id, pose] : batch.frames) {
    SEMMAP_RETURN_IF_ERROR(WriteFrame(session_id, pose)
                               .WithContext("frame seq " + std::to_string(pose.seq) +
                                            " of session " + std::to_string(session_id)));
  }
  // Keyframes before links: a link may name a keyframe of this very batch.
  result.keyframe_ids.reserve(batch.keyframes.size());
  for (const KeyframeRecord& kf : batch.keyframes) {
    StatusOr<int64_t> id = WriteKeyframe(kf);
    if (!id.ok()) {
      return id.status().WithContext("keyframe seq " + std::to_string(kf.seq) + " of session " +
                                     std::to_string(kf.session_id));
    }
    result.keyframe_ids.push_back(*id);
  }
  for (size_t i = 0; i < batch.links.size(); ++i) {
    SEMMAP_RETURN_IF_ERROR(WriteLink(batch.links[i]).WithContext("link " + std::to_string(i)));
  }
  for (const MapBlob& blob : batch.blobs) {
    SEMMAP_RETURN_IF_ERROR(WriteBlob(blob).WithContext("map blob '" + blob.kind + "'"));
  }
  for (const PoseUpdate& update : batch.pose_updates) {
    SEMMAP_RETURN_IF_ERROR(
        ApplyPoseUpdate(update).WithContext("pose update of seq " + std::to_string(update.seq) +
                                            " of session " + std::to_string(update.session_id)));
  }
  for (const auto& [session_id, seq] : batch.culled_keyframes) {
    SEMMAP_RETURN_IF_ERROR(CullKeyframe(session_id, seq)
                               .WithContext("culling keyframe seq " + std::to_string(seq) +
                                            " of session " + std::to_string(session_id)));
  }
  // After keyframes (an observation may name one of this batch), instances after observations.
  for (size_t i = 0; i < batch.observations.size(); ++i) {
    SEMMAP_RETURN_IF_ERROR(WriteObservation(batch.observations[i])
                               .WithContext("object observation " + std::to_string(i)));
  }
  for (const auto& [map_id, instances] : batch.instances) {
    SEMMAP_RETURN_IF_ERROR(
        ReplaceInstances(map_id, instances)
            .WithContext("object instances of map id " + std::to_string(map_id)));
  }
  for (const auto& [map_id, points] : batch.map_points) {
    SEMMAP_RETURN_IF_ERROR(ReplaceMapPoints(map_id, points)
                               .WithContext("map points of map id " + std::to_string(map_id)));
  }
  SEMMAP_RETURN_IF_ERROR(transaction.Commit());
  return result;
}

Status SqliteMapStore::WriteFrame(int64_t session_id, const TrajectoryPose& pose) {
  if (pose.seq < 0) return InvalidArgumentError("seq must not be negative");
  // Re-sending a seq replaces the row (a client retrying after a lost ack).
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("INSERT INTO frames (session_id, seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw,"
                   " is_keyframe, lost) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)"
                   " ON CONFLICT (session_id, seq) DO UPDATE SET stamp_ns = excluded.stamp_ns,"
                   " tx = excluded.tx, ty = excluded.ty, tz = excluded.tz, qx = excluded.qx,"
                   " qy = excluded.qy, qz = excluded.qz, qw = excluded.qw,"
                   " is_keyframe = excluded.is_keyframe, lost = excluded.lost"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(session_id, pose.seq, pose.stamp_ns));
  SEMMAP_RETURN_IF_ERROR(sqlite::BindPose(*stmt, 4, pose.T_world_camera));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(11, pose.is_keyframe ? 1 : 0));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(12, pose.lost ? 1 : 0));
  return stmt->Run();
}

StatusOr<int64_t> SqliteMapStore::WriteKeyframe(const KeyframeRecord& kf) {
  if (kf.seq < 0) return InvalidArgumentError("seq must not be negative");
  if (!std::isfinite(kf.depth_scale)) return InvalidArgumentError("depth scale is not finite");
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("INSERT INTO keyframes (session_id, seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw,"
                   " colour_format, colour, depth_format, depth, depth_scale)"
                   " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(kf.session_id, kf.seq, kf.stamp_ns));
  SEMMAP_RETURN_IF_ERROR(sqlite::BindPose(*stmt, 4, kf.T_world_camera));
  // The images outlive the statement's use (the batch is alive until Write returns): no copy.
  SEMMAP_RETURN_IF_ERROR(stmt->BindText(11, kf.colour.format));
  SEMMAP_RETURN_IF_ERROR(stmt->BindBlobNoCopy(12, kf.colour.bytes));
  SEMMAP_RETURN_IF_ERROR(stmt->BindText(13, kf.depth.format));
  SEMMAP_RETURN_IF_ERROR(stmt->BindBlobNoCopy(14, kf.depth.bytes));
  SEMMAP_RETURN_IF_ERROR(stmt->BindDouble(15, kf.depth_scale));
  Status inserted = stmt->Run();
  if (inserted.code() == StatusCode::kAlreadyExists) {
    return AlreadyExistsError("the session already has a keyframe at this seq");
  }
  SEMMAP_RETURN_IF_ERROR(inserted);
  const int64_t id = db_->last_insert_rowid();
  if (!kf.features.empty()) SEMMAP_RETURN_IF_ERROR(WriteKeyframeFeatures(id, kf));
  return id;
}

Status SqliteMapStore::WriteKeyframeFeatures(int64_t keyframe_id, const KeyframeRecord& kf) {
  if (kf.features_format.empty()) return InvalidArgumentError("keyframe features have no format");
  const Sha256Digest digest = Sha256(kf.features);
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("INSERT INTO keyframe_features (keyframe_id, format, data, length, sha256)"
                   " VALUES (?1, ?2, ?3, ?4, ?5)"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, keyframe_id));
  SEMMAP_RETURN_IF_ERROR(stmt->BindText(2, kf.features_format));
  SEMMAP_RETURN_IF_ERROR(stmt->BindBlobNoCopy(3, kf.features));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(4, static_cast<int64_t>(kf.features.size())));
  SEMMAP_RETURN_IF_ERROR(stmt->BindBlob(
      5, std::string_view(reinterpret_cast<const char*>(digest.data()), digest.size())));
  return stmt->Run();
}

Status SqliteMapStore::ApplyPoseUpdate(const PoseUpdate& update) {
  {
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("UPDATE frames SET tx = ?3, ty = ?4, tz = ?5, qx = ?6, qy = ?7, qz = ?8,"
                     " qw = ?9 WHERE session_id = ?1 AND seq = ?2"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindAll(update.session_id, update.seq));
    SEMMAP_RETURN_IF_ERROR(sqlite::BindPose(*stmt, 3, update.T_world_camera));
    SEMMAP_RETURN_IF_ERROR(stmt->Run());
    if (db_->changes() == 0) return NotFoundError("no such frame");
  }
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("UPDATE keyframes SET tx = ?3, ty = ?4, tz = ?5, qx = ?6, qy = ?7, qz = ?8,"
                   " qw = ?9 WHERE session_id = ?1 AND seq = ?2"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(update.session_id, update.seq));
  SEMMAP_RETURN_IF_ERROR(sqlite::BindPose(*stmt, 3, update.T_world_camera));
  return stmt->Run();
}

Status SqliteMapStore::CullKeyframe(int64_t session_id, int64_t seq) {
  int64_t id = 0;
  {
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("SELECT id FROM keyframes WHERE session_id = ?1 AND seq = ?2"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindAll(session_id, seq));
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) return NotFoundError("no such keyframe");
    id = stmt->ColumnInt64(0);
  }
  SEMMAP_RETURN_IF_ERROR(RunWithId("UPDATE keyframes SET culled = 1 WHERE id = ?1", id));
  return RunWithId("DELETE FROM keyframe_features WHERE keyframe_id = ?1", id);
}

StatusOr<int64_t> SqliteMapStore::ResolveLinkEnd(int64_t map_id, int64_t keyframe_id,
                                                 int64_t session_id, int64_t seq, const char* end) {
  const bool by_id = keyframe_id > 0;
  if (!by_id && (session_id <= 0 || seq < 0)) {
    return InvalidArgumentError(std::string(end) +
                                " keyframe is unset: give its id or its (session_id, seq)");
  }
  const std::string name = by_id ? "keyframe id " + std::to_string(keyframe_id)
                                 : "keyframe at seq " + std::to_string(seq) + " of session " +
                                       std::to_string(session_id);
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare(by_id ? "SELECT k.id, s.map_id FROM keyframes k"
                           " JOIN sessions s ON s.id = k.session_id WHERE k.id = ?1"
                         : "SELECT k.id, s.map_id FROM keyframes k"
                           " JOIN sessions s ON s.id = k.session_id"
                           " WHERE k.session_id = ?1 AND k.seq = ?2"));
  SEMMAP_RETURN_IF_ERROR(by_id ? stmt->BindInt64(1, keyframe_id) : stmt->BindAll(session_id, seq));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) return NotFoundError(std::string(end) + " " + name + " not found");
  if (stmt->ColumnInt64(1) != map_id) {
    return InvalidArgumentError(std::string(end) + " " + name + " belongs to map id " +
                                std::to_string(stmt->ColumnInt64(1)) + ", not to map id " +
                                std::to_string(map_id));
  }
  return stmt->ColumnInt64(0);
}

Status SqliteMapStore::WriteLink(const LinkRecord& link) {
  SEMMAP_RETURN_IF_ERROR(MapName(link.map_id).status());
  if (link.kind != LinkKind::kOdometry && link.kind != LinkKind::kLoop) {
    return InvalidArgumentError("link kind " + std::to_string(static_cast<int>(link.kind)) +
                                " is unknown");
  }
  if (!link.information.allFinite()) {
    return InvalidArgumentError("information matrix is not finite");
  }
  SEMMAP_ASSIGN_OR_RETURN(int64_t from,
                          ResolveLinkEnd(link.map_id, link.from_keyframe_id, link.from_session_id,
                                         link.from_seq, "from"));
  SEMMAP_ASSIGN_OR_RETURN(int64_t to, ResolveLinkEnd(link.map_id, link.to_keyframe_id,
                                                     link.to_session_id, link.to_seq, "to"));
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("INSERT INTO links (map_id, from_kf, to_kf, kind, tx, ty, tz, qx, qy, qz, qw,"
                   " information) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(link.map_id, from, to, static_cast<int>(link.kind)));
  SEMMAP_RETURN_IF_ERROR(sqlite::BindPose(*stmt, 5, link.T_from_to));
  SEMMAP_RETURN_IF_ERROR(stmt->BindBlob(12, sqlite::EncodeInformation(link.information)));
  return stmt->Run();
}

Status SqliteMapStore::WriteBlob(const MapBlob& blob) {
  if (blob.kind.empty()) return InvalidArgumentError("blob kind is empty");
  SEMMAP_RETURN_IF_ERROR(MapName(blob.map_id).status());
  // Length and digest are checked on every read: a truncated or altered blob (disk error, manual
  // edit) is reported as DATA_LOSS instead of being handed to the OctoMap parser.
  const Sha256Digest digest = Sha256(blob.data);
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("INSERT INTO blobs (map_id, kind, data, length, sha256, updated_ns)"
                   " VALUES (?1, ?2, ?3, ?4, ?5, ?6) ON CONFLICT (map_id, kind) DO UPDATE SET"
                   " data = excluded.data, length = excluded.length, sha256 = excluded.sha256,"
                   " updated_ns = excluded.updated_ns"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(blob.map_id, blob.kind));
  SEMMAP_RETURN_IF_ERROR(stmt->BindBlobNoCopy(3, blob.data));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(4, static_cast<int64_t>(blob.data.size())));
  SEMMAP_RETURN_IF_ERROR(stmt->BindBlob(
      5, std::string_view(reinterpret_cast<const char*>(digest.data()), digest.size())));
  SEMMAP_RETURN_IF_ERROR(
      stmt->BindInt64(6, blob.updated_unix_ns > 0 ? blob.updated_unix_ns : UnixNowNs()));
  return stmt->Run();
}

Status SqliteMapStore::ReplaceMapPoints(int64_t map_id, const std::vector<MapPointRecord>& points) {
  SEMMAP_RETURN_IF_ERROR(MapName(map_id).status());
  SEMMAP_RETURN_IF_ERROR(RunWithId("DELETE FROM map_points WHERE map_id = ?1", map_id));
  for (const MapPointRecord& point : points) {
    SEMMAP_RETURN_IF_ERROR(
        WriteMapPoint(map_id, point).WithContext("map point id " + std::to_string(point.point_id)));
  }
  return OkStatus();
}

Status SqliteMapStore::WriteMapPoint(int64_t map_id, const MapPointRecord& point) {
  // SQLite would store NaN as NULL, which NOT NULL refuses with a vaguer message.
  if (!point.position_world.allFinite()) return InvalidArgumentError("position is not finite");
  SEMMAP_ASSIGN_OR_RETURN(std::string observations,
                          sqlite::EncodeMapPointObservations(point.observations));
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("INSERT INTO map_points (map_id, point_id, session_id, x, y, z, observations)"
                   " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)"));
  const Eigen::Vector3d& p = point.position_world;
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(map_id, point.point_id, point.session_id, p.x(), p.y(),
                                       p.z(), sqlite::Blob{observations}));
  Status inserted = stmt->Run();
  if (inserted.code() == StatusCode::kAlreadyExists) {
    return InvalidArgumentError("the point id appears twice in the map's points");
  }
  return inserted;
}

Status SqliteMapStore::DropSessionFromMapPoints(int64_t map_id, int64_t session_id) {
  // The points to rewrite are collected first: the SELECT finishes before its rows change.
  std::vector<std::pair<int64_t, std::vector<MapPointObservationRecord>>> changed;
  {
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("SELECT point_id, observations FROM map_points WHERE map_id = ?1"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, map_id));
    for (;;) {
      SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
      if (!row) break;
      StatusOr<std::vector<MapPointObservationRecord>> observations =
          sqlite::DecodeMapPointObservations(stmt->ColumnBlob(1));
      if (!observations.ok()) continue;  // corrupt: ListMapPoints keeps reporting it
      if (std::erase_if(*observations, [session_id](const MapPointObservationRecord& o) {
            return o.session_id == session_id;
          }) > 0) {
        changed.emplace_back(stmt->ColumnInt64(0), std::move(observations).value());
      }
    }
  }
  for (const auto& [point_id, observations] : changed) {
    SEMMAP_RETURN_IF_ERROR(RewriteMapPointObservations(map_id, point_id, observations));
  }
  return OkStatus();
}

Status SqliteMapStore::RewriteMapPointObservations(
    int64_t map_id, int64_t point_id, const std::vector<MapPointObservationRecord>& observations) {
  if (observations.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("DELETE FROM map_points WHERE map_id = ?1 AND point_id = ?2"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindAll(map_id, point_id));
    return stmt->Run();
  }
  SEMMAP_ASSIGN_OR_RETURN(std::string bytes, sqlite::EncodeMapPointObservations(observations));
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("UPDATE map_points SET observations = ?3 WHERE map_id = ?1 AND point_id = ?2"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(map_id, point_id, sqlite::Blob{bytes}));
  return stmt->Run();
}

Status SqliteMapStore::UpdateKeyframePoses(
    const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& T_world_keyframe) {
  if (T_world_keyframe.empty()) return OkStatus();
  SEMMAP_ASSIGN_OR_RETURN(sqlite::Transaction transaction, sqlite::Transaction::Begin(*db_));
  for (const auto& [id, T] : T_world_keyframe) {
    {
      SEMMAP_ASSIGN_OR_RETURN(
          StatementLease stmt,
          db_->Prepare("UPDATE keyframes SET tx = ?2, ty = ?3, tz = ?4, qx = ?5, qy = ?6,"
                       " qz = ?7, qw = ?8 WHERE id = ?1"));
      SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, id));
      SEMMAP_RETURN_IF_ERROR(
          sqlite::BindPose(*stmt, 2, T).WithContext("keyframe id " + std::to_string(id)));
      SEMMAP_RETURN_IF_ERROR(stmt->Run());
      if (db_->changes() == 0) {
        return NotFoundError("keyframe id " + std::to_string(id) + " not found");
      }
    }
    // The keyframe's frame row carries the same pose, so trajectories agree with keyframes.
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("UPDATE frames SET tx = ?2, ty = ?3, tz = ?4, qx = ?5, qy = ?6, qz = ?7,"
                     " qw = ?8 WHERE (session_id, seq) ="
                     " (SELECT session_id, seq FROM keyframes WHERE id = ?1)"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, id));
    SEMMAP_RETURN_IF_ERROR(sqlite::BindPose(*stmt, 2, T));
    SEMMAP_RETURN_IF_ERROR(stmt->Run());
  }
  return transaction.Commit();
}

}  // namespace semmap
