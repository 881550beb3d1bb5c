#include "core/query/store_map_query.h"

#include <cmath>
#include <optional>
#include <string>

#include "core/query/map_export.h"

namespace semmap {

StatusOr<std::vector<MapInfo>> StoreMapQuery::ListMaps() {
  MutexLock lock(mutex_);
  return store_->ListMaps();
}

StatusOr<std::vector<SessionInfo>> StoreMapQuery::ListSessions(const std::string& map) {
  MutexLock lock(mutex_);
  return store_->ListSessions(map);
}

StatusOr<std::vector<TrajectoryPose>> StoreMapQuery::GetTrajectory(const std::string& map,
                                                                   const std::string& session,
                                                                   bool keyframes_only) {
  if (map.empty() || session.empty()) {
    return InvalidArgumentError("a trajectory query needs both a map and a session name");
  }
  MutexLock lock(mutex_);
  SEMMAP_ASSIGN_OR_RETURN(SessionInfo info, store_->GetSession(map, session));
  return store_->GetTrajectory(info.id, keyframes_only);
}

StatusOr<ExportResult> StoreMapQuery::ExportMap(const ExportRequest& request) {
  MutexLock lock(mutex_);
  return BuildExport(*store_, request, layers_);
}

StatusOr<std::vector<ObjectType>> StoreMapQuery::ListObjectTypes(const std::string& map) {
  MutexLock lock(mutex_);
  std::optional<int64_t> map_id;
  if (!map.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(MapInfo info, store_->GetMap(map));
    map_id = info.id;
  }
  // With views for their count; the photos and features stay on the server.
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectType> types,
                          store_->ListObjectTypes(map_id, /*with_views=*/true));
  for (ObjectType& type : types) {
    for (ObjectView& view : type.views) {
      view.image = {};
      view.features.clear();
    }
  }
  return types;
}

StatusOr<std::vector<ObjectInstance>> StoreMapQuery::FindObjects(const std::string& label,
                                                                 const std::string& map) {
  MutexLock lock(mutex_);
  std::optional<int64_t> map_id;
  if (!map.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(MapInfo info, store_->GetMap(map));
    map_id = info.id;
  }
  return store_->FindObjectInstances(map_id, label);
}

StatusOr<std::vector<ObjectInstance>> StoreMapQuery::ObjectsNear(const std::string& map,
                                                                 const Eigen::Vector3d& point,
                                                                 double radius_m,
                                                                 const std::string& label) {
  if (!point.allFinite() || !std::isfinite(radius_m) || radius_m <= 0) {
    return InvalidArgumentError("a near query needs a finite point and a radius > 0");
  }
  MutexLock lock(mutex_);
  MapInfo info;
  if (map.empty()) {
    // Coordinates belong to one map's frame: without a name, only an unambiguous one will do.
    SEMMAP_ASSIGN_OR_RETURN(std::vector<MapInfo> maps, store_->ListMaps());
    if (maps.size() != 1) {
      return InvalidArgumentError("the server has " + std::to_string(maps.size()) +
                                  " maps; name the one whose frame the point is in");
    }
    info = maps.front();
  } else {
    SEMMAP_ASSIGN_OR_RETURN(info, store_->GetMap(map));
  }
  return store_->ObjectInstancesNear(info.id, point, radius_m, label);
}

}  // namespace semmap
