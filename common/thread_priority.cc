#include "common/thread_priority.h"

#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <string>

namespace semmap {

bool LowerCurrentThreadPriority(int increment) {
  // On Linux, a thread id given to setpriority(PRIO_PROCESS) names that thread only.
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int current = getpriority(PRIO_PROCESS, tid);
  if (current == -1 && errno != 0) return false;
  return setpriority(PRIO_PROCESS, tid, current + increment) == 0;
}

int NiceIncrementOf(ThreadTier tier) {
  switch (tier) {
    case ThreadTier::kServing:
      return 0;
    case ThreadTier::kPerFrame:
      return 10;
    case ThreadTier::kBackground:
      return 19;
  }
  return 0;
}

bool RunCurrentThreadAs(ThreadTier tier) {
  // Relative to the process (its main thread), not to the calling thread: a thread inherits its
  // creator's nice value, and a stage started from a per-frame thread (the SLAM back end, opened
  // by the session that first streams into its map) would otherwise land a tier lower (19).
  errno = 0;
  const int process = getpriority(PRIO_PROCESS, static_cast<id_t>(getpid()));
  if (process == -1 && errno != 0) return false;
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int current = getpriority(PRIO_PROCESS, tid);
  if (current == -1 && errno != 0) return false;
  const int target = std::min(process + NiceIncrementOf(tier), 19);
  return current == target || setpriority(PRIO_PROCESS, tid, target) == 0;
}

void NameCurrentThread(std::string_view name) {
  constexpr size_t kMaxLength = 15;  // Linux's TASK_COMM_LEN less the terminator
  const std::string cut(name.substr(0, kMaxLength));
  pthread_setname_np(pthread_self(), cut.c_str());
}

}  // namespace semmap
