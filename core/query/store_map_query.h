// MapQueryInterface served from a MapStore (its own read connection), serialised by a mutex.
#pragma once

#include <memory>
#include <mutex>

#include "common/map_query.h"
#include "core/mapping/map_layer_builder.h"
#include "storage/map_store.h"

namespace semmap {

class StoreMapQuery final : public MapQueryInterface {
 public:
  // `layers`: resolutions for exports that rebuild a 3D layer (the server's layer options).
  explicit StoreMapQuery(std::unique_ptr<MapStore> store, MapLayerOptions layers = {})
      : store_(std::move(store)), layers_(std::move(layers)) {}

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
  std::mutex mutex_;
  std::unique_ptr<MapStore> store_;
  const MapLayerOptions layers_;
};

}  // namespace semmap
