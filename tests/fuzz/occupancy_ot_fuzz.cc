// OctoMap .ot reader (OccupancyMap::DeserializeOt): the map's stored occupancy layer and the
// `semmap export --format ot` file. What loads re-serialises to an .ot that loads to the same
// tree, and every query on it stays inside the tree.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <string>

#include "core/mapping/occupancy_map.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  StatusOr<OccupancyMap> map = OccupancyMap::DeserializeOt(fuzz::AsText(data, size));
  if (!map.ok()) {
    const StatusCode code = map.status().code();
    FUZZ_CHECK(code == StatusCode::kInvalidArgument || code == StatusCode::kDataLoss);
    return 0;
  }
  StatusOr<std::string> ot = map->SerializeOt();
  FUZZ_CHECK(ot.ok());
  StatusOr<OccupancyMap> again = OccupancyMap::DeserializeOt(*ot);
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(again->size() == map->size());
  FUZZ_CHECK(again->resolution() == map->resolution());
  StatusOr<std::string> ot_again = again->SerializeOt();
  FUZZ_CHECK(ot_again.ok() && *ot_again == *ot);

  FUZZ_CHECK(map->SerializeBt().ok());
  const double volume = map->KnownVolume();
  FUZZ_CHECK(std::isfinite(volume) && volume >= 0);
  for (const OccupancyMap::Voxel& v : map->OccupiedVoxels()) {
    FUZZ_CHECK(v.centre.allFinite() && v.size > 0);
    // The voxel's centre is in that voxel: occupied, with the same colour.
    FUZZ_CHECK(map->Occupancy(v.centre) == VoxelState::kOccupied);
    FUZZ_CHECK(map->ColourAt(v.centre) == v.rgb);
  }
  const Eigen::AlignedBox3d bounds = map->Bounds();
  if (!bounds.isEmpty()) {
    (void)map->Occupancy(bounds.center());
    (void)map->Occupancy(bounds.max() * 2.0);
  }
  (void)map->Occupancy(Eigen::Vector3d(1e30, 0, 0));
  return 0;
}
