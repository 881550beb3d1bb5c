#include "client/datasets/camera_yaml.h"

#include <cmath>
#include <set>
#include <string_view>
#include <vector>

#include "client/datasets/text_parse.h"

namespace semmap {
namespace {

using datasets_internal::LineError;
using datasets_internal::ParseDouble;
using datasets_internal::ParseInt;
using datasets_internal::SplitFields;
using datasets_internal::TextLine;
using datasets_internal::Trim;

constexpr const char* kRequiredKeys[] = {"width", "height", "fx", "fy", "cx", "cy"};

Status ParseDistortion(std::string_view value, const std::string& path, int line,
                       CameraCalibration* camera) {
  if (value.size() < 2 || value.front() != '[' || value.back() != ']') {
    return LineError(path, line, "distortion must be a list like [k1, k2, p1, p2, k3]");
  }
  const std::vector<std::string_view> fields = SplitFields(value.substr(1, value.size() - 2));
  // Four values (k1 k2 p1 p2) are a common OpenCV form; k3 is then zero.
  if (fields.size() != 4 && fields.size() != 5) {
    return LineError(
        path, line,
        "distortion needs 4 or 5 values (k1 k2 p1 p2 [k3]), got " + std::to_string(fields.size()));
  }
  camera->distortion = {};
  for (size_t i = 0; i < fields.size(); ++i) {
    if (!ParseDouble(fields[i], &camera->distortion[i])) {
      return LineError(path, line,
                       "distortion value '" + std::string(fields[i]) + "' is not a number");
    }
  }
  return OkStatus();
}

// Applies one `key: value` pair.
Status ApplyKey(std::string_view key, std::string_view value, const std::string& path, int line,
                CameraYaml* out) {
  CameraCalibration& c = out->camera;
  if (key == "distortion") return ParseDistortion(value, path, line, &c);
  if (key == "width" || key == "height") {
    int* target = key == "width" ? &c.width : &c.height;
    if (!ParseInt(value, target)) {
      return LineError(path, line,
                       std::string(key) + " must be an integer, got '" + std::string(value) + "'");
    }
    return OkStatus();
  }
  double* target = nullptr;
  if (key == "fx") target = &c.fx;
  if (key == "fy") target = &c.fy;
  if (key == "cx") target = &c.cx;
  if (key == "cy") target = &c.cy;
  if (key == "depth_scale") target = &out->depth_scale;
  if (key == "fps") target = &out->fps;
  if (target == nullptr) return LineError(path, line, "unknown key '" + std::string(key) + "'");
  if (!ParseDouble(value, target)) {
    return LineError(path, line,
                     std::string(key) + " must be a number, got '" + std::string(value) + "'");
  }
  return OkStatus();
}

}  // namespace

StatusOr<CameraYaml> ReadCameraYaml(const std::string& path) {
  SEMMAP_ASSIGN_OR_RETURN(const std::string content, datasets_internal::ReadWholeFile(path));
  return ParseCameraYaml(content, path);
}

StatusOr<CameraYaml> ParseCameraYaml(std::string_view content, const std::string& path) {
  CameraYaml out;
  std::set<std::string, std::less<>> seen;
  for (const TextLine& line : datasets_internal::SplitLines(content)) {
    const std::string_view text = Trim(datasets_internal::StripComment(line.text));
    if (text.empty()) continue;
    const size_t colon = text.find(':');
    if (colon == std::string_view::npos) {
      return LineError(path, line.number, "expected 'key: value', got '" + std::string(text) + "'");
    }
    const std::string_view key = Trim(text.substr(0, colon));
    const std::string_view value = Trim(text.substr(colon + 1));
    if (value.empty()) {
      return LineError(path, line.number, "key '" + std::string(key) + "' has no value");
    }
    SEMMAP_RETURN_IF_ERROR(ApplyKey(key, value, path, line.number, &out));
    if (!seen.emplace(key).second) {
      return LineError(path, line.number, "key '" + std::string(key) + "' appears twice");
    }
  }
  std::string missing;
  for (const char* key : kRequiredKeys) {
    if (seen.count(std::string_view(key)) == 0)
      missing += (missing.empty() ? "" : ", ") + std::string(key);
  }
  if (!missing.empty()) return InvalidArgumentError(path + ": missing required keys: " + missing);
  if (!std::isfinite(out.depth_scale) || out.depth_scale < 0) {
    return InvalidArgumentError(path + ": depth_scale must be >= 0 (0 = no depth), got " +
                                std::to_string(out.depth_scale));
  }
  if (seen.count(std::string_view("fps")) != 0 &&
      !(std::isfinite(out.fps) && out.fps > 0 && out.fps <= 10000)) {
    return InvalidArgumentError(path + ": fps must be in (0, 10000], got " +
                                std::to_string(out.fps));
  }
  if (Status valid = ValidateCalibration(out.camera); !valid.ok()) {
    return valid.WithContext(path);
  }
  return out;
}

}  // namespace semmap
