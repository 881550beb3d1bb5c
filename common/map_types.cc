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

std::string_view SessionEndReasonName(SessionEndReason reason) {
  switch (reason) {
    case SessionEndReason::kUnspecified:
      return "open/unknown";
    case SessionEndReason::kCompleted:
      return "completed";
    case SessionEndReason::kCancelled:
      return "cancelled";
    case SessionEndReason::kError:
      return "error";
    case SessionEndReason::kServerStopped:
      return "server stopped";
    case SessionEndReason::kIdleTimeout:
      return "idle timeout";
    case SessionEndReason::kCrashed:
      return "crashed";
  }
  return "unknown";
}

}  // namespace semmap
