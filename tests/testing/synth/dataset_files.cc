#include "tests/testing/synth/dataset_files.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <system_error>

namespace semmap::synth {
namespace {

// Shortest text that reads back as the same double.
std::string Num(double v) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, result.ptr);
}

std::string Fixed(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.6f", v == 0.0 ? 0.0 : v);  // no "-0.000000"
  return buf;
}

std::vector<std::string> Tokens(const std::string& line) {
  std::vector<std::string> tokens;
  std::istringstream in(line);
  for (std::string token; in >> token;) tokens.push_back(token);
  return tokens;
}

bool ParseNumber(const std::string& token, double* value) {
  const char* end = token.data() + token.size();
  const auto result = std::from_chars(token.data(), end, *value);
  return result.ec == std::errc() && result.ptr == end && std::isfinite(*value);
}

}  // namespace

std::string FormatCameraYaml(const CameraCalibration& camera, double depth_scale) {
  std::string out = "# synthetic pinhole camera (semmap-synth), images rendered undistorted\n";
  out += "width: " + std::to_string(camera.width) + "\n";
  out += "height: " + std::to_string(camera.height) + "\n";
  out += "fx: " + Num(camera.fx) + "\n";
  out += "fy: " + Num(camera.fy) + "\n";
  out += "cx: " + Num(camera.cx) + "\n";
  out += "cy: " + Num(camera.cy) + "\n";
  out += "depth_scale: " + Num(depth_scale) + "   # raw depth units per metre (0 = no depth)\n";
  out += "distortion: [";
  for (size_t i = 0; i < camera.distortion.size(); ++i) {
    out += (i ? ", " : "") + Num(camera.distortion[i]);
  }
  out += "]   # k1 k2 p1 p2 k3 (OpenCV order)\n";
  return out;
}

std::string FormatObjectsFile(const std::vector<NamedObject>& objects) {
  std::string out =
      "# named objects of the synthetic scene, world frame (z up), metres\n"
      "# centre and extents of each object's axis-aligned bounding box (0 = flat, e.g. a "
      "poster);\n"
      "# template images in objects/<label>.png\n"
      "# label cx cy cz sx sy sz\n";
  for (const NamedObject& o : objects) {
    out += o.label;
    for (int i = 0; i < 6; ++i) {
      out += ' ';  // (not " " + string: GCC 12 misreports -Wrestrict on that)
      out += Fixed(i < 3 ? o.centre[i] : o.size[i - 3]);
    }
    out += '\n';
  }
  return out;
}

StatusOr<std::vector<ObjectRecord>> ReadObjectsFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return NotFoundError(path + " does not exist");
  std::ifstream in(path);
  if (!in) return UnavailableError("cannot read " + path);
  std::vector<ObjectRecord> records;
  std::set<std::string> labels;
  int number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    const std::vector<std::string> tokens = Tokens(line);
    if (tokens.empty()) continue;
    if (tokens.size() != 7) {
      return InvalidArgumentError(where + "expected 'label cx cy cz sx sy sz', got " +
                                  std::to_string(tokens.size()) + " fields");
    }
    ObjectRecord record;
    record.label = tokens[0];
    for (int i = 0; i < 6; ++i) {
      double v = 0;
      if (!ParseNumber(tokens[static_cast<size_t>(i) + 1], &v)) {
        return InvalidArgumentError(where + "'" + tokens[static_cast<size_t>(i) + 1] +
                                    "' is not a number");
      }
      (i < 3 ? record.centre : record.size)[i % 3] = v;
    }
    if ((record.size.array() < 0).any()) return InvalidArgumentError(where + "negative size");
    if (!labels.insert(record.label).second) {
      return InvalidArgumentError(where + "label '" + record.label + "' appears twice");
    }
    records.push_back(record);
  }
  return records;
}

Status WriteTextFile(const std::string& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << content;
  out.close();
  if (!out) return UnavailableError("cannot write " + path);
  return OkStatus();
}

}  // namespace semmap::synth
