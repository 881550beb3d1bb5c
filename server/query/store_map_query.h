// MapQueryInterface served from a MapStore (its own read connection), serialised by a mutex.
#pragma once

#include <memory>
#include <mutex>

#include "common/map_query.h"
#include "storage/map_store.h"

namespace semmap {

class StoreMapQuery final : public MapQueryInterface {
 public:
  explicit StoreMapQuery(std::unique_ptr<MapStore> store) : store_(std::move(store)) {}

  StatusOr<std::vector<MapInfo>> ListMaps() override;
  StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& map) override;
  StatusOr<std::vector<TrajectoryPose>> GetTrajectory(const std::string& map,
                                                      const std::string& session,
                                                      bool keyframes_only) override;
  StatusOr<ExportResult> ExportMap(const ExportRequest& request) override;

 private:
  std::mutex mutex_;
  std::unique_ptr<MapStore> store_;
};

}  // namespace semmap
