// SqliteMapStore: trajectory, keyframe, link, map point and blob reads.
#include <algorithm>

#include "storage/sqlite/map_point_codec.h"
#include "storage/sqlite/row_codec.h"
#include "storage/sqlite/sqlite_map_store.h"

namespace semmap {

using sqlite::StatementLease;

StatusOr<std::vector<TrajectoryPose>> SqliteMapStore::GetTrajectory(int64_t session_id,
                                                                    bool keyframes_only) {
  SEMMAP_RETURN_IF_ERROR(RequireSession(session_id));
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare(keyframes_only
                       ? "SELECT seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw, is_keyframe, lost"
                         " FROM frames WHERE session_id = ?1 AND is_keyframe = 1 ORDER BY seq"
                       : "SELECT seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw, is_keyframe, lost"
                         " FROM frames WHERE session_id = ?1 ORDER BY seq"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, session_id));
  std::vector<TrajectoryPose> poses;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    TrajectoryPose& p = poses.emplace_back();
    p.seq = stmt->ColumnInt64(0);
    p.stamp_ns = stmt->ColumnInt64(1);
    p.T_world_camera = sqlite::ReadPose(*stmt, 2);
    p.is_keyframe = stmt->ColumnInt64(9) != 0;
    p.lost = stmt->ColumnInt64(10) != 0;
  }
  return poses;
}

namespace {

// Columns 0..14 of the keyframe queries below; 15 and 16 are the image bytes when selected.
KeyframeRecord KeyframeFromRow(const sqlite::Statement& stmt, bool with_images) {
  KeyframeRecord kf;
  kf.id = stmt.ColumnInt64(0);
  kf.session_id = stmt.ColumnInt64(1);
  kf.seq = stmt.ColumnInt64(2);
  kf.stamp_ns = stmt.ColumnInt64(3);
  kf.T_world_camera = sqlite::ReadPose(stmt, 4);
  kf.colour.format = stmt.ColumnText(11);
  kf.depth.format = stmt.ColumnText(12);
  kf.depth_scale = stmt.ColumnDouble(13);
  kf.culled = stmt.ColumnInt64(14) != 0;
  if (with_images) {
    kf.colour.bytes = stmt.ColumnBlob(15);
    kf.depth.bytes = stmt.ColumnBlob(16);
  }
  return kf;
}

}  // namespace

StatusOr<KeyframeRecord> SqliteMapStore::GetKeyframe(int64_t keyframe_id) {
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("SELECT id, session_id, seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw,"
                   " colour_format, depth_format, depth_scale, culled, colour, depth"
                   " FROM keyframes WHERE id = ?1"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, keyframe_id));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) return NotFoundError("keyframe id " + std::to_string(keyframe_id) + " not found");
  KeyframeRecord kf = KeyframeFromRow(*stmt, /*with_images=*/true);
  SEMMAP_RETURN_IF_ERROR(ReadKeyframeFeatures(kf));
  return kf;
}

Status SqliteMapStore::ReadKeyframeFeatures(KeyframeRecord& kf) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                          db_->Prepare("SELECT format, data, length, sha256 FROM keyframe_features"
                                       " WHERE keyframe_id = ?1"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, kf.id));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) return OkStatus();  // a keyframe without features (e.g. KNOWN_POSES)
  std::string data = stmt->ColumnBlob(1);
  SEMMAP_RETURN_IF_ERROR(
      sqlite::VerifyChecksummed("features of keyframe id " + std::to_string(kf.id), data,
                                stmt->ColumnInt64(2), stmt->ColumnBlob(3)));
  kf.features_format = stmt->ColumnText(0);
  kf.features = std::move(data);
  return OkStatus();
}

StatusOr<std::vector<KeyframeRecord>> SqliteMapStore::ListKeyframes(int64_t session_id,
                                                                    bool with_images) {
  SEMMAP_RETURN_IF_ERROR(RequireSession(session_id));
  // Without images the blobs are not even read from disk.
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare(with_images ? "SELECT id, session_id, seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw,"
                                 " colour_format, depth_format, depth_scale, culled, colour, depth"
                                 " FROM keyframes WHERE session_id = ?1 ORDER BY seq"
                               : "SELECT id, session_id, seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw,"
                                 " colour_format, depth_format, depth_scale, culled"
                                 " FROM keyframes WHERE session_id = ?1 ORDER BY seq"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, session_id));
  std::vector<KeyframeRecord> keyframes;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    keyframes.push_back(KeyframeFromRow(*stmt, with_images));
  }
  if (with_images) {
    for (KeyframeRecord& kf : keyframes) SEMMAP_RETURN_IF_ERROR(ReadKeyframeFeatures(kf));
  }
  return keyframes;
}

StatusOr<std::vector<KeyframeRecord>> SqliteMapStore::ListKeyframeFeatures(int64_t session_id) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> keyframes,
                          ListKeyframes(session_id, /*with_images=*/false));
  for (KeyframeRecord& kf : keyframes) SEMMAP_RETURN_IF_ERROR(ReadKeyframeFeatures(kf));
  return keyframes;
}

StatusOr<KeyframeRecord> SqliteMapStore::GetKeyframeFeatures(int64_t session_id, int64_t seq) {
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("SELECT id, session_id, seq, stamp_ns, tx, ty, tz, qx, qy, qz, qw,"
                   " colour_format, depth_format, depth_scale, culled"
                   " FROM keyframes WHERE session_id = ?1 AND seq = ?2"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, session_id));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(2, seq));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) {
    return NotFoundError("session id " + std::to_string(session_id) + " has no keyframe seq " +
                         std::to_string(seq));
  }
  KeyframeRecord kf = KeyframeFromRow(*stmt, /*with_images=*/false);
  SEMMAP_RETURN_IF_ERROR(ReadKeyframeFeatures(kf));
  return kf;
}

StatusOr<std::vector<LinkRecord>> SqliteMapStore::ListLinks(int64_t map_id) {
  SEMMAP_RETURN_IF_ERROR(MapName(map_id).status());
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("SELECT l.id, l.map_id, l.from_kf, l.to_kf, l.kind,"
                   " l.tx, l.ty, l.tz, l.qx, l.qy, l.qz, l.qw, l.information,"
                   " f.session_id, f.seq, t.session_id, t.seq FROM links l"
                   " JOIN keyframes f ON f.id = l.from_kf JOIN keyframes t ON t.id = l.to_kf"
                   " WHERE l.map_id = ?1 ORDER BY l.id"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, map_id));
  std::vector<LinkRecord> links;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    LinkRecord& link = links.emplace_back();
    link.id = stmt->ColumnInt64(0);
    link.map_id = stmt->ColumnInt64(1);
    link.from_keyframe_id = stmt->ColumnInt64(2);
    link.to_keyframe_id = stmt->ColumnInt64(3);
    link.kind = static_cast<LinkKind>(stmt->ColumnInt64(4));  // CHECK keeps it a known value
    link.T_from_to = sqlite::ReadPose(*stmt, 5);
    StatusOr<sqlite::InformationMatrix> information =
        sqlite::DecodeInformation(stmt->ColumnBlob(12));
    if (!information.ok()) {
      return information.status().WithContext("link id " + std::to_string(link.id));
    }
    link.information = *information;
    link.from_session_id = stmt->ColumnInt64(13);
    link.from_seq = stmt->ColumnInt64(14);
    link.to_session_id = stmt->ColumnInt64(15);
    link.to_seq = stmt->ColumnInt64(16);
  }
  return links;
}

StatusOr<SqliteMapStore::KeyframeKeys> SqliteMapStore::StoredKeyframeKeys(int64_t map_id) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                          db_->Prepare("SELECT k.session_id, k.seq FROM keyframes k"
                                       " JOIN sessions s ON s.id = k.session_id WHERE s.map_id = ?1"
                                       " ORDER BY k.session_id, k.seq"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, map_id));
  KeyframeKeys keys;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    keys.emplace_back(stmt->ColumnInt64(0), stmt->ColumnInt64(1));
  }
  return keys;
}

namespace {

// Columns point_id, session_id, x, y, z, observations of the query in ListMapPoints.
StatusOr<MapPointRecord> MapPointFromRow(const sqlite::Statement& stmt, int64_t map_id) {
  MapPointRecord point;
  point.point_id = stmt.ColumnInt64(0);
  point.session_id = stmt.ColumnInt64(1);
  point.position_world =
      Eigen::Vector3d(stmt.ColumnDouble(2), stmt.ColumnDouble(3), stmt.ColumnDouble(4));
  StatusOr<std::vector<MapPointObservationRecord>> observations =
      sqlite::DecodeMapPointObservations(stmt.ColumnBlob(5));
  if (!observations.ok()) {
    return observations.status().WithContext("map point id " + std::to_string(point.point_id) +
                                             " of map id " + std::to_string(map_id));
  }
  point.observations = std::move(observations).value();
  return point;
}

// Observations name keyframes by (session_id, seq), not by foreign key, so those of a removed
// session (or of keyframes never stored) are still in the blob: they are dropped here.
void DropUnstoredObservations(std::vector<MapPointObservationRecord>& observations,
                              const std::vector<std::pair<int64_t, int64_t>>& stored_keys) {
  std::erase_if(observations, [&](const MapPointObservationRecord& o) {
    return !std::binary_search(stored_keys.begin(), stored_keys.end(),
                               std::make_pair(o.session_id, o.seq));
  });
}

}  // namespace

StatusOr<std::vector<MapPointRecord>> SqliteMapStore::ListMapPoints(int64_t map_id) {
  SEMMAP_RETURN_IF_ERROR(MapName(map_id).status());
  SEMMAP_ASSIGN_OR_RETURN(const KeyframeKeys stored_keys, StoredKeyframeKeys(map_id));
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("SELECT point_id, session_id, x, y, z, observations FROM map_points"
                   " WHERE map_id = ?1 ORDER BY point_id"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, map_id));
  std::vector<MapPointRecord> points;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    SEMMAP_ASSIGN_OR_RETURN(MapPointRecord point, MapPointFromRow(*stmt, map_id));
    DropUnstoredObservations(point.observations, stored_keys);
    if (!point.observations.empty()) points.push_back(std::move(point));
  }
  return points;
}

StatusOr<MapBlob> SqliteMapStore::GetBlob(int64_t map_id, const std::string& kind) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                          db_->Prepare("SELECT data, length, sha256, updated_ns FROM blobs"
                                       " WHERE map_id = ?1 AND kind = ?2"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(map_id, kind));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  const std::string name = "map blob '" + kind + "' of map id " + std::to_string(map_id);
  if (!row) return NotFoundError(name + " not found");
  MapBlob blob;
  blob.map_id = map_id;
  blob.kind = kind;
  blob.data = stmt->ColumnBlob(0);
  blob.updated_unix_ns = stmt->ColumnInt64(3);
  SEMMAP_RETURN_IF_ERROR(
      sqlite::VerifyChecksummed(name, blob.data, stmt->ColumnInt64(1), stmt->ColumnBlob(2)));
  return blob;
}

}  // namespace semmap
