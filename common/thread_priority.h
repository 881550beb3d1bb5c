// Background threads (object recognition, map layer rebuilds) yield the CPU to tracking: on a
// machine with fewer cores than busy threads, the scheduler then runs the per-frame work first.
#pragma once

#include <string_view>

namespace semmap {

// Lowers the calling thread's scheduling priority (Linux: its nice value by `increment`, 10 by
// default). Best effort: false when the system refuses, and nothing else changes.
bool LowerCurrentThreadPriority(int increment = 10);

// Names the calling thread as `top -H`, perf and debuggers show it (Linux keeps 15 bytes; the
// rest is cut). Best effort, like the priority. Without it every pipeline thread shows the name
// of whatever gRPC thread started it.
void NameCurrentThread(std::string_view name);

}  // namespace semmap
