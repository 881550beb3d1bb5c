// Hands memory the allocator has freed back to the system. glibc keeps the freed pages of its
// per-thread arenas, jemalloc returns them only after its decay time: after a map's pipeline is
// released or its layers are rebuilt, hundreds of MB would otherwise stay resident although
// nothing uses them. Works with glibc malloc and with jemalloc (which semmapd links).
#pragma once

#include <cstddef>
#include <string>

namespace semmap {

void ReleaseFreedMemory();

// For a long-running server with many threads on glibc malloc: at most `arenas` malloc arenas
// (glibc gives each thread its own, up to 8 per core, and freed memory scatters across them).
// Nothing under jemalloc. Call once at start.
void LimitAllocatorArenas(int arenas);

// "jemalloc 5.3.0-..." or "the C library's malloc": for the start-up log.
std::string AllocatorName();

// The process's resident memory (VmRSS) in bytes; 0 where /proc cannot tell.
size_t ResidentBytes();

}  // namespace semmap
