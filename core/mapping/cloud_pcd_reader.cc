#include "core/mapping/cloud_pcd_reader.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>

#include "common/checked_math.h"

namespace semmap {
namespace {

// The next '\n'-terminated line; false at the end of the input.
bool NextLine(std::string_view& in, std::string_view& line) {
  const size_t end = in.find('\n');
  if (end == std::string_view::npos) return false;
  line = in.substr(0, end);
  in.remove_prefix(end + 1);
  return true;
}

bool ParseCount(std::string_view text, uint64_t& value) {
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && ptr == text.data() + text.size();
}

}  // namespace

StatusOr<std::vector<CloudPoint>> ReadCloudPcd(std::string_view pcd) {
  // Header lines in the order ToPcd writes them; WIDTH and POINTS carry the count.
  static constexpr std::string_view kExpected[] = {"# .PCD v0.7 - Point Cloud Data file format",
                                                   "VERSION 0.7",
                                                   "FIELDS x y z rgb",
                                                   "SIZE 4 4 4 4",
                                                   "TYPE F F F U",
                                                   "COUNT 1 1 1 1",
                                                   "WIDTH ",
                                                   "HEIGHT 1",
                                                   "VIEWPOINT 0 0 0 1 0 0 0",
                                                   "POINTS ",
                                                   "DATA binary"};
  std::string_view in = pcd;
  uint64_t width = 0, points = 0;
  for (std::string_view expected : kExpected) {
    std::string_view line;
    if (!NextLine(in, line))
      return InvalidArgumentError("not a semmap cloud PCD: header ends early");
    const bool counted = expected.back() == ' ';
    if (counted ? line.substr(0, expected.size()) != expected : line != expected) {
      return InvalidArgumentError("not a semmap cloud PCD: expected '" + std::string(expected) +
                                  "', found '" + std::string(line.substr(0, 60)) + "'");
    }
    if (counted &&
        !ParseCount(line.substr(expected.size()), expected == "WIDTH " ? width : points)) {
      return InvalidArgumentError("PCD header: bad count in '" + std::string(line) + "'");
    }
  }
  if (width != points) {
    return InvalidArgumentError("PCD header: WIDTH " + std::to_string(width) + " != POINTS " +
                                std::to_string(points));
  }
  constexpr size_t kPointBytes = 16;
  // Checked: POINTS 2^60 times 16 bytes wraps to 0, which an empty body would match.
  const std::optional<uint64_t> data_bytes = CheckedMul(points, kPointBytes);
  if (!data_bytes || *data_bytes != in.size()) {
    return DataLossError("PCD data holds " + std::to_string(in.size()) + " bytes, the header " +
                         "announces " + std::to_string(points) + " points of 16 bytes");
  }
  std::vector<CloudPoint> out(points);
  const char* data = in.data();
  for (CloudPoint& p : out) {
    float xyz[3];
    uint32_t rgb = 0;
    std::memcpy(xyz, data, sizeof(xyz));
    std::memcpy(&rgb, data + 12, sizeof(rgb));
    data += kPointBytes;
    if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2])) {
      return DataLossError("PCD point " + std::to_string(&p - out.data()) + " is not finite");
    }
    p.x = xyz[0];
    p.y = xyz[1];
    p.z = xyz[2];
    p.r = static_cast<uint8_t>(rgb >> 16);
    p.g = static_cast<uint8_t>(rgb >> 8);
    p.b = static_cast<uint8_t>(rgb);
  }
  return out;
}

}  // namespace semmap
