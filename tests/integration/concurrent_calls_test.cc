// Several sessions, queries and exports at once on one server (the ThreadSanitizer job runs it):
// every stream is stored whole, every query and export answers, nothing is refused at these
// modest numbers.
#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include "tests/integration/ingest_test_util.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

constexpr int kSessions = 3;
constexpr int kFrames = 30;

TEST(ConcurrentCallsTest, SessionsQueriesAndExportsRunSideBySide) {
  testing::TempDir dir;
  auto started = testing::StartInProcessServer(ServerOptions{}, dir.File("data"));
  ASSERT_TRUE(started.ok()) << started.status().ToString();
  MapClient& client = *started->client;

  std::atomic<bool> streaming{true};
  std::vector<Status> stream_status(kSessions, OkStatus());
  std::vector<std::thread> devices;
  devices.reserve(kSessions);
  for (int s = 0; s < kSessions; ++s) {
    devices.emplace_back([&, s] {
      const std::string map = "home" + std::to_string(s % 2);  // two sessions share a map
      auto stream = client.Ingest(testing::KnownPosesStart(map, "s" + std::to_string(s)));
      if (!stream.ok()) {
        stream_status[s] = stream.status();
        return;
      }
      for (int i = 0; i < kFrames; ++i) {
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.translation() = Eigen::Vector3d(0.1 * i, 0.05 * s, 0);
        if (!(*stream)->Write(testing::MakeFrame(i, T)).ok()) break;
      }
      stream_status[s] = (*stream)->Finish().status();
    });
  }
  // Queries and exports while the sessions stream; NOT_FOUND until a map exists is fine.
  std::vector<Status> failures;
  int answered = 0;
  std::thread app([&] {
    for (int n = 0; streaming.load() || n < 20; ++n) {
      Status status = OkStatus();
      switch (n % 4) {
        case 0:
          status = client.FindObjects("", "home0").status();
          break;
        case 1:
          status = client.ObjectsNear("home1", Eigen::Vector3d::Zero(), 2.0, "").status();
          break;
        case 2:
          status = client.ListSessions("").status();
          break;
        default: {
          ExportRequest request;
          request.map = "home0";
          request.format = n % 8 == 3 ? "json" : "ply";
          status = client.ExportMap(request).status();
        }
      }
      if (status.ok()) {
        ++answered;
      } else if (status.code() != StatusCode::kNotFound) {
        failures.push_back(status);
      }
    }
  });
  for (std::thread& device : devices) device.join();
  streaming.store(false);
  app.join();

  for (int s = 0; s < kSessions; ++s)
    EXPECT_TRUE(stream_status[s].ok()) << stream_status[s].ToString();
  for (const Status& failure : failures) ADD_FAILURE() << failure.ToString();
  EXPECT_GT(answered, 0);
  for (int s = 0; s < kSessions; ++s) {
    auto trajectory =
        client.GetTrajectory("home" + std::to_string(s % 2), "s" + std::to_string(s), false);
    ASSERT_TRUE(trajectory.ok()) << trajectory.status().ToString();
    EXPECT_EQ(trajectory->size(), static_cast<size_t>(kFrames));
  }
}

}  // namespace
}  // namespace semmap
