// Wire request messages of the unary and server-streaming RPCs -> domain requests. Everything a
// handler reads from a request goes through here, so one fuzz target covers all of it.
#pragma once

#include <Eigen/Core>
#include <string>

#include "common/map_query.h"
#include "common/status.h"
#include "core/objects/object_catalog.h"
#include "semmap/v1/service.grpc.pb.h"

namespace semmap {

// INVALID_ARGUMENT for colour channels above 255.
StatusOr<RegisterObjectInput> FromProto(const v1::RegisterObjectRequest& request);

// The width is clamped to 2^20 (the renderer refuses what it cannot draw).
ExportRequest FromProto(const v1::ExportMapRequest& request);

struct NearQuery {
  std::string map;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double radius_m = 0;  // validated by the store (finite, > 0)
  std::string label;
};
NearQuery FromProto(const v1::ObjectsNearRequest& request);

}  // namespace semmap
