#include "common/tum_format.h"

#include <cstdio>

#include "common/pose.h"
#include "common/time_util.h"

namespace semmap {

std::string FormatTumPoseLine(int64_t stamp_ns, const Eigen::Isometry3d& T_world_camera) {
  const PoseTq tq = ToPoseTq(T_world_camera);
  const std::string stamp = FormatStampSeconds(stamp_ns);
  constexpr const char* kFormat = "%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n";
  const auto print = [&](char* out, size_t size) {
    return std::snprintf(out, size, kFormat, stamp.c_str(), tq.t.x(), tq.t.y(), tq.t.z(), tq.q.x(),
                         tq.q.y(), tq.q.z(), tq.q.w());
  };
  // %.9f of a large finite value has up to 309 integer digits: size the line from the first
  // pass rather than cutting it (and its newline) off in a fixed buffer.
  char buf[256];
  const int length = print(buf, sizeof(buf));
  if (length < 0) return {};
  if (static_cast<size_t>(length) < sizeof(buf))
    return std::string(buf, static_cast<size_t>(length));
  std::string line(static_cast<size_t>(length) + 1, '\0');
  print(line.data(), line.size());
  line.resize(static_cast<size_t>(length));
  return line;
}

}  // namespace semmap
