// Decoder of stored map point observations (map_points.observations, schema v5): what decodes
// has exactly 4 + 20 * count bytes and no negative keypoint, and encodes back to the very same
// bytes (the format has one encoding per value); anything else is DATA_LOSS.
#include <cstdint>
#include <string>
#include <vector>

#include "storage/sqlite/map_point_codec.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  const std::string_view input = fuzz::AsText(data, size);
  StatusOr<std::vector<MapPointObservationRecord>> decoded =
      sqlite::DecodeMapPointObservations(input);
  if (!decoded.ok()) {
    FUZZ_CHECK(decoded.status().code() == StatusCode::kDataLoss);
    return 0;
  }
  FUZZ_CHECK(input.size() ==
             sqlite::kMapPointCountBytes + decoded->size() * sqlite::kMapPointObservationBytes);
  for (const MapPointObservationRecord& o : *decoded) FUZZ_CHECK(o.keypoint >= 0);
  StatusOr<std::string> again = sqlite::EncodeMapPointObservations(*decoded);
  FUZZ_CHECK(again.ok() && *again == input);
  return 0;
}
