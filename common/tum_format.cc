#include "common/tum_format.h"

#include <cstdio>

#include "common/pose.h"
#include "common/time_util.h"

namespace semmap {

std::string FormatTumPoseLine(int64_t stamp_ns, const Eigen::Isometry3d& T_world_camera) {
  const PoseTq tq = ToPoseTq(T_world_camera);
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n",
                FormatStampSeconds(stamp_ns).c_str(), tq.t.x(), tq.t.y(), tq.t.z(), tq.q.x(),
                tq.q.y(), tq.q.z(), tq.q.w());
  return buf;
}

}  // namespace semmap
