#include "core/objects/object_catalog.h"

#include <chrono>
#include <string>
#include <utility>

#include "common/name_validation.h"
#include "core/slam/feature_codec.h"

namespace semmap {
namespace {

constexpr size_t kMaxPhotos = 32;

int64_t NowUnixNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

std::array<uint8_t, 3> LabelColour(const std::string& label) {
  // FNV-1a of the label picks a hue; full saturation and value keep boxes visible on any cloud.
  uint32_t h = 2166136261u;
  for (const char c : label) h = (h ^ static_cast<uint8_t>(c)) * 16777619u;
  const double hue = static_cast<double>(h % 360u) / 60.0;
  const int sector = static_cast<int>(hue);
  const double f = hue - sector;
  const auto v = [](double x) { return static_cast<uint8_t>(40 + 215 * x); };
  switch (sector) {
    case 0:
      return {v(1), v(f), v(0)};
    case 1:
      return {v(1 - f), v(1), v(0)};
    case 2:
      return {v(0), v(1), v(f)};
    case 3:
      return {v(0), v(1 - f), v(1)};
    case 4:
      return {v(f), v(0), v(1)};
    default:
      return {v(1), v(0), v(1 - f)};
  }
}

StatusOr<ObjectCatalog::Entry> ObjectCatalog::EntryFromType(const ObjectType& type) {
  Entry entry;
  entry.model.type_id = type.id;
  entry.model.label = type.label;
  entry.map_id = type.map_id;
  entry.rgb = type.rgb;
  for (const ObjectView& view : type.views) {
    StatusOr<FrameFeatures> features = DecodeFeatures(view.features_format, view.features);
    if (!features.ok()) {
      return DataLossError("object '" + type.label + "' view " + std::to_string(view.id) + ": " +
                           features.status().message());
    }
    entry.model.views.push_back({std::move(features).value(), view.width, view.height});
  }
  return entry;
}

StatusOr<std::unique_ptr<ObjectCatalog>> ObjectCatalog::Load(StorageWriter* writer,
                                                             ObjectRecognitionOptions options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (writer == nullptr) return InvalidArgumentError("the object catalog needs a storage writer");
  std::vector<ObjectType> types;
  SEMMAP_RETURN_IF_ERROR(writer->RunSync([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(types, store.ListObjectTypes(std::nullopt, /*with_views=*/true));
    return OkStatus();
  }));
  std::unique_ptr<ObjectCatalog> catalog(new ObjectCatalog(writer, options));
  MutexLock lock(catalog->mutex_);  // not shared yet; the lock keeps the analysis simple
  for (const ObjectType& type : types) {
    SEMMAP_ASSIGN_OR_RETURN(Entry entry, EntryFromType(type));
    catalog->entries_.emplace(type.id, std::move(entry));
  }
  return catalog;
}

StatusOr<ObjectType> ObjectCatalog::Register(const RegisterObjectInput& input,
                                             const CancelCheck& cancelled) {
  SEMMAP_RETURN_IF_ERROR(ValidateName("object label", input.label));
  if (input.photos.empty()) {
    return InvalidArgumentError("object '" + input.label + "' needs at least one photo");
  }
  if (input.photos.size() > kMaxPhotos) {
    return InvalidArgumentError("at most " + std::to_string(kMaxPhotos) + " photos per object");
  }
  ObjectType type;
  type.label = input.label;
  type.rgb = input.rgb ? *input.rgb : LabelColour(input.label);
  type.created_unix_ns = NowUnixNs();
  // Features first (the expensive, fallible part), outside any lock.
  Entry entry;
  entry.model.label = input.label;
  entry.rgb = type.rgb;
  for (size_t i = 0; i < input.photos.size(); ++i) {
    const EncodedImage& photo = input.photos[i];
    StatusOr<ModelView> view = BuildModelViewFromEncoded(photo.bytes, options_);
    if (!view.ok()) {
      return Status(view.status().code(),
                    "photo " + std::to_string(i + 1) + ": " + view.status().message());
    }
    ObjectView stored;
    stored.image = photo;
    stored.width = view->width;
    stored.height = view->height;
    stored.features_format = std::string(kFeatureCodecFormat);
    stored.features = EncodeFeatures(view->features);
    stored.feature_count = view->features.size();
    type.views.push_back(std::move(stored));
    entry.model.views.push_back(std::move(view).value());
  }
  const Status stored_type = writer_->RunSync([&](MapStore& store) -> Status {
    if (!input.map.empty()) {
      SEMMAP_ASSIGN_OR_RETURN(MapInfo map, store.GetMap(input.map));
      type.map_id = map.id;
    }
    SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancelled));
    SEMMAP_ASSIGN_OR_RETURN(type, store.CreateObjectType(type));
    return OkStatus();
  });
  SEMMAP_RETURN_IF_ERROR(stored_type);
  // The views just built are what the stored features decode to (lossless codec).
  entry.model.type_id = type.id;
  entry.map_id = type.map_id;
  MutexLock lock(mutex_);
  entries_[type.id] = std::move(entry);
  cache_.clear();
  return type;
}

Status ObjectCatalog::Remove(const std::string& label, const std::string& map,
                             const CancelCheck& cancelled) {
  std::optional<int64_t> map_id;
  const Status removed = writer_->RunSync([&](MapStore& store) -> Status {
    if (!map.empty()) {
      SEMMAP_ASSIGN_OR_RETURN(MapInfo info, store.GetMap(map));
      map_id = info.id;
    }
    SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancelled));
    return store.RemoveObjectType(label, map_id);
  });
  SEMMAP_RETURN_IF_ERROR(removed);
  MutexLock lock(mutex_);
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (it->second.model.label == label && it->second.map_id == map_id) {
      entries_.erase(it);
      break;
    }
  }
  cache_.clear();
  return OkStatus();
}

void ObjectCatalog::ForgetMap(int64_t map_id) {
  MutexLock lock(mutex_);
  for (auto it = entries_.begin(); it != entries_.end();) {
    it = it->second.map_id == map_id ? entries_.erase(it) : std::next(it);
  }
  cache_.clear();
}

std::shared_ptr<const ObjectModelSet> ObjectCatalog::ModelsFor(int64_t map_id) const {
  MutexLock lock(mutex_);
  auto cached = cache_.find(map_id);
  if (cached != cache_.end()) return cached->second;
  auto set = std::make_shared<ObjectModelSet>();
  for (const auto& [id, entry] : entries_) {
    if (entry.map_id && *entry.map_id != map_id) continue;
    set->models.push_back(entry.model);
    set->colours.push_back(entry.rgb);
  }
  std::shared_ptr<const ObjectModelSet> shared = std::move(set);
  cache_.emplace(map_id, shared);
  return shared;
}

bool ObjectCatalog::Contains(int64_t type_id) const {
  MutexLock lock(mutex_);
  return entries_.count(type_id) > 0;
}

}  // namespace semmap
