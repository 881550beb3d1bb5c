// The server's object database: the registered object types with the features of their photos,
// loaded from the store at start and kept in step by Register / Remove (which write through the
// storage writer). Recognisers take an immutable snapshot of the models visible in their map
// for each keyframe, so a type registered while a session streams is searched for from the
// next keyframe on, and a removed one is no longer.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/cancel_check.h"
#include "common/map_types.h"
#include "common/object_types.h"
#include "common/status.h"
#include "common/thread_annotations.h"
#include "core/recognition/object_model.h"
#include "storage/storage_writer.h"

namespace semmap {

struct RegisterObjectInput {
  std::string label;
  std::string map;  // empty: global
  std::vector<EncodedImage> photos;
  std::optional<std::array<uint8_t, 3>> rgb;  // none: derived from the label
};

// The object types a keyframe of one map is searched for.
struct ObjectModelSet {
  std::vector<ObjectModel> models;
  std::vector<std::array<uint8_t, 3>> colours;  // per model
};

class ObjectCatalog {
 public:
  // Reads every type with its views (on the writer's thread). DATA_LOSS when stored features
  // do not decode. `writer` must outlive the catalog.
  static StatusOr<std::unique_ptr<ObjectCatalog>> Load(StorageWriter* writer,
                                                       ObjectRecognitionOptions options);

  // Builds a view from every photo (INVALID_ARGUMENT naming the photo that cannot be used: not
  // decodable, too few features), stores the type (ALREADY_EXISTS, NOT_FOUND for an unknown
  // map, INVALID_ARGUMENT for a bad label or no photos) and makes it visible to recognisers.
  // `cancelled` is asked right before the type is stored: a call whose client has gone or whose
  // deadline has passed by then takes no effect.
  StatusOr<ObjectType> Register(const RegisterObjectInput& input,
                                const CancelCheck& cancelled = nullptr) SEMMAP_EXCLUDES(mutex_);
  // NOT_FOUND when the scope has no type of that label.
  Status Remove(const std::string& label, const std::string& map,
                const CancelCheck& cancelled = nullptr) SEMMAP_EXCLUDES(mutex_);
  // Drops the types of a map that was removed from the store (with them, by cascade).
  void ForgetMap(int64_t map_id) SEMMAP_EXCLUDES(mutex_);

  // Global types and the map's own; never null.
  std::shared_ptr<const ObjectModelSet> ModelsFor(int64_t map_id) const SEMMAP_EXCLUDES(mutex_);
  // Whether a type id is still registered (observations of removed types are dropped).
  bool Contains(int64_t type_id) const SEMMAP_EXCLUDES(mutex_);
  const ObjectRecognitionOptions& options() const { return options_; }

 private:
  struct Entry {
    ObjectModel model;
    std::optional<int64_t> map_id;
    std::array<uint8_t, 3> rgb{};
  };

  ObjectCatalog(StorageWriter* writer, ObjectRecognitionOptions options)
      : writer_(writer), options_(options) {}
  static StatusOr<Entry> EntryFromType(const ObjectType& type);

  StorageWriter* const writer_;
  const ObjectRecognitionOptions options_;
  mutable Mutex mutex_;
  std::map<int64_t, Entry> entries_ SEMMAP_GUARDED_BY(mutex_);  // by type id
  // Snapshots handed out, per map, until the next change.
  mutable std::map<int64_t, std::shared_ptr<const ObjectModelSet>> cache_ SEMMAP_GUARDED_BY(mutex_);
};

// A stable, saturated colour for a label (the same label always gets the same colour).
std::array<uint8_t, 3> LabelColour(const std::string& label);

}  // namespace semmap
