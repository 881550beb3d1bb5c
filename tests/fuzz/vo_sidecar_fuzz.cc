// The learned VO model's JSON sidecar (core/odometry/mono_vo_model): an operator's file read at
// start. What parses is a usable description (a valid canonical camera, positive sizes, a
// recurrent state list, the image input at the network's size); everything else is INVALID_ARGUMENT
// naming the sidecar.
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
  // The recurrent state: 1 to 16 entries, names set, shapes of 2 to 4 positive dimensions.
  FUZZ_CHECK(!info->state.empty() && info->state.size() <= 16);
  for (const MonoVoState& s : info->state) {
    FUZZ_CHECK(!s.input.empty() && !s.output.empty());
    FUZZ_CHECK(s.shape.size() >= 2 && s.shape.size() <= 4);
    for (const int d : s.shape) FUZZ_CHECK(d > 0);
  }
  for (const double s : info->stddev) FUZZ_CHECK(s > 0);
  FUZZ_CHECK(info->sha256.size() == 64);
  return 0;
}
