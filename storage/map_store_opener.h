// Opens a read connection to the store on demand, so that a pipeline stage restores what a
// map holds on its own thread, without going through (and stalling) the storage writer. SQLite
// in WAL mode lets such readers run next to the one writer; a reader sees what is committed.
#pragma once

#include <functional>
#include <memory>
#include <utility>

#include "common/status.h"
#include "storage/map_store.h"
#include "storage/storage_writer.h"

namespace semmap {

using MapStoreOpener = std::function<StatusOr<std::unique_ptr<MapStore>>()>;

}  // namespace semmap

namespace semmap {

// How a pipeline stage restores what the store holds for its map when it starts: not at all
// (a new map), through the storage writer (consistent with every write queued before, but all
// commits wait meanwhile), or through a read connection of its own on the stage's thread (the
// writer keeps committing; the stage sees what is committed).
struct StoreRestore {
  bool enabled = false;
  MapStoreOpener open_reader;  // empty: through the writer

  static StoreRestore None() { return {}; }
  static StoreRestore ThroughWriter() { return {true, nullptr}; }
  static StoreRestore ThroughReader(MapStoreOpener opener) { return {true, std::move(opener)}; }
};

// Runs `read` against the store the way `restore` says (nothing when it is not enabled).
inline Status ReadForRestore(const StoreRestore& restore, StorageWriter& writer,
                             const std::function<Status(MapStore&)>& read) {
  if (!restore.enabled) return OkStatus();
  if (!restore.open_reader) return writer.RunSync(read);
  SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<MapStore> reader, restore.open_reader());
  return read(*reader);
}

}  // namespace semmap
