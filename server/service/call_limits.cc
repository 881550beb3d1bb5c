#include "server/service/call_limits.h"

#include <string>

namespace semmap {

Status CallLimits::Validate() const {
  if (workers < 1 || workers > 64) return InvalidArgumentError("--query-workers must be in 1..64");
  if (worker_queue < 1 || worker_queue > 10000) {
    return InvalidArgumentError("--query-queue must be in 1..10000");
  }
  if (max_pending_exports < 1 || max_pending_exports > workers) {
    return InvalidArgumentError("--max-pending-exports must be in 1..--query-workers (" +
                                std::to_string(workers) + ")");
  }
  return OkStatus();
}

}  // namespace semmap
