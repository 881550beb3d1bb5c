// The learned VO model's JSON sidecar (core/odometry/mono_vo_model): an operator's file read at
// start. What parses is a usable description (a valid canonical camera, positive sizes, the
// image input at the network's size); everything else is INVALID_ARGUMENT naming the sidecar.
#include <cstdint>
#include <string>

#include "core/odometry/mono_vo_model.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  StatusOr<MonoVoModelInfo> info = ParseMonoVoSidecar(fuzz::AsText(data, size));
  if (!info.ok()) {
    FUZZ_CHECK(info.status().code() == StatusCode::kInvalidArgument);
    FUZZ_CHECK(info.status().message().find("sidecar") != std::string::npos);
    return 0;
  }
  FUZZ_CHECK(info->camera.Validate().ok());
  FUZZ_CHECK(info->hidden > 0);
  FUZZ_CHECK(info->f2_shape.size() == 4 && info->f3_shape.size() == 4);
  for (const double s : info->stddev) FUZZ_CHECK(s > 0);
  FUZZ_CHECK(info->sha256.size() == 64);
  return 0;
}
