#include "core/mapping/keyframe_cloud_cache.h"

#include <string>
#include <utility>
#include <vector>

#include "core/mapping/stored_keyframe_clouds.h"

namespace semmap {

KeyframeCloudCache::KeyframeCloudCache(size_t budget_bytes, OccupancyMapOptions options,
                                       StoreReader reader)
    : budget_bytes_(budget_bytes), options_(options), reader_(std::move(reader)) {}

size_t KeyframeCloudCache::BytesOf(const KeyframeCloud& cloud) {
  // The arrays, the cloud itself and its shared_ptr control block (~32 bytes).
  return cloud.points.capacity() * sizeof(cloud.points[0]) +
         cloud.colours.capacity() * sizeof(cloud.colours[0]) + sizeof(KeyframeCloud) + 32;
}

void KeyframeCloudCache::MakeResident(const Key& key, Slot& slot,
                                      std::shared_ptr<const KeyframeCloud> cloud) {
  Drop(slot);
  slot.bytes = BytesOf(*cloud);
  slot.cloud = std::move(cloud);
  slot.order = next_order_++;
  resident_order_.emplace(slot.order, key);
  resident_bytes_ += slot.bytes;
}

void KeyframeCloudCache::Drop(Slot& slot) {
  if (!slot.cloud) return;
  resident_order_.erase(slot.order);
  resident_bytes_ -= slot.bytes;
  slot.cloud.reset();
  slot.bytes = 0;
}

void KeyframeCloudCache::Put(const Key& key, std::shared_ptr<const KeyframeCloud> cloud,
                             const CameraCalibration& camera) {
  cameras_[key.first] = camera;
  Slot& slot = slots_[key];
  slot.keyframe_id.reset();  // new images: what the store holds may be older
  MakeResident(key, slot, std::move(cloud));
  slot.read_back = false;
}

void KeyframeCloudCache::PutStored(const Key& key, int64_t keyframe_id,
                                   const CameraCalibration& camera) {
  cameras_[key.first] = camera;
  Slot& slot = slots_[key];
  Drop(slot);
  slot.keyframe_id = keyframe_id;
}

void KeyframeCloudCache::Erase(const Key& key) {
  auto it = slots_.find(key);
  if (it == slots_.end()) return;
  Drop(it->second);
  slots_.erase(it);
}

KeyframeCloudCache::Source KeyframeCloudCache::SourceOf(const Key& key) const {
  const Slot& slot = slots_.at(key);
  return {slot.cloud, slot.keyframe_id.value_or(0), cameras_.at(key.first)};
}

StatusOr<std::shared_ptr<const KeyframeCloud>> KeyframeCloudCache::Read(
    const Source& source) const {
  if (source.cloud) return source.cloud;
  std::optional<KeyframeCloud> cloud;
  SEMMAP_RETURN_IF_ERROR(reader_([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(
        cloud, ReadStoredKeyframeCloud(store, source.keyframe_id, source.camera, options_));
    return OkStatus();
  }));
  reads_.fetch_add(1, std::memory_order_relaxed);
  return std::make_shared<const KeyframeCloud>(std::move(*cloud));
}

void KeyframeCloudCache::KeepIfRoom(const Key& key, std::shared_ptr<const KeyframeCloud> cloud) {
  auto it = slots_.find(key);
  if (it == slots_.end() || it->second.cloud || cloud == nullptr) return;
  if (resident_bytes_ + BytesOf(*cloud) > budget_bytes_) return;
  MakeResident(key, it->second, std::move(cloud));
  it->second.read_back = true;
}

void KeyframeCloudCache::MoveToNewest(const Key& key, Slot& slot) {
  resident_order_.erase(slot.order);
  slot.order = next_order_++;
  resident_order_.emplace(slot.order, key);
}

Status KeyframeCloudCache::EvictOverBudget(const BeforeDrop& before_drop) {
  if (resident_bytes_ <= budget_bytes_) return OkStatus();
  const size_t low_water = budget_bytes_ / 4 * 3;
  std::vector<Key> oldest_first;
  oldest_first.reserve(resident_order_.size());
  for (const auto& [order, key] : resident_order_) oldest_first.push_back(key);
  // Each session's stored keyframes (seq -> id), listed once per call when first needed;
  // nullopt for a session removed meanwhile (its clouds stay: the map is rebuilt without it).
  std::map<int64_t, std::optional<std::map<int64_t, int64_t>>> listed;
  for (const Key& key : oldest_first) {
    if (resident_bytes_ <= low_water) break;
    Slot& slot = slots_.at(key);
    if (!slot.keyframe_id) {
      auto [it, first] = listed.try_emplace(key.first);
      if (first) {
        std::map<int64_t, int64_t> stored;
        Status status = reader_([&](MapStore& store) -> Status {
          SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> records,
                                  store.ListKeyframes(key.first, /*with_images=*/false));
          for (const KeyframeRecord& record : records) {
            if (record.depth_scale > 0) stored[record.seq] = record.id;
          }
          return OkStatus();
        });
        if (status.ok()) {
          it->second = std::move(stored);
        } else if (status.code() != StatusCode::kNotFound) {
          return status;
        }
      }
      if (it->second) {
        const auto found = it->second->find(key.second);
        if (found != it->second->end()) slot.keyframe_id = found->second;
      }
      if (!slot.keyframe_id) {
        // Not committed yet (or its write failed): considered again after the others, so it
        // never holds up the eviction of those behind it.
        MoveToNewest(key, slot);
        continue;
      }
    }
    if (before_drop && !slot.read_back &&
        !before_drop(key, slot.cloud, {nullptr, *slot.keyframe_id, cameras_.at(key.first)})) {
      MoveToNewest(key, slot);
      continue;
    }
    Drop(slot);
  }
  return OkStatus();
}

}  // namespace semmap
