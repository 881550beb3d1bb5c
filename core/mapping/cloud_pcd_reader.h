// Reads back the binary PCD that PointCloudMap::ToPcd(true) writes (the map's stored cloud
// layer), without PCL: a strict parser for exactly that layout, so a damaged blob is reported,
// never trusted.
#pragma once

#include <string_view>
#include <vector>

#include "common/status.h"
#include "core/mapping/point_cloud_map.h"

namespace semmap {

// INVALID_ARGUMENT when the header is not PointCloudMap's binary PCD layout (FIELDS x y z rgb,
// SIZE 4 4 4 4, TYPE F F F U, HEIGHT 1, DATA binary); DATA_LOSS when the point data is short,
// too long or holds non-finite coordinates.
StatusOr<std::vector<CloudPoint>> ReadCloudPcd(std::string_view pcd);

}  // namespace semmap
