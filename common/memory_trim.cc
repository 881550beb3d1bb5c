#include "common/memory_trim.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <fstream>
#include <string>

// jemalloc's control interface. A weak reference: null unless the executable links jemalloc
// (semmapd does; tests and tools run on glibc malloc).
extern "C" int mallctl(const char* name, void* oldp, size_t* oldlenp, void* newp, size_t newlen)
    __attribute__((weak));

namespace semmap {

void ReleaseFreedMemory() {
  if (mallctl != nullptr) {
    // Every arena ("arena.<MALLCTL_ARENAS_ALL = 4096>"): its unused dirty pages go back now
    // rather than after jemalloc's decay time.
    mallctl("arena.4096.purge", nullptr, nullptr, nullptr, 0);
    return;
  }
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

void LimitAllocatorArenas(int arenas) {
  if (mallctl != nullptr) return;  // jemalloc sizes its arenas by the cores
#if defined(__GLIBC__)
  mallopt(M_ARENA_MAX, arenas);
#else
  (void)arenas;
#endif
}

std::string AllocatorName() {
  if (mallctl != nullptr) {
    const char* version = nullptr;
    size_t size = sizeof(version);
    if (mallctl("version", static_cast<void*>(&version), &size, nullptr, 0) == 0 &&
        version != nullptr) {
      return std::string("jemalloc ") + version;
    }
    return "jemalloc";
  }
  return "the C library's malloc";
}

size_t ResidentBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0)
      return static_cast<size_t>(std::stoull(line.substr(6))) * 1024;
  }
  return 0;
}

}  // namespace semmap
