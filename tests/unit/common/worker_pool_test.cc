#include "common/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>

namespace semmap {
namespace {

TEST(WorkerPoolTest, RunsEverythingSubmittedAndDrainsOnStop) {
  auto pool = WorkerPool::Start({/*threads=*/2, /*queue_capacity=*/100, "test-worker"});
  ASSERT_TRUE(pool.ok()) << pool.status().ToString();
  std::atomic<int> done{0};
  for (int i = 0; i < 50; ++i) ASSERT_TRUE((*pool)->Submit([&done] { done.fetch_add(1); }).ok());
  (*pool)->Stop();
  EXPECT_EQ(done.load(), 50);
  EXPECT_EQ((*pool)->Submit([] {}).code(), StatusCode::kUnavailable);
}

TEST(WorkerPoolTest, AFullQueueRefusesInsteadOfWaiting) {
  auto pool = WorkerPool::Start({1, 1, "test-worker"});
  ASSERT_TRUE(pool.ok());
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::promise<void> started;
  ASSERT_TRUE((*pool)
                  ->Submit([&started, released] {
                    started.set_value();
                    released.wait();
                  })
                  .ok());
  started.get_future().wait();
  EXPECT_EQ((*pool)->running(), 1u);
  ASSERT_TRUE((*pool)->Submit([] {}).ok());  // waits in the queue
  const Status refused = (*pool)->Submit([] {});
  EXPECT_EQ(refused.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.message().find("queue is full"), std::string::npos);
  release.set_value();
  (*pool)->Stop();
  EXPECT_EQ((*pool)->running(), 0u);
}

TEST(WorkerPoolTest, OptionsAreValidated) {
  EXPECT_EQ(WorkerPool::Start({0, 1, "w"}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(WorkerPool::Start({1, 0, "w"}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(WorkerPool::Start({1, 1, "a-name-longer-than-15"}).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
