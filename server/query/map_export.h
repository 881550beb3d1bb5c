// Builds export products from the store. Formats: "tum" (one session's full trajectory in TUM
// text), "json" (the map's sessions, keyframe poses and links).
#pragma once

#include "common/map_query.h"
#include "storage/map_store.h"

namespace semmap {

StatusOr<ExportResult> BuildExport(MapStore& store, const ExportRequest& request);

}  // namespace semmap
