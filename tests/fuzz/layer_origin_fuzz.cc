// The stored layer origin of a map (core/mapping/layer_frame): what decodes is a finite
// position within 1e7 m that encodes back to bytes decoding to the same position.
#include <cmath>
#include <cstdint>

#include "core/mapping/layer_frame.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  StatusOr<Eigen::Vector3d> origin = DecodeLayerOrigin(fuzz::AsText(data, size));
  if (!origin.ok()) {
    FUZZ_CHECK(origin.status().code() == StatusCode::kDataLoss);
    return 0;
  }
  FUZZ_CHECK(origin->allFinite() && origin->cwiseAbs().maxCoeff() <= 1e7);
  StatusOr<Eigen::Vector3d> again = DecodeLayerOrigin(EncodeLayerOrigin(*origin));
  FUZZ_CHECK(again.ok() && *again == *origin);
  return 0;
}
