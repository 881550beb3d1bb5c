#include "server/query/store_map_query.h"

#include "server/query/map_export.h"

namespace semmap {

StatusOr<std::vector<MapInfo>> StoreMapQuery::ListMaps() {
  std::lock_guard lock(mutex_);
  return store_->ListMaps();
}

StatusOr<std::vector<SessionInfo>> StoreMapQuery::ListSessions(const std::string& map) {
  std::lock_guard lock(mutex_);
  return store_->ListSessions(map);
}

StatusOr<std::vector<TrajectoryPose>> StoreMapQuery::GetTrajectory(const std::string& map,
                                                                   const std::string& session,
                                                                   bool keyframes_only) {
  if (map.empty() || session.empty()) {
    return InvalidArgumentError("a trajectory query needs both a map and a session name");
  }
  std::lock_guard lock(mutex_);
  SEMMAP_ASSIGN_OR_RETURN(SessionInfo info, store_->GetSession(map, session));
  return store_->GetTrajectory(info.id, keyframes_only);
}

StatusOr<ExportResult> StoreMapQuery::ExportMap(const ExportRequest& request) {
  std::lock_guard lock(mutex_);
  return BuildExport(*store_, request);
}

}  // namespace semmap
