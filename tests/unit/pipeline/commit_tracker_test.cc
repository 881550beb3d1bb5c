// Durability accounting: durable_seq only moves forward on commits, the first failure is kept,
// and WaitAll returns once every submitted batch has an answer.
#include "core/pipeline/commit_tracker.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace semmap {
namespace {

TEST(CommitTrackerTest, DurableSeqIsTheHighestCommittedAndTheFirstErrorIsKept) {
  CommitTracker tracker;
  EXPECT_FALSE(tracker.durable_seq().has_value());
  for (int i = 0; i < 4; ++i) tracker.Submitted();
  EXPECT_EQ(tracker.Committed(OkStatus(), 3, 1.0), 3u);
  EXPECT_EQ(tracker.Committed(OkStatus(), 2, 1.0), 3u);  // out of order: never backwards
  EXPECT_EQ(tracker.Committed(UnavailableError("disk"), 4, 1.0), 3u);
  EXPECT_EQ(tracker.Committed(InternalError("later"), 5, 1.0), 3u);
  const Status error = tracker.error();
  EXPECT_EQ(error.code(), StatusCode::kUnavailable);
  EXPECT_NE(error.message().find("storing frame seq 4 failed"), std::string::npos)
      << error.ToString();
  EXPECT_EQ(tracker.CommitLatency().count, 4u);
  tracker.WaitAll();  // nothing pending
}

TEST(CommitTrackerTest, WaitAllBlocksUntilEveryBatchIsAnswered) {
  CommitTracker tracker;
  tracker.Submitted();
  tracker.Submitted();
  tracker.Submitted();
  tracker.SubmitFailed();  // refused by the writer: never answered
  std::atomic<bool> returned{false};
  std::thread waiter([&] {
    tracker.WaitAll();
    returned.store(true);
  });
  tracker.Committed(OkStatus(), 1, 0.5);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(returned.load());  // one batch still pending
  tracker.Committed(OkStatus(), 2, 0.5);
  waiter.join();
  EXPECT_TRUE(returned.load());
  EXPECT_EQ(tracker.durable_seq(), 2u);
}

}  // namespace
}  // namespace semmap
