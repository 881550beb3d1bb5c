// The Ingest RPC through a real in-process server on loopback: the happy path, every
// status-code path, durability of what was acknowledged, and restart persistence.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "server/semmap_server.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

using testing::CircleTrajectory;
using testing::KnownPosesStart;
using testing::MakeFrame;

class IngestServiceTest : public ::testing::Test {
 protected:
  void SetUp() override { StartServer(); }

  void StartServer(ServerOptions options = {}) {
    options.max_message_mb = 4;
    options.ingest.max_frame_bytes = 2u << 20;
    auto started = testing::StartInProcessServer(options, dir_.path());
    ASSERT_TRUE(started.ok()) << started.status().ToString();
    server_ = std::move(started->server);
    client_ = std::move(started->client);
  }

  void RestartServer() {
    ASSERT_TRUE(server_->Shutdown().ok());
    client_.reset();
    server_.reset();
    StartServer();
  }

  // Streams frames 0..n-1 and finishes; returns the final status.
  Status Stream(const v1::IngestStart& start, int n, int* acks = nullptr) {
    int count = 0;
    auto stream = client_->Ingest(start, [&](const v1::FrameAck&) { ++count; });
    if (!stream.ok()) return stream.status();
    const auto poses = CircleTrajectory(n);
    for (int i = 0; i < n; ++i) {
      Status s = (*stream)->Write(MakeFrame(i, poses[i]));
      if (!s.ok()) return s;
    }
    auto summary = (*stream)->Finish();
    if (acks) *acks = count;
    return summary.status();
  }

  // Opens a stream, sends `frames`, then finishes; returns the stream's final status.
  Status StreamFrames(const v1::IngestStart& start, std::vector<v1::Frame> frames) {
    auto stream = client_->Ingest(start);
    if (!stream.ok()) return stream.status();
    for (auto& f : frames) {
      Status s = (*stream)->Write(std::move(f));
      if (!s.ok()) return s;
    }
    return (*stream)->Finish().status();
  }

  testing::TempDir dir_;
  std::unique_ptr<SemmapServer> server_;
  std::unique_ptr<MapClient> client_;
};

TEST_F(IngestServiceTest, KnownPosesSessionIsStoredAndQueryable) {
  int acks = 0;
  ASSERT_TRUE(Stream(KnownPosesStart("lab", "run1"), 30, &acks).ok());
  EXPECT_EQ(acks, 30);

  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  ASSERT_EQ(maps->size(), 1u);
  EXPECT_EQ((*maps)[0].name, "lab");

  auto sessions = client_->ListSessions("lab");
  ASSERT_TRUE(sessions.ok()) << sessions.status().ToString();
  ASSERT_EQ(sessions->size(), 1u);
  EXPECT_EQ((*sessions)[0].frame_count, 30);
  EXPECT_NE((*sessions)[0].ended_unix_ns, 0);
  // A 1 m circle in 30 steps moves ~0.21 m per frame: every frame is a keyframe.
  EXPECT_EQ((*sessions)[0].keyframe_count, 30);

  auto trajectory = client_->GetTrajectory("lab", "run1", false);
  ASSERT_TRUE(trajectory.ok());
  ASSERT_EQ(trajectory->size(), 30u);
  const auto poses = CircleTrajectory(30);
  for (int i = 0; i < 30; ++i) {
    EXPECT_EQ((*trajectory)[i].seq, i);
    EXPECT_TRUE((*trajectory)[i].T_world_camera.isApprox(poses[i], 1e-9));
  }
}

TEST_F(IngestServiceTest, KeyframesFollowTheMotionThreshold) {
  v1::IngestStart start = KnownPosesStart("lab", "slow");
  start.mutable_keyframes()->set_min_motion(0.5);
  ASSERT_TRUE(Stream(start, 60).ok());
  auto kfs = client_->GetTrajectory("lab", "slow", /*keyframes_only=*/true);
  ASSERT_TRUE(kfs.ok());
  // 60 poses on a 1 m circle: chord between keyframes must exceed 0.5 m-equivalent.
  EXPECT_GT(kfs->size(), 3u);
  EXPECT_LT(kfs->size(), 20u);
  EXPECT_EQ((*kfs)[0].seq, 0);
}

TEST_F(IngestServiceTest, GeneratedSessionNamesAreUnique) {
  ASSERT_TRUE(Stream(KnownPosesStart("lab", ""), 2).ok());
  ASSERT_TRUE(Stream(KnownPosesStart("lab", ""), 2).ok());
  auto sessions = client_->ListSessions("lab");
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->size(), 2u);
  EXPECT_NE((*sessions)[0].name, (*sessions)[1].name);
}

TEST_F(IngestServiceTest, DuplicateSessionIsAlreadyExists) {
  ASSERT_TRUE(Stream(KnownPosesStart("lab", "a"), 1).ok());
  EXPECT_EQ(Stream(KnownPosesStart("lab", "a"), 1).code(), StatusCode::kAlreadyExists);
}

// A server without the VO model (this one has none) refuses MONO sessions saying why; RGBD and
// KNOWN_POSES keep working (the other tests).
TEST_F(IngestServiceTest, MonoWithoutAModelIsFailedPreconditionAndUnspecifiedIsInvalid) {
  v1::IngestStart start = KnownPosesStart("lab", "x");
  start.set_mode(v1::SESSION_MODE_MONO);
  const Status mono = Stream(start, 1);
  EXPECT_EQ(mono.code(), StatusCode::kFailedPrecondition) << mono.ToString();
  EXPECT_NE(mono.message().find("--vo-model"), std::string::npos) << mono.message();
  start.set_mode(v1::SESSION_MODE_UNSPECIFIED);
  EXPECT_EQ(Stream(start, 1).code(), StatusCode::kInvalidArgument);
}

TEST_F(IngestServiceTest, BadCalibrationIsInvalidArgument) {
  v1::IngestStart start = KnownPosesStart("lab", "x");
  start.mutable_camera()->set_k(0, std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(Stream(start, 1).code(), StatusCode::kInvalidArgument);
  start = KnownPosesStart("lab", "x");
  start.mutable_camera()->mutable_k()->RemoveLast();
  EXPECT_EQ(Stream(start, 1).code(), StatusCode::kInvalidArgument);
  start = KnownPosesStart("lab", "x");
  start.mutable_camera()->set_k(0, -10);
  EXPECT_EQ(Stream(start, 1).code(), StatusCode::kInvalidArgument);
  start = KnownPosesStart("lab", "x");
  start.clear_camera();
  EXPECT_EQ(Stream(start, 1).code(), StatusCode::kInvalidArgument);
  start = KnownPosesStart("", "x");
  EXPECT_EQ(Stream(start, 1).code(), StatusCode::kInvalidArgument);
}

TEST_F(IngestServiceTest, FrameBeforeStartIsInvalidArgument) {
  grpc::ClientContext context;
  auto raw = client_->stub().Ingest(&context);
  v1::IngestRequest request;
  *request.mutable_frame() = MakeFrame(0, Eigen::Isometry3d::Identity());
  raw->Write(request);
  raw->WritesDone();
  v1::IngestResponse response;
  while (raw->Read(&response)) {
  }
  const grpc::Status status = raw->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("start"), std::string::npos) << status.error_message();
}

TEST_F(IngestServiceTest, FrameAfterEndIsInvalidArgument) {
  grpc::ClientContext context;
  auto raw = client_->stub().Ingest(&context);
  v1::IngestRequest request;
  *request.mutable_start() = KnownPosesStart("lab", "late");
  raw->Write(request);
  request.mutable_end();
  raw->Write(request);
  *request.mutable_frame() = MakeFrame(0, Eigen::Isometry3d::Identity());
  raw->Write(request);
  raw->WritesDone();
  v1::IngestResponse response;
  while (raw->Read(&response)) {
  }
  const grpc::Status status = raw->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("after the end"), std::string::npos)
      << status.error_message();
}

TEST_F(IngestServiceTest, NonMonotonicSeqIsInvalidArgumentAndEarlierFramesStay) {
  std::vector<v1::Frame> frames;
  frames.push_back(MakeFrame(5, Eigen::Isometry3d::Identity()));
  frames.push_back(MakeFrame(5, Eigen::Isometry3d::Identity()));
  const Status status = StreamFrames(KnownPosesStart("lab", "seq"), std::move(frames));
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("not greater"), std::string::npos) << status.message();
  auto trajectory = client_->GetTrajectory("lab", "seq", false);
  ASSERT_TRUE(trajectory.ok());
  EXPECT_EQ(trajectory->size(), 1u);  // the acknowledged frame was kept
}

TEST_F(IngestServiceTest, ImageProblemsAreInvalidArgument) {
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  auto expect_invalid = [&](v1::Frame frame, const std::string& needle) {
    std::vector<v1::Frame> frames;
    frames.push_back(std::move(frame));
    static int n = 0;
    const Status status =
        StreamFrames(KnownPosesStart("lab", "img" + std::to_string(n++)), std::move(frames));
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
    EXPECT_NE(status.message().find(needle), std::string::npos) << status.message();
  };
  v1::Frame wrong_size = MakeFrame(0, I, 80, 60);
  expect_invalid(wrong_size, "session camera is 160x120");

  v1::Frame garbage = MakeFrame(0, I);
  garbage.mutable_colour()->mutable_compressed()->set_data("definitely not a png");
  expect_invalid(garbage, "could not be decoded");

  v1::Frame unknown = MakeFrame(0, I);
  unknown.mutable_colour()->mutable_compressed()->set_format("webp");
  expect_invalid(unknown, "unknown compressed format");

  v1::Frame raw_encoding = MakeFrame(0, I);
  raw_encoding.mutable_depth()->mutable_image()->mutable_raw()->set_encoding("yuv422");
  expect_invalid(raw_encoding, "unknown encoding");

  v1::Frame short_data = MakeFrame(0, I);
  short_data.mutable_depth()->mutable_image()->mutable_raw()->mutable_data()->resize(100);
  expect_invalid(short_data, "bytes");

  v1::Frame no_colour = MakeFrame(0, I);
  no_colour.clear_colour();
  expect_invalid(no_colour, "no colour image");

  v1::Frame bad_scale = MakeFrame(0, I);
  bad_scale.mutable_depth()->set_depth_scale(0);
  expect_invalid(bad_scale, "depth_scale");

  v1::Frame no_stamp = MakeFrame(0, I);
  no_stamp.clear_timestamp();
  expect_invalid(no_stamp, "timestamp");
}

TEST_F(IngestServiceTest, PoseProblemsAreInvalidArgument) {
  v1::Frame zero_q = MakeFrame(0, Eigen::Isometry3d::Identity());
  zero_q.mutable_pose_prior()->mutable_orientation()->set_w(0);
  std::vector<v1::Frame> frames;
  frames.push_back(zero_q);
  EXPECT_EQ(StreamFrames(KnownPosesStart("lab", "p1"), std::move(frames)).code(),
            StatusCode::kInvalidArgument);

  v1::Frame nan_t = MakeFrame(0, Eigen::Isometry3d::Identity());
  nan_t.mutable_pose_prior()->mutable_position()->set_x(std::nan(""));
  frames.clear();
  frames.push_back(nan_t);
  EXPECT_EQ(StreamFrames(KnownPosesStart("lab", "p2"), std::move(frames)).code(),
            StatusCode::kInvalidArgument);

  v1::Frame no_pose = MakeFrame(0, Eigen::Isometry3d::Identity());
  no_pose.clear_pose_prior();
  frames.clear();
  frames.push_back(no_pose);
  const Status status = StreamFrames(KnownPosesStart("lab", "p3"), std::move(frames));
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("pose_prior"), std::string::npos) << status.message();
}

TEST_F(IngestServiceTest, OversizeFramesAreResourceExhausted) {
  // Above the frame payload limit (2 MiB) but under the message limit (4 MiB).
  v1::Frame big = MakeFrame(0, Eigen::Isometry3d::Identity());
  big.mutable_colour()->mutable_compressed()->mutable_data()->resize(3u << 20);
  std::vector<v1::Frame> frames;
  frames.push_back(big);
  EXPECT_EQ(StreamFrames(KnownPosesStart("lab", "big1"), std::move(frames)).code(),
            StatusCode::kResourceExhausted);
  // Above gRPC's receive limit: refused by the transport with the same code.
  big.mutable_colour()->mutable_compressed()->mutable_data()->resize(5u << 20);
  frames.clear();
  frames.push_back(big);
  EXPECT_EQ(StreamFrames(KnownPosesStart("lab", "big2"), std::move(frames)).code(),
            StatusCode::kResourceExhausted);
}

ExportRequest Export(const std::string& map, const std::string& format,
                     const std::string& session) {
  ExportRequest request;
  request.map = map;
  request.format = format;
  request.session = session;
  return request;
}

TEST_F(IngestServiceTest, UnknownMapOrSessionIsNotFound) {
  EXPECT_EQ(client_->ListSessions("nope").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(client_->GetTrajectory("nope", "x", false).status().code(), StatusCode::kNotFound);
  ASSERT_TRUE(Stream(KnownPosesStart("lab", "a"), 1).ok());
  EXPECT_EQ(client_->GetTrajectory("lab", "nope", false).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(client_->ExportMap(Export("nope", "json", "")).status().code(), StatusCode::kNotFound);
}

TEST_F(IngestServiceTest, ExportsAreChecksummed) {
  ASSERT_TRUE(Stream(KnownPosesStart("lab", "a"), 5).ok());
  auto tum = client_->ExportMap(Export("lab", "tum", ""));
  ASSERT_TRUE(tum.ok()) << tum.status().ToString();
  EXPECT_EQ(std::count(tum->bytes.begin(), tum->bytes.end(), '\n'), 2 + 5);
  auto json = client_->ExportMap(Export("lab", "json", "a"));
  ASSERT_TRUE(json.ok()) << json.status().ToString();
  EXPECT_NE(json->bytes.find("\"keyframes\""), std::string::npos);
  EXPECT_EQ(client_->ExportMap(Export("lab", "obj", "")).status().code(),
            StatusCode::kInvalidArgument);
}

TEST_F(IngestServiceTest, DataSurvivesRestart) {
  ASSERT_TRUE(Stream(KnownPosesStart("lab", "persist"), 12).ok());
  RestartServer();
  auto trajectory = client_->GetTrajectory("lab", "persist", false);
  ASSERT_TRUE(trajectory.ok()) << trajectory.status().ToString();
  EXPECT_EQ(trajectory->size(), 12u);
}

TEST_F(IngestServiceTest, SeveralSessionsAtOnce) {
  std::vector<std::thread> threads;
  std::vector<Status> results(3);
  threads.reserve(3);
  for (int s = 0; s < 3; ++s) {
    threads.emplace_back(
        [&, s] { results[s] = Stream(KnownPosesStart("multi", "s" + std::to_string(s)), 20); });
  }
  for (auto& t : threads) t.join();
  for (const Status& s : results) EXPECT_TRUE(s.ok()) << s.ToString();
  auto sessions = client_->ListSessions("multi");
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->size(), 3u);
  for (const SessionInfo& s : *sessions) EXPECT_EQ(s.frame_count, 20);
}

TEST_F(IngestServiceTest, ShutdownDuringIngestStoresWhatWasAcknowledged) {
  auto stream = client_->Ingest(KnownPosesStart("lab", "cut"));
  ASSERT_TRUE(stream.ok());
  const auto poses = CircleTrajectory(10);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE((*stream)->Write(MakeFrame(i, poses[i])).ok());
  std::thread stopper([&] { EXPECT_TRUE(server_->Shutdown().ok()); });
  const Status status = (*stream)->Finish().status();
  stopper.join();
  // Either the end won the race (OK) or the server refused the rest (UNAVAILABLE).
  EXPECT_TRUE(status.ok() || status.code() == StatusCode::kUnavailable) << status.ToString();
  const std::optional<uint64_t> durable = (*stream)->durable_seq();
  stream->reset();
  client_.reset();
  server_.reset();  // releases the data directory's lock
  StartServer();
  auto trajectory = client_->GetTrajectory("lab", "cut", false);
  ASSERT_TRUE(trajectory.ok());
  if (durable) {
    EXPECT_GE(trajectory->size(), *durable + 1);
  }
}

}  // namespace
}  // namespace semmap
