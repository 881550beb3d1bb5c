// Hands memory the allocator has freed back to the system. glibc keeps the freed pages of its
// per-thread arenas: after a map's pipeline is released or its layers are rebuilt, hundreds of
// MB would otherwise stay resident although nothing uses them. A no-op with other allocators.
#pragma once

#include <cstddef>

namespace semmap {

void ReleaseFreedMemory();

// For a long-running server with many threads: at most `arenas` malloc arenas (glibc gives each
// thread its own, up to 8 per core, and freed memory scatters across them). Call once at start.
void LimitAllocatorArenas(int arenas);

// The process's resident memory (VmRSS) in bytes; 0 where /proc cannot tell.
size_t ResidentBytes();

}  // namespace semmap
