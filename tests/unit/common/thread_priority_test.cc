#include "common/thread_priority.h"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <string>
#include <thread>

namespace semmap {
namespace {

std::string CurrentThreadName() {
  char name[64] = {};
  if (pthread_getname_np(pthread_self(), name, sizeof(name)) != 0) return "?";
  return name;
}

// The calling thread's nice value (errno cleared: -1 is a valid answer).
int NiceOfThisThread() {
  errno = 0;
  return getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
}

TEST(ThreadPriorityTest, NamesTheCallingThreadOnlyCuttingAt15Bytes) {
  const std::string before = CurrentThreadName();
  std::string inside, cut;
  std::thread([&] {
    NameCurrentThread("slam-backend");
    inside = CurrentThreadName();
    NameCurrentThread("a-name-longer-than-fifteen-bytes");
    cut = CurrentThreadName();
  }).join();
  EXPECT_EQ(inside, "slam-backend");
  EXPECT_EQ(cut, "a-name-longer-t");
  EXPECT_EQ(CurrentThreadName(), before);
}

TEST(ThreadPriorityTest, LowersTheCallingThreadOnly) {
  const int before = NiceOfThisThread();
  int inside_before = 0, inside_after = 0;
  bool lowered = false;
  std::thread([&] {
    inside_before = NiceOfThisThread();
    lowered = LowerCurrentThreadPriority(3);
    inside_after = NiceOfThisThread();
  }).join();
  if (!lowered) GTEST_SKIP() << "this system refuses setpriority";
  EXPECT_EQ(inside_after, std::min(inside_before + 3, 19));
  EXPECT_EQ(NiceOfThisThread(), before);
}

TEST(ThreadPriorityTest, TiersRunServingFirstThenPerFrameThenBackground) {
  EXPECT_EQ(NiceIncrementOf(ThreadTier::kServing), 0);
  EXPECT_LT(NiceIncrementOf(ThreadTier::kServing), NiceIncrementOf(ThreadTier::kPerFrame));
  EXPECT_LT(NiceIncrementOf(ThreadTier::kPerFrame), NiceIncrementOf(ThreadTier::kBackground));
  EXPECT_LE(NiceIncrementOf(ThreadTier::kBackground), 19);  // the lowest nice value Linux has

  int serving_before = 0, serving_after = 0, per_frame_before = 0, per_frame_after = 0;
  bool moved = false;
  std::thread([&] {
    serving_before = NiceOfThisThread();
    EXPECT_TRUE(RunCurrentThreadAs(ThreadTier::kServing));  // nothing to change
    serving_after = NiceOfThisThread();
  }).join();
  std::thread([&] {
    per_frame_before = NiceOfThisThread();
    moved = RunCurrentThreadAs(ThreadTier::kPerFrame);
    per_frame_after = NiceOfThisThread();
  }).join();
  EXPECT_EQ(serving_after, serving_before);
  if (!moved) GTEST_SKIP() << "this system refuses setpriority";
  EXPECT_EQ(per_frame_after,
            std::min(per_frame_before + NiceIncrementOf(ThreadTier::kPerFrame), 19));
}

// A stage started from a per-frame thread (the SLAM back end, opened by the session streaming
// into its map) must land in the per-frame tier, not a tier below what it inherited.
TEST(ThreadPriorityTest, TiersAreRelativeToTheProcessNotTheStartingThread) {
  const int process = NiceOfThisThread();  // the test's main thread
  int outer = 0, inner = 0, background = 0;
  bool moved = false;
  std::thread([&] {
    moved = RunCurrentThreadAs(ThreadTier::kPerFrame);
    outer = NiceOfThisThread();
    std::thread([&] {
      EXPECT_TRUE(RunCurrentThreadAs(ThreadTier::kPerFrame));
      inner = NiceOfThisThread();
      EXPECT_TRUE(RunCurrentThreadAs(ThreadTier::kBackground));
      background = NiceOfThisThread();
    }).join();
  }).join();
  if (!moved) GTEST_SKIP() << "this system refuses setpriority";
  const int per_frame = std::min(process + NiceIncrementOf(ThreadTier::kPerFrame), 19);
  EXPECT_EQ(outer, per_frame);
  EXPECT_EQ(inner, per_frame);
  EXPECT_EQ(background, std::min(process + NiceIncrementOf(ThreadTier::kBackground), 19));
}

}  // namespace
}  // namespace semmap
