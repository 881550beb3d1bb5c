// The service answers on its worker pool: a blocked export leaves queries served, a cancelled
// export stops, a call that waited past its deadline does no work, and the queue, pending-export
// and registration limits answer RESOURCE_EXHAUSTED naming themselves. The store is replaced by
// a query whose export blocks until the call is cancelled or the test releases it, so every
// case is decided by events, not by timing.
#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <future>
#include <memory>
#include <string>

#include "client/lib/map_client.h"
#include "common/sha256.h"
#include "common/thread_annotations.h"
#include "server/semmap_server.h"
#include "server/service/map_service.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

// Exports block until released or until their cancel check answers; everything else answers
// at once (counting the object queries it saw).
class BlockingQuery final : public MapQueryInterface {
 public:
  StatusOr<std::vector<MapInfo>> ListMaps() override { return std::vector<MapInfo>{}; }
  StatusOr<std::vector<SessionInfo>> ListSessions(const std::string&) override {
    return std::vector<SessionInfo>{};
  }
  StatusOr<std::vector<TrajectoryPose>> GetTrajectory(const std::string&, const std::string&,
                                                      bool) override {
    return std::vector<TrajectoryPose>{};
  }
  StatusOr<ExportResult> ExportMap(const ExportRequest&, const CancelCheck& cancel) override {
    MutexLock lock(mutex_);
    ++exports_started_;
    changed_.notify_all();
    while (!released_) {
      if (Status status = CheckNotCancelled(cancel); !status.ok()) {
        ++exports_cancelled_;
        changed_.notify_all();
        return status;
      }
      changed_.wait_for(lock, std::chrono::milliseconds(1));
    }
    ExportResult result;
    result.format = "json";
    result.bytes = "{}";
    result.sha256_hex = ToHex(Sha256(result.bytes));
    return result;
  }
  StatusOr<std::vector<ObjectType>> ListObjectTypes(const std::string&) override {
    return std::vector<ObjectType>{};
  }
  StatusOr<std::vector<ObjectInstance>> FindObjects(const std::string&,
                                                    const std::string&) override {
    finds_.fetch_add(1);
    return std::vector<ObjectInstance>{};
  }
  StatusOr<std::vector<ObjectInstance>> ObjectsNear(const std::string&, const Eigen::Vector3d&,
                                                    double, const std::string&) override {
    return std::vector<ObjectInstance>{};
  }

  // Waits (up to 30 s) until `count` exports have started / been cancelled.
  bool WaitForExports(int count) {
    return WaitFor([&]() SEMMAP_REQUIRES(mutex_) { return exports_started_ >= count; });
  }
  bool WaitForCancelled(int count) {
    return WaitFor([&]() SEMMAP_REQUIRES(mutex_) { return exports_cancelled_ >= count; });
  }
  void Release() {
    MutexLock lock(mutex_);
    released_ = true;
    changed_.notify_all();
  }
  int finds() const { return finds_.load(); }

 private:
  template <typename Predicate>
  bool WaitFor(Predicate done) {
    MutexLock lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(30),
                             [&]() SEMMAP_REQUIRES(mutex_) { return done(); });
  }

  Mutex mutex_;
  std::condition_variable_any changed_;
  bool released_ SEMMAP_GUARDED_BY(mutex_) = false;
  int exports_started_ SEMMAP_GUARDED_BY(mutex_) = 0;
  int exports_cancelled_ SEMMAP_GUARDED_BY(mutex_) = 0;
  std::atomic<int> finds_{0};
};

class CallWorkersTest : public ::testing::Test {
 protected:
  // A service over the blocking query with `workers` threads and a queue of `queue`.
  void Serve(size_t workers, size_t queue, size_t max_pending_exports) {
    WorkerPoolOptions pool;
    pool.threads = workers;
    pool.queue_capacity = queue;
    auto started = WorkerPool::Start(pool);
    ASSERT_TRUE(started.ok()) << started.status().ToString();
    pool_ = std::move(started).value();
    CallLimits limits;
    limits.workers = workers;
    limits.max_pending_exports = max_pending_exports;
    service_ =
        std::make_unique<MapServiceImpl>(nullptr, &query_, nullptr, nullptr, pool_.get(), limits);
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    ClientOptions options;
    options.server = "127.0.0.1:" + std::to_string(port_);
    options.query_timeout = std::chrono::seconds(60);
    client_ = std::make_unique<MapClient>(options);
  }

  void TearDown() override {
    query_.Release();
    if (server_) server_->Shutdown();
    if (pool_) pool_->Stop();
  }

  // An export on its own thread, cancelled by the client once `cancel` is set.
  std::future<Status> ExportInBackground(std::atomic<bool>* cancel = nullptr) {
    return std::async(std::launch::async, [this, cancel] {
      ExportRequest request;
      request.map = "home";
      request.format = "json";
      CancelCheck check;
      if (cancel != nullptr) {
        check = [cancel]() -> Status {
          return cancel->load() ? CancelledError("the test cancelled the export") : OkStatus();
        };
      }
      return client_->ExportMap(request, check).status();
    });
  }

  BlockingQuery query_;
  std::unique_ptr<WorkerPool> pool_;
  std::unique_ptr<MapServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  std::unique_ptr<MapClient> client_;
};

TEST_F(CallWorkersTest, AQueryIsAnsweredWhileAnExportHoldsAWorker) {
  Serve(/*workers=*/2, /*queue=*/8, /*max_pending_exports=*/1);
  std::future<Status> exported = ExportInBackground();
  ASSERT_TRUE(query_.WaitForExports(1));
  // The export is still blocked: before workers, this waited for it.
  EXPECT_TRUE(client_->FindObjects("laptop", "home").ok());
  EXPECT_EQ(exported.wait_for(std::chrono::seconds(0)), std::future_status::timeout);
  query_.Release();
  EXPECT_EQ(exported.get().ToString(), "OK");
}

TEST_F(CallWorkersTest, ACancelledExportStopsAndLetsGoOfItsWorker) {
  Serve(2, 8, 1);
  std::atomic<bool> cancel{false};
  std::future<Status> exported = ExportInBackground(&cancel);
  ASSERT_TRUE(query_.WaitForExports(1));
  cancel.store(true);
  EXPECT_EQ(exported.get().code(), StatusCode::kCancelled);
  // The server saw the cancellation inside the export (never released), and the worker is free.
  ASSERT_TRUE(query_.WaitForCancelled(1));
  for (int i = 0; i < 3000 && pool_->running() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(pool_->running(), 0u);
}

TEST_F(CallWorkersTest, MoreExportsThanAllowedAreRefusedNamingTheLimit) {
  Serve(2, 8, 1);
  std::future<Status> first = ExportInBackground();
  ASSERT_TRUE(query_.WaitForExports(1));
  ExportRequest second;
  second.map = "home";
  second.format = "json";
  const Status refused = client_->ExportMap(second).status();
  EXPECT_EQ(refused.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.message().find("--max-pending-exports"), std::string::npos)
      << refused.ToString();
  query_.Release();
  EXPECT_EQ(first.get().ToString(), "OK");
  // With the first one done, another is admitted.
  EXPECT_TRUE(client_->ExportMap(second).ok());
}

TEST_F(CallWorkersTest, AFullCallQueueIsRefusedAndAQueuedCallPastItsDeadlineDoesNoWork) {
  Serve(/*workers=*/1, /*queue=*/1, /*max_pending_exports=*/1);
  std::future<Status> exported = ExportInBackground();
  ASSERT_TRUE(query_.WaitForExports(1));  // the only worker is held
  // One call waits in the queue, past its deadline by the time a worker is free.
  ClientOptions impatient_options;
  impatient_options.server = "127.0.0.1:" + std::to_string(port_);
  impatient_options.query_timeout = std::chrono::seconds(1);
  MapClient impatient(impatient_options);
  std::future<Status> queued = std::async(std::launch::async, [&impatient] {
    return impatient.FindObjects("laptop", "home").status();
  });
  for (int i = 0; i < 3000 && pool_->queued() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(pool_->queued(), 1u);
  // A third call finds the queue full.
  const Status third = client_->FindObjects("cup", "home").status();
  EXPECT_EQ(third.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(third.message().find("queue is full"), std::string::npos) << third.ToString();
  EXPECT_EQ(queued.get().code(), StatusCode::kDeadlineExceeded);
  // The server's copy of the deadline ends a little after the client's (it counts from when
  // the call arrived): let it pass there too before a worker is freed.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  query_.Release();
  EXPECT_EQ(exported.get().ToString(), "OK");
  // The expired call reached a worker only after its deadline: it was not answered.
  for (int i = 0; i < 3000 && (pool_->running() > 0 || pool_->queued() > 0); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(query_.finds(), 0);
}

// Registrations per minute, on a real server: the limit is checked before the request's
// content, so requests the catalogue would refuse count too.
TEST(CallLimitsTest, RegistrationsBeyondThePerMinuteLimitAreRefused) {
  testing::TempDir dir;
  ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.data_dir = dir.File("data");
  options.calls.max_registrations_per_minute = 2;
  auto server = SemmapServer::Start(options);
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  ClientOptions client_options;
  client_options.server = (*server)->address();
  MapClient client(client_options);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(client.RegisterObject("cup", "", {}, std::nullopt).status().code(),
              StatusCode::kInvalidArgument);
  }
  const Status refused = client.RegisterObject("cup", "", {}, std::nullopt).status();
  EXPECT_EQ(refused.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.message().find("per minute"), std::string::npos) << refused.ToString();
  // Queries are not limited by it.
  EXPECT_TRUE(client.ListMaps().ok());
}

TEST(CallLimitsTest, OptionsAreValidated) {
  CallLimits limits;
  EXPECT_TRUE(limits.Validate().ok());
  limits.max_pending_exports = limits.workers + 1;  // exports could then hold every worker
  EXPECT_EQ(limits.Validate().code(), StatusCode::kInvalidArgument);
  limits = {};
  limits.workers = 0;
  EXPECT_EQ(limits.Validate().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
