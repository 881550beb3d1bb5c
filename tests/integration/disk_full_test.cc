// A full disk, for real: the server's data directory on a small tmpfs the test mounts, filled
// up by a file beside the database. Ingest must end RESOURCE_EXHAUSTED without losing what it
// acknowledged as durable, queries must keep working while the disk is full, and writing must
// resume once space is freed. Skips with a message where mounting is not permitted (not root,
// no CAP_SYS_ADMIN, a container).
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "server/semmap_server.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 240;

class DiskFullTest : public ::testing::Test {
 protected:
  void SetUp() override {
    mount_point_ = dir_.File("small-disk");
    std::filesystem::create_directories(mount_point_);
    if (::mount("semmap-test", mount_point_.c_str(), "tmpfs", MS_NOSUID | MS_NODEV,
                "size=12m,mode=0700") != 0) {
      GTEST_SKIP() << "cannot mount a 12 MB tmpfs at " << mount_point_ << " ("
                   << std::strerror(errno)
                   << "): the disk-full test needs root with CAP_SYS_ADMIN outside a container";
    }
    mounted_ = true;
    auto started = testing::StartInProcessServer(ServerOptions{}, mount_point_ + "/data");
    ASSERT_TRUE(started.ok()) << started.status().ToString();
    server_ = std::move(started).value();
  }

  void TearDown() override {
    server_.server.reset();
    server_.client.reset();
    if (mounted_ && ::umount2(mount_point_.c_str(), MNT_DETACH) != 0) {
      ADD_FAILURE() << "umount " << mount_point_ << ": " << std::strerror(errno);
    }
  }

  // Fills the disk with a file beside the data directory, then gives back `leave_bytes`.
  void FillDiskLeaving(size_t leave_bytes) {
    const std::string filler = mount_point_ + "/filler";
    {
      std::ofstream out(filler, std::ios::binary);
      const std::string block(64 << 10, 'x');
      while (out.write(block.data(), static_cast<std::streamsize>(block.size()))) {
      }
    }
    const auto size = std::filesystem::file_size(filler);
    std::filesystem::resize_file(filler, size > leave_bytes ? size - leave_bytes : 0);
  }
  void FreeDisk() { std::filesystem::remove(mount_point_ + "/filler"); }

  // Streams up to `frames` keyframe-sized frames into map "home"; the stream's final status and
  // the last seq acknowledged durable.
  Status Stream(const std::string& session, int frames, std::optional<uint64_t>* durable) {
    auto stream =
        server_.client->Ingest(testing::KnownPosesStart("home", session, kWidth, kHeight));
    if (!stream.ok()) return stream.status();
    for (int i = 0; i < frames; ++i) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation().x() = 0.3 * i;  // every frame a keyframe: images are stored
      if (!(*stream)->Write(testing::MakeFrame(i, T, kWidth, kHeight)).ok()) break;
    }
    Status status = (*stream)->Finish().status();
    *durable = (*stream)->durable_seq();
    return status;
  }

  testing::TempDir dir_;
  std::string mount_point_;
  bool mounted_ = false;
  testing::InProcessServer server_;
};

TEST_F(DiskFullTest, IngestStopsWithResourceExhaustedReadsGoOnAndWritingResumesWhenFreed) {
  std::optional<uint64_t> durable;
  ASSERT_TRUE(Stream("before", 3, &durable).ok());  // the map exists, with a session
  FillDiskLeaving(256 << 10);

  const Status full = Stream("while-full", 200, &durable);
  EXPECT_EQ(full.code(), StatusCode::kResourceExhausted) << full.ToString();
  std::cout << "disk full after " << (durable ? std::to_string(*durable + 1) : std::string("no"))
            << " durable frames: " << full.ToString() << "\n";
  // Every frame acknowledged as durable is stored.
  auto stored = server_.client->GetTrajectory("home", "while-full", false);
  ASSERT_TRUE(stored.ok()) << stored.status().ToString();
  if (durable) {
    ASSERT_GE(stored->size(), *durable + 1);
    for (uint64_t seq = 0; seq <= *durable; ++seq) EXPECT_EQ((*stored)[seq].seq, seq);
  }

  // Reads while the disk is still full.
  EXPECT_TRUE(server_.client->ListMaps().ok());
  auto sessions = server_.client->ListSessions("home");
  ASSERT_TRUE(sessions.ok()) << sessions.status().ToString();
  EXPECT_GE(sessions->size(), 2u);
  auto before = server_.client->GetTrajectory("home", "before", false);
  ASSERT_TRUE(before.ok()) << before.status().ToString();
  EXPECT_EQ(before->size(), 3u);
  EXPECT_TRUE(server_.client->FindObjects("", "home").ok());

  // A few MB free: the next session is stored whole.
  FreeDisk();
  std::optional<uint64_t> resumed_durable;
  const Status resumed = Stream("after", 5, &resumed_durable);
  EXPECT_TRUE(resumed.ok()) << resumed.ToString();
  EXPECT_EQ(resumed_durable, std::optional<uint64_t>(4));
  auto after = server_.client->GetTrajectory("home", "after", false);
  ASSERT_TRUE(after.ok()) << after.status().ToString();
  EXPECT_EQ(after->size(), 5u);
}

}  // namespace
}  // namespace semmap
