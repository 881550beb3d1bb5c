// PCD reader of the stored cloud layer (ReadCloudPcd): what parses re-serialises with
// PointCloudMap::ToPcd to bytes that parse to the same points.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/mapping/cloud_pcd_reader.h"
#include "core/mapping/point_cloud_map.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

bool Same(const semmap::CloudPoint& a, const semmap::CloudPoint& b) {
  // Bitwise for the floats: -0 and 0 must survive too.
  return std::memcmp(&a.x, &b.x, sizeof(float)) == 0 &&
         std::memcmp(&a.y, &b.y, sizeof(float)) == 0 &&
         std::memcmp(&a.z, &b.z, sizeof(float)) == 0 && a.r == b.r && a.g == b.g && a.b == b.b;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  StatusOr<std::vector<CloudPoint>> points = ReadCloudPcd(fuzz::AsText(data, size));
  if (!points.ok()) {
    const StatusCode code = points.status().code();
    FUZZ_CHECK(code == StatusCode::kInvalidArgument || code == StatusCode::kDataLoss);
    return 0;
  }
  for (const CloudPoint& p : *points) {
    FUZZ_CHECK(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
  }
  const PointCloudMap map = PointCloudMap::FromPoints(*points, PointCloudMapOptions{});
  StatusOr<std::string> pcd = map.ToPcd(/*binary=*/true);
  FUZZ_CHECK(pcd.ok());
  StatusOr<std::vector<CloudPoint>> again = ReadCloudPcd(*pcd);
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(again->size() == points->size());
  for (size_t i = 0; i < points->size(); ++i) FUZZ_CHECK(Same((*again)[i], (*points)[i]));
  FUZZ_CHECK(map.ToPcd(/*binary=*/false).ok());
  FUZZ_CHECK(map.ToPly(/*binary=*/true).ok());
  const Eigen::AlignedBox3d box = map.Bounds();
  FUZZ_CHECK(points->empty() == box.isEmpty());
  return 0;
}
