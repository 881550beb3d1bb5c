// Scheduling tiers. On a machine with fewer cores than busy threads (12 ingest streams on 2
// cores), the scheduler then answers a query before it decodes or tracks a frame, and tracks a
// frame before it rebuilds a map layer. The serving tier matters most: gRPC's callback threads
// carry every call's bytes (queries' too), so when they wait behind per-frame work every query
// waits with them (measured: `where` p50 33 s under load_bench with all threads at one level).
#pragma once

#include <string_view>

namespace semmap {

enum class ThreadTier {
  kServing,     // gRPC's threads, query workers, the storage writer: the process's priority
  kPerFrame,    // ingest decode and tracking: nice + 10
  kBackground,  // the SLAM back end, map layers, object recognition: nice + 19 (the lowest)
};

// The nice increment of a tier relative to the serving threads.
int NiceIncrementOf(ThreadTier tier);

// Moves the calling thread to `tier`: the process's (main thread's) nice value plus the tier's
// increment, whatever the thread inherited from the thread that started it. Best effort, as
// LowerCurrentThreadPriority (raising a thread's priority back may need privileges).
bool RunCurrentThreadAs(ThreadTier tier);

// Lowers the calling thread's scheduling priority (Linux: its nice value by `increment`, 10 by
// default). Best effort: false when the system refuses, and nothing else changes.
bool LowerCurrentThreadPriority(int increment = 10);

// Names the calling thread as `top -H`, perf and debuggers show it (Linux keeps 15 bytes; the
// rest is cut). Best effort, like the priority. Without it every pipeline thread shows the name
// of whatever gRPC thread started it.
void NameCurrentThread(std::string_view name);

}  // namespace semmap
