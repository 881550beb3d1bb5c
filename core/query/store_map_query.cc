#include "core/query/store_map_query.h"

#include <cmath>
#include <optional>
#include <string>

#include "core/query/map_export.h"
#include "core/slam/feature_codec.h"

namespace semmap {
namespace {

std::vector<std::unique_ptr<MapStore>> OneStore(std::unique_ptr<MapStore> store) {
  std::vector<std::unique_ptr<MapStore>> stores;
  stores.push_back(std::move(store));
  return stores;
}

}  // namespace

StoreMapQuery::StoreMapQuery(std::unique_ptr<MapStore> store, MapLayerOptions layers)
    : StoreMapQuery(OneStore(std::move(store)), layers) {}

StoreMapQuery::StoreMapQuery(std::vector<std::unique_ptr<MapStore>> stores, MapLayerOptions layers)
    : stores_(std::move(stores)), layers_(layers) {
  MutexLock lock(mutex_);
  for (const std::unique_ptr<MapStore>& store : stores_) idle_.push_back(store.get());
}

StoreMapQuery::Lease StoreMapQuery::Acquire() {
  MutexLock lock(mutex_);
  while (idle_.empty()) returned_.wait(lock);
  MapStore* store = idle_.back();
  idle_.pop_back();
  return {this, store};
}

void StoreMapQuery::Return(MapStore* store) {
  {
    MutexLock lock(mutex_);
    idle_.push_back(store);
  }
  returned_.notify_one();
}

StatusOr<std::vector<MapInfo>> StoreMapQuery::ListMaps() {
  const Lease store = Acquire();
  return store->ListMaps();
}

StatusOr<std::vector<SessionInfo>> StoreMapQuery::ListSessions(const std::string& map) {
  const Lease store = Acquire();
  return store->ListSessions(map);
}

StatusOr<std::vector<TrajectoryPose>> StoreMapQuery::GetTrajectory(const std::string& map,
                                                                   const std::string& session,
                                                                   bool keyframes_only) {
  if (map.empty() || session.empty()) {
    return InvalidArgumentError("a trajectory query needs both a map and a session name");
  }
  const Lease store = Acquire();
  SEMMAP_ASSIGN_OR_RETURN(SessionInfo info, store->GetSession(map, session));
  return store->GetTrajectory(info.id, keyframes_only);
}

StatusOr<ExportResult> StoreMapQuery::ExportMap(const ExportRequest& request,
                                                const CancelCheck& cancel) {
  const Lease store = Acquire();
  return BuildExport(*store, request, layers_, cancel);
}

StatusOr<std::vector<ObjectType>> StoreMapQuery::ListObjectTypes(const std::string& map) {
  const Lease store = Acquire();
  std::optional<int64_t> map_id;
  if (!map.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(MapInfo info, store->GetMap(map));
    map_id = info.id;
  }
  // With views for their count and feature count; the photos and features stay on the server.
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectType> types,
                          store->ListObjectTypes(map_id, /*with_views=*/true));
  for (ObjectType& type : types) {
    for (ObjectView& view : type.views) {
      StatusOr<FrameFeatures> features = DecodeFeatures(view.features_format, view.features);
      if (!features.ok()) {
        return Status(features.status().code(),
                      "object '" + type.label + "': " + features.status().message());
      }
      view.feature_count = features->size();
      view.image = {};
      view.features.clear();
    }
  }
  return types;
}

StatusOr<std::vector<ObjectInstance>> StoreMapQuery::FindObjects(const std::string& label,
                                                                 const std::string& map) {
  const Lease store = Acquire();
  std::optional<int64_t> map_id;
  if (!map.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(MapInfo info, store->GetMap(map));
    map_id = info.id;
  }
  return store->FindObjectInstances(map_id, label);
}

StatusOr<std::vector<ObjectInstance>> StoreMapQuery::ObjectsNear(const std::string& map,
                                                                 const Eigen::Vector3d& point,
                                                                 double radius_m,
                                                                 const std::string& label) {
  if (!point.allFinite() || !std::isfinite(radius_m) || radius_m <= 0) {
    return InvalidArgumentError("a near query needs a finite point and a radius > 0");
  }
  const Lease store = Acquire();
  MapInfo info;
  if (map.empty()) {
    // Coordinates belong to one map's frame: without a name, only an unambiguous one will do.
    SEMMAP_ASSIGN_OR_RETURN(std::vector<MapInfo> maps, store->ListMaps());
    if (maps.size() != 1) {
      return InvalidArgumentError("the server has " + std::to_string(maps.size()) +
                                  " maps; name the one whose frame the point is in");
    }
    info = maps.front();
  } else {
    SEMMAP_ASSIGN_OR_RETURN(info, store->GetMap(map));
  }
  return store->ObjectInstancesNear(info.id, point, radius_m, label);
}

}  // namespace semmap
