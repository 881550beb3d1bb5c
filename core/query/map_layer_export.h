// Exports of a map's 3D layers: OctoMap (ot, bt), coloured cloud (ply, pcd) and the rendered
// picture (png). The whole map comes from its persisted blobs (sha256-checked by the store,
// then validated: damage is DATA_LOSS); a session filter or another resolution rebuilds the
// layer from the stored keyframes at their corrected poses.
#pragma once

#include "common/cancel_check.h"
#include "common/map_query.h"
#include "core/mapping/map_layer_builder.h"
#include "storage/map_store.h"

namespace semmap {

// True for the formats handled here.
bool IsLayerExportFormat(const std::string& format);

// `layers` gives the resolutions a rebuild uses when the request names none; `cancel` is asked
// before each keyframe a rebuild decodes or inserts.
StatusOr<ExportResult> BuildLayerExport(MapStore& store, const ExportRequest& request,
                                        const MapLayerOptions& layers,
                                        const CancelCheck& cancel = {});

}  // namespace semmap
