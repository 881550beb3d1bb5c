// camera.yaml of the datasets: what parses is a valid calibration, and writing it back out
// (17 significant digits) parses to exactly the same values.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "client/datasets/camera_yaml.h"
#include "tests/fuzz/fuzz_util.h"

namespace semmap {
namespace {

std::string Number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::string Format(const CameraYaml& yaml) {
  const CameraCalibration& c = yaml.camera;
  std::string out = "# written back\nwidth: " + std::to_string(c.width) +
                    "\nheight: " + std::to_string(c.height) + "\nfx: " + Number(c.fx) +
                    "\nfy: " + Number(c.fy) + "\ncx: " + Number(c.cx) + "\ncy: " + Number(c.cy) +
                    "\ndepth_scale: " + Number(yaml.depth_scale) + "  # comment\ndistortion: [";
  for (size_t i = 0; i < c.distortion.size(); ++i) {
    out += (i > 0 ? ", " : "") + Number(c.distortion[i]);
  }
  return out + "]\n";
}

}  // namespace
}  // namespace semmap

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  StatusOr<CameraYaml> yaml = ParseCameraYaml(fuzz::AsText(data, size), "camera.yaml");
  if (!yaml.ok()) {
    FUZZ_CHECK(yaml.status().code() == StatusCode::kInvalidArgument);
    FUZZ_CHECK(fuzz::NamesSource(yaml.status().message(), "camera.yaml"));
    return 0;
  }
  FUZZ_CHECK(ValidateCalibration(yaml->camera).ok());
  FUZZ_CHECK(std::isfinite(yaml->depth_scale) && yaml->depth_scale >= 0);
  StatusOr<CameraYaml> again = ParseCameraYaml(Format(*yaml), "again.yaml");
  FUZZ_CHECK(again.ok());
  const CameraCalibration& a = yaml->camera;
  const CameraCalibration& b = again->camera;
  FUZZ_CHECK(a.width == b.width && a.height == b.height);
  FUZZ_CHECK(a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy);
  FUZZ_CHECK(a.distortion == b.distortion);
  FUZZ_CHECK(yaml->depth_scale == again->depth_scale);
  return 0;
}
