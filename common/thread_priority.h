// Background threads (object recognition, map layer rebuilds) yield the CPU to tracking: on a
// machine with fewer cores than busy threads, the scheduler then runs the per-frame work first.
#pragma once

namespace semmap {

// Lowers the calling thread's scheduling priority (Linux: its nice value by `increment`, 10 by
// default). Best effort: false when the system refuses, and nothing else changes.
bool LowerCurrentThreadPriority(int increment = 10);

}  // namespace semmap
