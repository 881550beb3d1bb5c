// SqliteMapStore: object types with their views, observations and fused instances (schema v3).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>

#include "common/time_util.h"
#include "storage/sqlite/row_codec.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "storage/sqlite/transaction.h"

namespace semmap {

using sqlite::StatementLease;

namespace {

// ValidateName's rules (common/name_validation.h), repeated here because the server
// library depends on storage: labels the service accepts are exactly the ones stored.
Status ValidateLabel(const std::string& label) {
  if (label.empty()) return InvalidArgumentError("object type label is empty");
  if (label.size() > 128) return InvalidArgumentError("object type label is longer than 128 bytes");
  for (unsigned char c : label) {
    if (c < 0x20 || c == 0x7f || c == '/') {
      return InvalidArgumentError("object type label '" + label +
                                  "' contains a control character or '/'");
    }
  }
  if (label.front() == ' ' || label.back() == ' ') {
    return InvalidArgumentError("object type label '" + label + "' has leading or trailing spaces");
  }
  return OkStatus();
}

Status ValidateView(const ObjectView& view) {
  if (view.image.empty()) return InvalidArgumentError("image is empty");
  if (view.features.empty()) return InvalidArgumentError("features are empty");
  if (view.features_format.empty()) return InvalidArgumentError("features have no format");
  if (view.width < 0 || view.height < 0) return InvalidArgumentError("size is negative");
  return OkStatus();
}

// "global object type 'laptop'", "object type 'laptop' of map 'lab'".
std::string TypeName(const std::string& label, const std::optional<int64_t>& map_id,
                     const std::string& map_name) {
  if (!map_id) return "global object type '" + label + "'";
  return "object type '" + label + "' of map '" + map_name + "'";
}

Status BindScope(sqlite::Statement& stmt, int index, const std::optional<int64_t>& map_id) {
  return map_id ? stmt.BindInt64(index, *map_id) : stmt.BindNull(index);
}

// Sorted, without repeats: "3,5".
std::string EncodeSessionIds(std::vector<int64_t> ids) {
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::string text;
  for (int64_t id : ids) {
    if (!text.empty()) text += ',';
    text += std::to_string(id);
  }
  return text;
}

StatusOr<std::vector<int64_t>> DecodeSessionIds(const std::string& text) {
  std::vector<int64_t> ids;
  if (text.empty()) return ids;
  const char* p = text.data();
  const char* end = p + text.size();
  for (;;) {
    int64_t id = 0;
    auto [next, ec] = std::from_chars(p, end, id);
    if (ec != std::errc() || next == p) break;
    ids.push_back(id);
    if (next == end) return ids;
    if (*next != ',') break;
    p = next + 1;
  }
  return DataLossError("session ids '" + text + "' are malformed");
}

Status ValidateInstance(const ObjectInstance& instance) {
  if (!instance.position.allFinite()) return InvalidArgumentError("position is not finite");
  if (!instance.extent.allFinite() || (instance.extent.array() < 0).any()) {
    return InvalidArgumentError("extent is negative or not finite");
  }
  // Written as a negation so NaN is refused too.
  if (!(instance.confidence >= 0 && instance.confidence <= 1)) {
    return InvalidArgumentError("confidence " + std::to_string(instance.confidence) +
                                " is outside [0, 1]");
  }
  if (instance.observations < 0) return InvalidArgumentError("observation count is negative");
  return OkStatus();
}

// Columns 0..15 of the instance queries below.
constexpr char kInstanceColumns[] =
    "SELECT i.id, i.map_id, m.name, i.type_id, i.label, i.x, i.y, i.z, i.ex, i.ey, i.ez,"
    " i.confidence, i.observations, i.session_ids, i.first_seen_ns, i.last_seen_ns";

StatusOr<std::vector<ObjectInstance>> ReadInstanceRows(sqlite::Statement& stmt) {
  std::vector<ObjectInstance> instances;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    ObjectInstance& o = instances.emplace_back();
    o.id = stmt.ColumnInt64(0);
    o.map_id = stmt.ColumnInt64(1);
    o.map_name = stmt.ColumnText(2);
    o.type_id = stmt.ColumnInt64(3);
    o.label = stmt.ColumnText(4);
    o.position = Eigen::Vector3d(stmt.ColumnDouble(5), stmt.ColumnDouble(6), stmt.ColumnDouble(7));
    o.extent = Eigen::Vector3d(stmt.ColumnDouble(8), stmt.ColumnDouble(9), stmt.ColumnDouble(10));
    o.confidence = stmt.ColumnDouble(11);
    o.observations = static_cast<int>(stmt.ColumnInt64(12));
    StatusOr<std::vector<int64_t>> sessions = DecodeSessionIds(stmt.ColumnText(13));
    if (!sessions.ok()) {
      return sessions.status().WithContext("object instance id " + std::to_string(o.id));
    }
    o.session_ids = std::move(sessions).value();
    o.first_seen_ns = stmt.ColumnInt64(14);
    o.last_seen_ns = stmt.ColumnInt64(15);
  }
  return instances;
}

}  // namespace

// --- types ---

StatusOr<ObjectType> SqliteMapStore::CreateObjectType(const ObjectType& type) {
  SEMMAP_RETURN_IF_ERROR(ValidateLabel(type.label));
  if (type.views.empty()) {
    return InvalidArgumentError("object type '" + type.label + "' has no views");
  }
  for (size_t i = 0; i < type.views.size(); ++i) {
    SEMMAP_RETURN_IF_ERROR(
        ValidateView(type.views[i])
            .WithContext("view " + std::to_string(i) + " of object type '" + type.label + "'"));
  }
  ObjectType created = type;
  created.map_name.clear();
  if (created.created_unix_ns == 0) created.created_unix_ns = UnixNowNs();

  SEMMAP_ASSIGN_OR_RETURN(sqlite::Transaction transaction, sqlite::Transaction::Begin(*db_));
  if (created.map_id) {
    SEMMAP_ASSIGN_OR_RETURN(created.map_name, MapName(*created.map_id));
  }
  {
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("INSERT INTO object_types (label, map_id, r, g, b, created_ns)"
                     " VALUES (?1, ?2, ?3, ?4, ?5, ?6)"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindText(1, created.label));
    SEMMAP_RETURN_IF_ERROR(BindScope(*stmt, 2, created.map_id));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(3, created.rgb[0]));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(4, created.rgb[1]));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(5, created.rgb[2]));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(6, created.created_unix_ns));
    Status inserted = stmt->Run();
    if (inserted.code() == StatusCode::kAlreadyExists) {
      return AlreadyExistsError(TypeName(created.label, created.map_id, created.map_name) +
                                " already exists");
    }
    SEMMAP_RETURN_IF_ERROR(inserted);
  }
  created.id = db_->last_insert_rowid();
  for (ObjectView& view : created.views) {
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("INSERT INTO object_views (type_id, image_format, image, width, height,"
                     " features_format, features, features_length, features_sha256)"
                     " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, created.id));
    SEMMAP_RETURN_IF_ERROR(stmt->BindText(2, view.image.format));
    // `created` outlives the statement's use: no copy of the photo and its features.
    SEMMAP_RETURN_IF_ERROR(stmt->BindBlobNoCopy(3, view.image.bytes));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(4, view.width));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(5, view.height));
    SEMMAP_RETURN_IF_ERROR(stmt->BindText(6, view.features_format));
    SEMMAP_RETURN_IF_ERROR(stmt->BindBlobNoCopy(7, view.features));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(8, static_cast<int64_t>(view.features.size())));
    SEMMAP_RETURN_IF_ERROR(stmt->BindBlob(9, sqlite::Sha256Bytes(view.features)));
    SEMMAP_RETURN_IF_ERROR(stmt->Run());
    view.id = db_->last_insert_rowid();
  }
  SEMMAP_RETURN_IF_ERROR(transaction.Commit());
  return created;
}

Status SqliteMapStore::ReadObjectViews(ObjectType& type) {
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("SELECT id, image_format, image, width, height, features_format, features,"
                   " features_length, features_sha256 FROM object_views WHERE type_id = ?1"
                   " ORDER BY id"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, type.id));
  type.views.clear();
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    ObjectView& view = type.views.emplace_back();
    view.id = stmt->ColumnInt64(0);
    view.image.format = stmt->ColumnText(1);
    view.image.bytes = stmt->ColumnBlob(2);
    view.width = static_cast<int>(stmt->ColumnInt64(3));
    view.height = static_cast<int>(stmt->ColumnInt64(4));
    view.features_format = stmt->ColumnText(5);
    view.features = stmt->ColumnBlob(6);
    SEMMAP_RETURN_IF_ERROR(sqlite::VerifyChecksummed(
        "features of view id " + std::to_string(view.id) + " of object type '" + type.label + "'",
        view.features, stmt->ColumnInt64(7), stmt->ColumnBlob(8)));
  }
  return OkStatus();
}

StatusOr<std::vector<ObjectType>> SqliteMapStore::ListObjectTypes(std::optional<int64_t> map_id,
                                                                  bool with_views) {
  if (map_id) SEMMAP_RETURN_IF_ERROR(MapName(*map_id).status());
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare(std::string("SELECT t.id, t.label, t.map_id, m.name, t.r, t.g, t.b, t.created_ns"
                               " FROM object_types t LEFT JOIN maps m ON m.id = t.map_id") +
                   (map_id ? " WHERE t.map_id IS NULL OR t.map_id = ?1" : "") +
                   " ORDER BY t.label, t.map_id IS NOT NULL, m.name"));
  if (map_id) SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, *map_id));
  std::vector<ObjectType> types;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    ObjectType& type = types.emplace_back();
    type.id = stmt->ColumnInt64(0);
    type.label = stmt->ColumnText(1);
    if (!stmt->ColumnIsNull(2)) {
      type.map_id = stmt->ColumnInt64(2);
      type.map_name = stmt->ColumnText(3);
    }
    // The CHECKs keep the colour components bytes.
    for (int c = 0; c < 3; ++c) type.rgb[c] = static_cast<uint8_t>(stmt->ColumnInt64(4 + c));
    type.created_unix_ns = stmt->ColumnInt64(7);
  }
  if (with_views) {
    for (ObjectType& type : types) SEMMAP_RETURN_IF_ERROR(ReadObjectViews(type));
  }
  return types;
}

Status SqliteMapStore::RemoveObjectType(const std::string& label, std::optional<int64_t> map_id) {
  std::string map_name;
  if (map_id) {
    SEMMAP_ASSIGN_OR_RETURN(map_name, MapName(*map_id));
  }
  // Views, observations and instances go by cascade; the instances' R*Tree rows by trigger.
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("DELETE FROM object_types WHERE label = ?1 AND ifnull(map_id, 0) = ?2"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(label, map_id.value_or(0)));
  SEMMAP_RETURN_IF_ERROR(stmt->Run());
  if (db_->changes() == 0) {
    return NotFoundError(TypeName(label, map_id, map_name) + " not found");
  }
  return OkStatus();
}

StatusOr<std::string> SqliteMapStore::TypeLabelInMap(int64_t type_id, int64_t map_id) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                          db_->Prepare("SELECT label, map_id FROM object_types WHERE id = ?1"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, type_id));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) return NotFoundError("object type id " + std::to_string(type_id) + " not found");
  std::string label = stmt->ColumnText(0);
  if (!stmt->ColumnIsNull(1) && stmt->ColumnInt64(1) != map_id) {
    return InvalidArgumentError("object type '" + label + "' belongs to map id " +
                                std::to_string(stmt->ColumnInt64(1)) + ", not to map id " +
                                std::to_string(map_id));
  }
  return label;
}

// --- observations ---

Status SqliteMapStore::WriteObservation(const ObjectObservation& o) {
  SEMMAP_RETURN_IF_ERROR(MapName(o.map_id).status());
  SEMMAP_RETURN_IF_ERROR(TypeLabelInMap(o.type_id, o.map_id).status());
  if (!o.p_keyframe.allFinite() || !o.extent.allFinite() || !std::isfinite(o.xi)) {
    return InvalidArgumentError("position, extent or xi is not finite");
  }
  if (o.matches < 0 || o.inliers < 0) return InvalidArgumentError("match count is negative");
  SEMMAP_ASSIGN_OR_RETURN(int64_t keyframe_id,
                          ResolveLinkEnd(o.map_id, o.keyframe_id, o.session_id, o.seq, "observed"));
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("INSERT INTO object_observations (map_id, type_id, keyframe_id, px, py, pz,"
                   " ex, ey, ez, matches, inliers, xi, stamp_ns)"
                   " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13)"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindAll(
      o.map_id, o.type_id, keyframe_id, o.p_keyframe.x(), o.p_keyframe.y(), o.p_keyframe.z(),
      o.extent.x(), o.extent.y(), o.extent.z(), o.matches, o.inliers, o.xi, o.stamp_ns));
  return stmt->Run();
}

StatusOr<std::vector<ObjectObservation>> SqliteMapStore::ListObjectObservations(int64_t map_id) {
  SEMMAP_RETURN_IF_ERROR(MapName(map_id).status());
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare("SELECT o.id, o.map_id, o.type_id, t.label, o.keyframe_id, k.session_id, k.seq,"
                   " o.px, o.py, o.pz, o.ex, o.ey, o.ez, o.matches, o.inliers, o.xi, o.stamp_ns"
                   " FROM object_observations o JOIN object_types t ON t.id = o.type_id"
                   " JOIN keyframes k ON k.id = o.keyframe_id"
                   " WHERE o.map_id = ?1 ORDER BY o.keyframe_id, o.id"));
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, map_id));
  std::vector<ObjectObservation> observations;
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
    if (!row) break;
    ObjectObservation& o = observations.emplace_back();
    o.id = stmt->ColumnInt64(0);
    o.map_id = stmt->ColumnInt64(1);
    o.type_id = stmt->ColumnInt64(2);
    o.label = stmt->ColumnText(3);
    o.keyframe_id = stmt->ColumnInt64(4);
    o.session_id = stmt->ColumnInt64(5);
    o.seq = stmt->ColumnInt64(6);
    o.p_keyframe =
        Eigen::Vector3d(stmt->ColumnDouble(7), stmt->ColumnDouble(8), stmt->ColumnDouble(9));
    o.extent =
        Eigen::Vector3d(stmt->ColumnDouble(10), stmt->ColumnDouble(11), stmt->ColumnDouble(12));
    o.matches = static_cast<int>(stmt->ColumnInt64(13));
    o.inliers = static_cast<int>(stmt->ColumnInt64(14));
    o.xi = stmt->ColumnDouble(15);
    o.stamp_ns = stmt->ColumnInt64(16);
  }
  return observations;
}

// --- instances ---

Status SqliteMapStore::ReplaceInstances(int64_t map_id,
                                        const std::vector<ObjectInstance>& instances) {
  SEMMAP_RETURN_IF_ERROR(MapName(map_id).status());
  {
    // The delete trigger drops their R*Tree rows in the same transaction.
    SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                            db_->Prepare("DELETE FROM object_instances WHERE map_id = ?1"));
    SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, map_id));
    SEMMAP_RETURN_IF_ERROR(stmt->Run());
  }
  std::vector<int64_t> checked_sessions;  // each checked once per replacement
  for (size_t i = 0; i < instances.size(); ++i) {
    const ObjectInstance& instance = instances[i];
    const std::string context = "instance " + std::to_string(i);
    if (instance.map_id != 0 && instance.map_id != map_id) {
      return InvalidArgumentError(context + " names map id " + std::to_string(instance.map_id));
    }
    SEMMAP_RETURN_IF_ERROR(ValidateInstance(instance).WithContext(context));
    StatusOr<std::string> label = TypeLabelInMap(instance.type_id, map_id);
    if (!label.ok()) return label.status().WithContext(context);
    if (!instance.label.empty() && instance.label != *label) {
      return InvalidArgumentError(context + " is labelled '" + instance.label +
                                  "' but its type is '" + *label + "'");
    }
    for (int64_t session_id : instance.session_ids) {
      if (std::find(checked_sessions.begin(), checked_sessions.end(), session_id) !=
          checked_sessions.end()) {
        continue;
      }
      SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                              db_->Prepare("SELECT map_id FROM sessions WHERE id = ?1"));
      SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, session_id));
      SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
      if (!row) {
        return NotFoundError(context + ": session id " + std::to_string(session_id) + " not found");
      }
      if (stmt->ColumnInt64(0) != map_id) {
        return InvalidArgumentError(context + ": session id " + std::to_string(session_id) +
                                    " belongs to map id " + std::to_string(stmt->ColumnInt64(0)));
      }
      checked_sessions.push_back(session_id);
    }
    // The insert trigger adds the instance's R*Tree point box.
    SEMMAP_ASSIGN_OR_RETURN(
        StatementLease stmt,
        db_->Prepare("INSERT INTO object_instances (map_id, type_id, label, x, y, z, ex, ey, ez,"
                     " confidence, observations, session_ids, first_seen_ns, last_seen_ns)"
                     " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)"));
    const Eigen::Vector3d& p = instance.position;
    const Eigen::Vector3d& e = instance.extent;
    SEMMAP_RETURN_IF_ERROR(stmt->BindAll(
        map_id, instance.type_id, *label, p.x(), p.y(), p.z(), e.x(), e.y(), e.z(),
        instance.confidence, instance.observations, EncodeSessionIds(instance.session_ids),
        instance.first_seen_ns, instance.last_seen_ns));
    SEMMAP_RETURN_IF_ERROR(stmt->Run());
  }
  return OkStatus();
}

Status SqliteMapStore::FillSessionNames(std::vector<ObjectInstance>& instances) {
  std::map<int64_t, std::optional<std::string>> names;  // a few sessions per map
  for (ObjectInstance& instance : instances) {
    std::vector<int64_t> ids;
    instance.sessions.clear();
    for (int64_t id : instance.session_ids) {
      auto it = names.find(id);
      if (it == names.end()) {
        SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt,
                                db_->Prepare("SELECT name FROM sessions WHERE id = ?1"));
        SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, id));
        SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
        it = names.emplace(id, row ? std::optional(stmt->ColumnText(0)) : std::nullopt).first;
      }
      if (!it->second) continue;
      ids.push_back(id);
      instance.sessions.push_back(*it->second);
    }
    instance.session_ids = std::move(ids);
  }
  return OkStatus();
}

StatusOr<std::vector<ObjectInstance>> SqliteMapStore::FindObjectInstances(
    std::optional<int64_t> map_id, const std::string& label) {
  if (map_id) SEMMAP_RETURN_IF_ERROR(MapName(*map_id).status());
  std::string where;
  if (map_id) where = " WHERE i.map_id = ?1";
  if (!label.empty()) where += (where.empty() ? " WHERE" : " AND") + std::string(" i.label = ?2");
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare(std::string(kInstanceColumns) +
                   " FROM object_instances i JOIN maps m ON m.id = i.map_id" + where +
                   " ORDER BY m.name, i.label, i.confidence DESC, i.id"));
  if (map_id) SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(1, *map_id));
  if (!label.empty()) SEMMAP_RETURN_IF_ERROR(stmt->BindText(2, label));
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectInstance> instances, ReadInstanceRows(*stmt));
  SEMMAP_RETURN_IF_ERROR(FillSessionNames(instances));
  return instances;
}

StatusOr<std::vector<ObjectInstance>> SqliteMapStore::ObjectInstancesNear(
    int64_t map_id, const Eigen::Vector3d& centre, double radius_m, const std::string& label) {
  if (!centre.allFinite()) return InvalidArgumentError("query centre is not finite");
  // Written as a negation so NaN is refused too.
  if (!(radius_m >= 0) || !std::isfinite(radius_m)) {
    return InvalidArgumentError("query radius must be finite and not negative");
  }
  SEMMAP_RETURN_IF_ERROR(MapName(map_id).status());
  // The R*Tree keeps 32-bit boxes rounded outwards, so the cube around the sphere finds every
  // candidate; the exact distance below (from the REAL columns) decides. CROSS JOIN keeps the
  // R*Tree search as the outer loop: left to itself the planner prefers object_instances_by_map
  // and would scan the whole map, probing the R*Tree by id.
  SEMMAP_ASSIGN_OR_RETURN(
      StatementLease stmt,
      db_->Prepare(std::string(kInstanceColumns) +
                   " FROM object_instances_rtree r CROSS JOIN object_instances i ON i.id = r.id"
                   " JOIN maps m ON m.id = i.map_id"
                   " WHERE r.max_x >= ?1 AND r.min_x <= ?2 AND r.max_y >= ?3 AND r.min_y <= ?4"
                   " AND r.max_z >= ?5 AND r.min_z <= ?6 AND i.map_id = ?7" +
                   (label.empty() ? "" : " AND i.label = ?8")));
  for (int axis = 0; axis < 3; ++axis) {
    SEMMAP_RETURN_IF_ERROR(stmt->BindDouble(1 + 2 * axis, centre[axis] - radius_m));
    SEMMAP_RETURN_IF_ERROR(stmt->BindDouble(2 + 2 * axis, centre[axis] + radius_m));
  }
  SEMMAP_RETURN_IF_ERROR(stmt->BindInt64(7, map_id));
  if (!label.empty()) SEMMAP_RETURN_IF_ERROR(stmt->BindText(8, label));
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectInstance> candidates, ReadInstanceRows(*stmt));
  std::vector<ObjectInstance> near;
  for (ObjectInstance& instance : candidates) {
    instance.distance_m = (instance.position - centre).norm();
    if (instance.distance_m <= radius_m) near.push_back(std::move(instance));
  }
  std::sort(near.begin(), near.end(), [](const ObjectInstance& a, const ObjectInstance& b) {
    return a.distance_m != b.distance_m ? a.distance_m < b.distance_m : a.id < b.id;
  });
  SEMMAP_RETURN_IF_ERROR(FillSessionNames(near));
  return near;
}

}  // namespace semmap
