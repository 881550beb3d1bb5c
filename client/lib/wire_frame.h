// A dataset frame as the Ingest RPC's wire message: its image files sent as they are stored
// (PNG / JPEG bytes, decoded by the server). One place for the CLI and the benches.
#pragma once

#include <Eigen/Geometry>
#include <optional>

#include "client/datasets/dataset.h"
#include "common/status.h"
#include "semmap/v1/service.pb.h"

namespace semmap {

// `with_depth`: attach the frame's depth image (when it has one) with `depth_scale`.
// `T_world_camera`: sent as the pose prior (KNOWN_POSES sessions). NOT_FOUND / INVALID_ARGUMENT
// naming the file when an image cannot be read.
StatusOr<v1::Frame> MakeWireFrame(const DatasetFrame& frame, bool with_depth, double depth_scale,
                                  const std::optional<Eigen::Isometry3d>& T_world_camera);

}  // namespace semmap
