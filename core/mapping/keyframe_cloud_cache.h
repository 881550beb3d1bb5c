// The keyframe clouds a map's layers keep for rebuilds and moves, within a memory budget.
//
// A keyframe's cloud (its depth back-projected and thinned, ~100 kB) is what the occupancy
// rebuild after a loop closure and a move of the keyframe in the coloured cloud need. Kept for
// every keyframe, they made a long-lived map's memory grow with everything it was ever streamed.
// Here they stay in memory while they fit the budget; beyond it the oldest are dropped, but only
// once the store is seen to hold their keyframe (its images, from which the same cloud is made
// again), and read back from there when needed: one at a time for a move, streamed while a
// rebuild builds (OccupancyMap::Build's source). Depth is stored losslessly, so a cloud made again
// has the same points; its colours differ where the store re-encoded them (JPEG of raw colour
// frames), which is why eviction lets the owner swap what it built from the cloud in memory for
// what reading it back gives, before the cloud in memory is gone.
//
// Not thread-safe: one owner (the map's layer builder). Read() touches only the store reader and
// the read counter, so the owner may let one other thread call it while it calls nothing else
// that reads the store (a rebuild's ray-casting thread).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <utility>

#include "common/camera.h"
#include "common/status.h"
#include "core/mapping/occupancy_map.h"
#include "storage/map_store.h"

namespace semmap {

class KeyframeCloudCache {
 public:
  using Key = std::pair<int64_t, int64_t>;  // (session_id, seq)
  // Runs `read` against the store (a connection of the caller's choosing); one call at a time.
  using StoreReader = std::function<Status(const std::function<Status(MapStore&)>& read)>;

  // What Read() needs to give a keyframe's cloud, taken while the owner holds the cache.
  struct Source {
    std::shared_ptr<const KeyframeCloud> cloud;  // in memory; null when it is in the store only
    int64_t keyframe_id = 0;
    CameraCalibration camera;
  };

  // budget_bytes: clouds beyond it are evicted (0 keeps none once stored). `reader` reads the
  // stored keyframes back; `options` make their clouds as the live ones were made.
  KeyframeCloudCache(size_t budget_bytes, OccupancyMapOptions options, StoreReader reader);

  // A keyframe's cloud, in memory (replacing what the keyframe had).
  void Put(const Key& key, std::shared_ptr<const KeyframeCloud> cloud,
           const CameraCalibration& camera);
  // A stored keyframe whose cloud is read when first needed (what a restore knows).
  void PutStored(const Key& key, int64_t keyframe_id, const CameraCalibration& camera);
  bool Contains(const Key& key) const { return slots_.count(key) != 0; }
  // Forgets a keyframe (its cloud could not be read back: it is left out of the layers).
  void Erase(const Key& key);

  // The key must be contained.
  Source SourceOf(const Key& key) const;
  // The source's cloud: the one in memory, or made again from the stored keyframe (not kept:
  // see KeepIfRoom). NOT_FOUND when the store no longer has it, DATA_LOSS when its images are
  // damaged.
  StatusOr<std::shared_ptr<const KeyframeCloud>> Read(const Source& source) const;
  // Keeps a cloud Read() made again in memory when it fits the budget (a rebuild reads every
  // evicted keyframe; those that fit need not be read at the next one).
  void KeepIfRoom(const Key& key, std::shared_ptr<const KeyframeCloud> cloud);

  // Runs before a cloud is dropped, with the cloud and where the store holds it (not for clouds
  // that were read back from there); false keeps it in memory (it cannot be read back).
  using BeforeDrop = std::function<bool(
      const Key& key, const std::shared_ptr<const KeyframeCloud>& in_memory, const Source& stored)>;
  // Over budget: drops the oldest clouds in memory, down to 3/4 of the budget (so the store is
  // asked in batches), of keyframes the store is seen to hold (one listing per session).
  // Clouds whose keyframe the store does not hold yet, or that `before_drop` keeps, stay and
  // are considered again after the others. The store's error when a listing fails.
  Status EvictOverBudget(const BeforeDrop& before_drop = {});

  size_t resident_bytes() const { return resident_bytes_; }
  size_t evicted() const { return slots_.size() - resident_order_.size(); }
  uint64_t reads() const { return reads_.load(std::memory_order_relaxed); }
  size_t budget_bytes() const { return budget_bytes_; }

  // What a cloud holds in memory (its arrays and their bookkeeping).
  static size_t BytesOf(const KeyframeCloud& cloud);

 private:
  struct Slot {
    std::shared_ptr<const KeyframeCloud> cloud;  // null: evicted
    std::optional<int64_t> keyframe_id;          // known once the store was seen to hold it
    uint64_t order = 0;                          // when it came into memory
    size_t bytes = 0;
    bool read_back = false;  // the cloud in memory was read from the store
  };
  void MakeResident(const Key& key, Slot& slot, std::shared_ptr<const KeyframeCloud> cloud);
  void Drop(Slot& slot);
  void MoveToNewest(const Key& key, Slot& slot);

  const size_t budget_bytes_;
  const OccupancyMapOptions options_;
  const StoreReader reader_;
  std::map<Key, Slot> slots_;
  std::map<uint64_t, Key> resident_order_;        // in memory, oldest first
  std::map<int64_t, CameraCalibration> cameras_;  // by session id
  uint64_t next_order_ = 0;
  size_t resident_bytes_ = 0;
  mutable std::atomic<uint64_t> reads_{0};
};

}  // namespace semmap
