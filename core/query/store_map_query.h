// MapQueryInterface served from a MapStore (its own read connection), serialised by a mutex.
#pragma once

#include <memory>

#include "common/map_query.h"
#include "common/thread_annotations.h"
#include "core/mapping/map_layer_builder.h"
#include "storage/map_store.h"

namespace semmap {

class StoreMapQuery final : public MapQueryInterface {
 public:
  // `layers`: resolutions for exports that rebuild a 3D layer (the server's layer options).
  explicit StoreMapQuery(std::unique_ptr<MapStore> store, MapLayerOptions layers = {})
      : store_(std::move(store)), layers_(layers) {}

  StatusOr<std::vector<MapInfo>> ListMaps() override;
  StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& map) override;
  StatusOr<std::vector<TrajectoryPose>> GetTrajectory(const std::string& map,
                                                      const std::string& session,
                                                      bool keyframes_only) override;
  StatusOr<ExportResult> ExportMap(const ExportRequest& request) override;
  StatusOr<std::vector<ObjectType>> ListObjectTypes(const std::string& map) override;
  StatusOr<std::vector<ObjectInstance>> FindObjects(const std::string& label,
                                                    const std::string& map) override;
  StatusOr<std::vector<ObjectInstance>> ObjectsNear(const std::string& map,
                                                    const Eigen::Vector3d& point, double radius_m,
                                                    const std::string& label) override;

 private:
  Mutex mutex_;
  // The store's connection is not thread-safe: the pointer is set once, what it points to is
  // used under mutex_.
  const std::unique_ptr<MapStore> store_ SEMMAP_PT_GUARDED_BY(mutex_);
  const MapLayerOptions layers_;
};

}  // namespace semmap
