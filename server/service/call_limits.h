// Limits on the calls that cost a lot; each answers RESOURCE_EXHAUSTED naming itself when hit.
// (Ingest streams, open maps and frame sizes have theirs in IngestOptions.)
#pragma once

#include <cstddef>

#include "common/status.h"

namespace semmap {

struct CallLimits {
  // Threads answering queries, exports and registrations, each with its own read connection.
  size_t workers = 4;
  size_t worker_queue = 64;                  // calls waiting for a worker
  size_t max_pending_exports = 2;            // exports running or waiting for a worker
  size_t max_registrations_per_minute = 30;  // RegisterObject calls admitted per minute; 0: any

  Status Validate() const;
};

}  // namespace semmap
