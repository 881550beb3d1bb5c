#include "common/map_types.h"

namespace semmap {

std::string_view SessionModeName(SessionMode mode) {
  switch (mode) {
    case SessionMode::kRgbd:
      return "rgbd";
    case SessionMode::kMono:
      return "mono";
    case SessionMode::kKnownPoses:
      return "known_poses";
  }
  return "unknown";
}

}  // namespace semmap
