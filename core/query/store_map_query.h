// MapQueryInterface served from a MapStore. Each query leases one of the store's read
// connections for its duration (SQLite's WAL lets readers run beside each other and the
// writer), so a long export holds one connection and queries keep the others; with all leased,
// a query waits for the first one returned.
#pragma once

#include <condition_variable>
#include <memory>
#include <vector>

#include "common/map_query.h"
#include "common/thread_annotations.h"
#include "core/mapping/map_layer_builder.h"
#include "storage/map_store.h"

namespace semmap {

class StoreMapQuery final : public MapQueryInterface {
 public:
  // `layers`: resolutions for exports that rebuild a 3D layer (the server's layer options).
  explicit StoreMapQuery(std::unique_ptr<MapStore> store, MapLayerOptions layers = {});
  // One connection per query that may run at once (at least one).
  explicit StoreMapQuery(std::vector<std::unique_ptr<MapStore>> stores,
                         MapLayerOptions layers = {});

  StatusOr<std::vector<MapInfo>> ListMaps() override;
  StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& map) override;
  StatusOr<std::vector<TrajectoryPose>> GetTrajectory(const std::string& map,
                                                      const std::string& session,
                                                      bool keyframes_only) override;
  StatusOr<ExportResult> ExportMap(const ExportRequest& request,
                                   const CancelCheck& cancel = {}) override;
  StatusOr<std::vector<ObjectType>> ListObjectTypes(const std::string& map) override;
  StatusOr<std::vector<ObjectInstance>> FindObjects(const std::string& label,
                                                    const std::string& map) override;
  StatusOr<std::vector<ObjectInstance>> ObjectsNear(const std::string& map,
                                                    const Eigen::Vector3d& point, double radius_m,
                                                    const std::string& label) override;

  size_t num_connections() const { return stores_.size(); }

 private:
  // A connection held by one query; back to the pool when it goes out of scope.
  class Lease {
   public:
    Lease(StoreMapQuery* owner, MapStore* store) : owner_(owner), store_(store) {}
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { owner_->Return(store_); }
    MapStore* operator->() const { return store_; }
    MapStore& operator*() const { return *store_; }

   private:
    StoreMapQuery* owner_;
    MapStore* store_;
  };

  Lease Acquire() SEMMAP_EXCLUDES(mutex_);
  void Return(MapStore* store) SEMMAP_EXCLUDES(mutex_);

  // Set once; a connection is used by the query holding its lease only.
  const std::vector<std::unique_ptr<MapStore>> stores_;
  const MapLayerOptions layers_;
  Mutex mutex_;
  std::condition_variable_any returned_;
  std::vector<MapStore*> idle_ SEMMAP_GUARDED_BY(mutex_);
};

}  // namespace semmap
