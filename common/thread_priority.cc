#include "common/thread_priority.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>

namespace semmap {

bool LowerCurrentThreadPriority(int increment) {
  // On Linux, a thread id given to setpriority(PRIO_PROCESS) names that thread only.
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int current = getpriority(PRIO_PROCESS, tid);
  if (current == -1 && errno != 0) return false;
  return setpriority(PRIO_PROCESS, tid, current + increment) == 0;
}

}  // namespace semmap
