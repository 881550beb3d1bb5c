// Builds export products from the store. Formats: "tum" (one session's full trajectory in TUM
// text), "json" (the map's sessions, keyframe poses and links), and the 3D layers (ot, bt, ply,
// pcd, png: map_layer_export.h).
#pragma once

#include "common/cancel_check.h"
#include "common/map_query.h"
#include "core/mapping/map_layer_builder.h"
#include "storage/map_store.h"

namespace semmap {

// `layers`: the server's layer options (resolutions of rebuilt layers). `cancel` is asked
// between the steps of a long export (each keyframe of a rebuild); its status ends it.
StatusOr<ExportResult> BuildExport(MapStore& store, const ExportRequest& request,
                                   const MapLayerOptions& layers = {},
                                   const CancelCheck& cancel = {});

}  // namespace semmap
