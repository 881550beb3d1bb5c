// What a hostile or broken client found (issue 11), through a real in-process server on
// loopback: each numbered finding with its status code and message, and that what the server
// acknowledged before is still there.
#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

#include "server/semmap_server.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/hostile_images.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

using testing::KnownPosesStart;
using testing::MakeFrame;

Eigen::Isometry3d At(double x, double y = 0, double z = 0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

std::string Serialized(const v1::IngestRequest& request) {
  std::string bytes;
  EXPECT_TRUE(request.SerializeToString(&bytes));
  return bytes;
}
v1::IngestRequest StartRequest(const v1::IngestStart& start) {
  v1::IngestRequest request;
  *request.mutable_start() = start;
  return request;
}
v1::IngestRequest FrameRequest(v1::Frame frame) {
  v1::IngestRequest request;
  *request.mutable_frame() = std::move(frame);
  return request;
}

// An Ingest call that sends raw bytes as messages (what a client that is not ours can send).
class RawIngestCall {
 public:
  explicit RawIngestCall(const std::shared_ptr<grpc::Channel>& channel) : stub_(channel) {
    context_.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    call_ = stub_.PrepareCall(&context_, "/semmap.v1.MapService/Ingest", &cq_);
    call_->StartCall(this);
    Wait();
  }
  ~RawIngestCall() {
    cq_.Shutdown();
    void* tag = nullptr;
    bool ok = false;
    while (cq_.Next(&tag, &ok)) {
    }
  }
  // False once the server has ended the call.
  bool Write(const std::string& bytes) {
    grpc::Slice slice(bytes);
    grpc::ByteBuffer buffer(&slice, 1);
    call_->Write(buffer, this);
    return Wait();
  }
  // Half-closes, reads every response and returns the final status.
  grpc::Status Finish() {
    call_->WritesDone(this);
    Wait();
    for (;;) {
      grpc::ByteBuffer buffer;
      call_->Read(&buffer, this);
      if (!Wait()) break;
      ++responses_;
    }
    grpc::Status status;
    call_->Finish(&status, this);
    Wait();
    return status;
  }

 private:
  bool Wait() {
    void* tag = nullptr;
    bool ok = false;
    EXPECT_TRUE(cq_.Next(&tag, &ok));
    return ok;
  }

  grpc::GenericStub stub_;
  grpc::ClientContext context_;
  grpc::CompletionQueue cq_;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call_;
  int responses_ = 0;
};

// The process's peak resident memory (the server runs in this process).
int64_t PeakRssKb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6));
  }
  return -1;
}

class HostileInputTest : public ::testing::Test {
 protected:
  void SetUp() override { StartServer(); }

  void StartServer() {
    ServerOptions options = options_;
    options.vocabulary_path.clear();
    auto started = testing::StartInProcessServer(options, dir_.path());
    ASSERT_TRUE(started.ok()) << started.status().ToString();
    server_ = std::move(started->server);
    client_ = std::move(started->client);
    channel_ = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
  }
  void RestartServer() {
    ASSERT_TRUE(server_->Shutdown().ok());
    client_.reset();
    server_.reset();
    StartServer();
  }

  // Good frames 0..good-1 along x, then `last` (if any); returns the final status.
  Status Stream(const std::string& session, int good, std::optional<v1::Frame> last,
                const std::string& map = "m") {
    auto stream = client_->Ingest(KnownPosesStart(map, session));
    if (!stream.ok()) return stream.status();
    for (int i = 0; i < good; ++i) {
      Status s = (*stream)->Write(MakeFrame(i, At(0.2 * i)));
      if (!s.ok()) return s;
    }
    if (last) {
      Status s = (*stream)->Write(std::move(*last));
      if (!s.ok()) return s;
    }
    return (*stream)->Finish().status();
  }

  size_t StoredFrames(const std::string& session, const std::string& map = "m") {
    auto trajectory = client_->GetTrajectory(map, session, false);
    EXPECT_TRUE(trajectory.ok()) << trajectory.status().ToString();
    return trajectory.ok() ? trajectory->size() : 0;
  }

  SessionInfo StoredSession(const std::string& session, const std::string& map = "m") {
    auto sessions = client_->ListSessions(map);
    EXPECT_TRUE(sessions.ok()) << sessions.status().ToString();
    for (const SessionInfo& s : sessions.ok() ? *sessions : std::vector<SessionInfo>{}) {
      if (s.name == session) return s;
    }
    ADD_FAILURE() << "no session " << session;
    return {};
  }

  void ExpectServing() {
    const StatusOr<std::string> health = client_->Health();
    EXPECT_TRUE(health.ok() && *health == "SERVING") << health.status().ToString();
    const Status again = Stream("still-alive-" + std::to_string(++alive_checks_), 3, std::nullopt);
    EXPECT_TRUE(again.ok()) << again.ToString();
  }

  testing::TempDir dir_;
  ServerOptions options_;
  std::unique_ptr<SemmapServer> server_;
  std::unique_ptr<MapClient> client_;
  std::shared_ptr<grpc::Channel> channel_;
  int alive_checks_ = 0;
};

void ExpectStatus(const Status& status, StatusCode code, const std::string& fragment) {
  EXPECT_EQ(status.code(), code) << status.ToString();
  EXPECT_NE(status.message().find(fragment), std::string::npos) << status.message();
}

// 1. A raw image whose width x height x bytes per pixel wraps around 2^64 aborted the server.
TEST_F(HostileInputTest, RawImageSizesThatWrapAroundAreRefused) {
  const uint32_t huge = 1u << 31;
  for (const char* encoding : {"32FC1", "16UC1", "rgb8"}) {
    v1::Frame frame = MakeFrame(2, At(0.4));
    v1::RawImage* raw = std::string(encoding) == "rgb8"
                            ? frame.mutable_colour()->mutable_raw()
                            : frame.mutable_depth()->mutable_image()->mutable_raw();
    raw->set_encoding(encoding);
    raw->set_width(huge);
    raw->set_height(huge);
    raw->set_step(0);
    raw->clear_data();
    const std::string session = std::string("wrap-") + encoding;
    const Status status = Stream(session, 2, std::move(frame));
    ExpectStatus(status, StatusCode::kInvalidArgument,
                 "is 2147483648x2147483648 but the session camera is 160x120");
    EXPECT_NE(status.message().find("frames up to seq 1 are stored"), std::string::npos);
    EXPECT_EQ(StoredFrames(session), 2u);
  }
  ExpectServing();
}

// Found by fuzz_image_decode: a raw depth step that splits a 16-bit sample (321 bytes for 160
// pixels) made OpenCV throw inside the session's decoder, ending the server.
TEST_F(HostileInputTest, RawStepsThatSplitASampleAreRefused) {
  v1::Frame frame = MakeFrame(2, At(0.4));
  v1::RawImage* raw = frame.mutable_depth()->mutable_image()->mutable_raw();
  raw->set_step(321);
  raw->set_data(std::string(size_t{321} * 120, '\0'));
  const Status status = Stream("split-sample", 2, std::move(frame));
  ExpectStatus(status, StatusCode::kInvalidArgument,
               "depth image step 321 is not a multiple of its 2-byte samples (16UC1)");
  EXPECT_NE(status.message().find("frames up to seq 1 are stored"), std::string::npos);
  EXPECT_EQ(StoredFrames("split-sample"), 2u);
  ExpectServing();
}

// 2. A message that does not parse ended the session OK, dropping everything after it.
TEST_F(HostileInputTest, UnparseableMessagesEndTheStreamWithInvalidArgument) {
  v1::Frame utf8 = MakeFrame(2, At(0.4));
  utf8.mutable_depth()->mutable_image()->mutable_raw()->set_encoding("16UC1\xff\xfe");
  const std::string truncated = Serialized(FrameRequest(MakeFrame(2, At(0.4))));
  const struct {
    const char* name;
    std::string bytes;
  } cases[] = {
      {"garbage", std::string("\xff\xff\xff\xff\x0f garbage that is no protobuf", 32)},
      {"truncated", truncated.substr(0, truncated.size() / 2)},
      {"utf8", Serialized(FrameRequest(utf8))},
  };
  for (const auto& c : cases) {
    const std::string session = std::string("bad-") + c.name;
    {
      RawIngestCall call(channel_);
      ASSERT_TRUE(call.Write(Serialized(StartRequest(KnownPosesStart("m", session)))));
      ASSERT_TRUE(call.Write(Serialized(FrameRequest(MakeFrame(0, At(0))))));
      ASSERT_TRUE(call.Write(Serialized(FrameRequest(MakeFrame(1, At(0.2))))));
      call.Write(c.bytes);
      // What follows must not be taken as if nothing had happened.
      call.Write(Serialized(FrameRequest(MakeFrame(3, At(0.6)))));
      v1::IngestRequest end;
      end.mutable_end();
      call.Write(Serialized(end));
      const Status status = FromGrpcStatus(call.Finish());
      ExpectStatus(status, StatusCode::kInvalidArgument,
                   "message 4 of the ingest stream (" + std::to_string(c.bytes.size()) +
                       " bytes) is not a valid semmap.v1.IngestRequest");
      EXPECT_NE(status.message().find("frames up to seq 1 are stored"), std::string::npos)
          << status.message();
    }
    EXPECT_EQ(StoredFrames(session), 2u) << c.name;
    EXPECT_EQ(StoredSession(session).end_reason, SessionEndReason::kError) << c.name;
  }
  // A start with invalid UTF-8 is named as what it is, not as a missing start.
  v1::IngestStart bad_start = KnownPosesStart("m\xc3\x28", "s");
  RawIngestCall call(channel_);
  call.Write(Serialized(StartRequest(bad_start)));
  const Status status = FromGrpcStatus(call.Finish());
  ExpectStatus(status, StatusCode::kInvalidArgument, "message 1 of the ingest stream");
  EXPECT_EQ(status.message().find("must be start"), std::string::npos) << status.message();
  ExpectServing();
}

// 3. A keyframe beyond the occupancy tree's extent failed its stream and, after a restart, the
// next session on the map; an absurd pose broke the map's PNG export for good.
TEST_F(HostileInputTest, FarKeyframesNeverPoisonAMap) {
  {
    auto stream = client_->Ingest(KnownPosesStart("far", "gps"));
    ASSERT_TRUE(stream.ok());
    for (int i = 0; i < 3; ++i) ASSERT_TRUE((*stream)->Write(MakeFrame(i, At(0.2 * i))).ok());
    ASSERT_TRUE((*stream)->Write(MakeFrame(3, At(1700))).ok());  // beyond +-1638 m at 5 cm
    ASSERT_TRUE((*stream)->Write(MakeFrame(4, At(0.8))).ok());
    auto summary = (*stream)->Finish();
    ASSERT_TRUE(summary.ok()) << summary.status().ToString();
    EXPECT_EQ(summary->frames(), 5u);
  }
  RestartServer();
  const Status after_restart = Stream("next", 4, std::nullopt, "far");
  EXPECT_TRUE(after_restart.ok()) << after_restart.ToString();
  for (const char* format : {"png", "ot", "pcd"}) {
    ExportRequest request;
    request.map = "far";
    request.format = format;
    auto exported = client_->ExportMap(request);
    EXPECT_TRUE(exported.ok()) << format << ": " << exported.status().ToString();
  }

  // UTM coordinates: the layers are built around the map's first keyframe, exports say where.
  {
    auto stream = client_->Ingest(KnownPosesStart("utm", "drive"));
    ASSERT_TRUE(stream.ok());
    for (int i = 0; i < 4; ++i) {
      ASSERT_TRUE((*stream)->Write(MakeFrame(i, At(690000.0 + 0.2 * i, 5335000.0, 2.0))).ok());
    }
    ASSERT_TRUE((*stream)->Finish().ok());
  }
  ExportRequest pcd;
  pcd.map = "utm";
  pcd.format = "pcd";
  pcd.ascii = true;
  auto cloud = client_->ExportMap(pcd);
  ASSERT_TRUE(cloud.ok()) << cloud.status().ToString();
  EXPECT_TRUE(cloud->layer_origin.isApprox(Eigen::Vector3d(690000, 5335000, 0)))
      << cloud->layer_origin.transpose();
  EXPECT_NE(cloud->bytes.find("# semmap layer_origin 690000 5335000 0"), std::string::npos);
  // The points are near the layer origin, at full float precision.
  std::istringstream lines(cloud->bytes.substr(cloud->bytes.find("DATA ascii\n") + 11));
  double x = 0, y = 0, z = 0;
  ASSERT_TRUE(lines >> x >> y >> z);
  EXPECT_LT(std::abs(x), 10.0);
  EXPECT_LT(std::abs(y), 10.0);
  EXPECT_LT(std::abs(z), 10.0);

  // Beyond 1e7 m is not a place: refused before its ack. 5e6 m is, and the picture still renders.
  const Status absurd = Stream("absurd", 2, MakeFrame(2, At(2e7)), "far");
  ExpectStatus(absurd, StatusCode::kInvalidArgument, "beyond 1e7 m on an axis");
  EXPECT_EQ(StoredFrames("absurd", "far"), 2u);
  EXPECT_TRUE(Stream("continental", 2, MakeFrame(2, At(5e6)), "far").ok());
  ExportRequest png;
  png.map = "far";
  png.format = "png";
  EXPECT_TRUE(client_->ExportMap(png).ok());

  // And the map's owner can take a bad session out: the layers are rebuilt without it.
  ASSERT_TRUE(client_->RemoveSession("far", "continental").ok());
  auto removed = client_->RemoveSession("far", "gps");
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(removed->frames, 5);
  EXPECT_EQ(client_->GetTrajectory("far", "gps", false).status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(client_->ExportMap(png).ok());
  ExportRequest ot;
  ot.map = "far";
  ot.format = "ot";
  EXPECT_TRUE(client_->ExportMap(ot).ok());
  EXPECT_EQ(StoredFrames("next", "far"), 4u);
  // The whole map too; another map is untouched.
  auto map_removed = client_->RemoveMap("far");
  ASSERT_TRUE(map_removed.ok()) << map_removed.status().ToString();
  EXPECT_EQ(client_->ListSessions("far").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(StoredFrames("drive", "utm"), 4u);
  EXPECT_EQ(client_->RemoveMap("far").status().code(), StatusCode::kNotFound);
}

TEST_F(HostileInputTest, RemovalIsRefusedWhileTheMapIsStreaming) {
  auto stream = client_->Ingest(KnownPosesStart("busy", "live"));
  ASSERT_TRUE(stream.ok());
  ASSERT_TRUE((*stream)->Write(MakeFrame(0, At(0))).ok());
  // The start was processed once the first ack is back.
  for (int i = 0; i < 200 && (*stream)->acks() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ExpectStatus(client_->RemoveMap("busy").status(), StatusCode::kFailedPrecondition,
               "has an ingest stream running");
  ExpectStatus(client_->RemoveSession("busy", "live").status(), StatusCode::kFailedPrecondition,
               "has an ingest stream running");
  ASSERT_TRUE((*stream)->Finish().ok());
  EXPECT_TRUE(client_->RemoveSession("busy", "live").ok());
}

// 4. seq >= 2^63 was acknowledged, then failed at commit (stored seqs are int64).
TEST_F(HostileInputTest, SeqAbove2To63IsRefusedBeforeItsAck) {
  v1::Frame frame = MakeFrame(0, At(0.4));
  frame.set_seq(uint64_t{1} << 63);
  const Status status = Stream("seq", 2, std::move(frame));
  ExpectStatus(status, StatusCode::kInvalidArgument, "above the largest allowed seq, 2^63 - 1");
  EXPECT_EQ(StoredFrames("seq"), 2u);
}

// Found by fuzz_ingest_request: seconds * 1e9 overflowed int64 for times past 2262.
TEST_F(HostileInputTest, TimestampsBeyondInt64NanosecondsAreRefused) {
  v1::Frame frame = MakeFrame(2, At(0.4));
  frame.mutable_timestamp()->set_seconds(18521711057);
  const Status status = Stream("far-future", 2, std::move(frame));
  ExpectStatus(status, StatusCode::kInvalidArgument, "frame seq 2: timestamp 18521711057 s");
  EXPECT_EQ(StoredFrames("far-future"), 2u);
  v1::Frame bad_nanos = MakeFrame(2, At(0.4));
  bad_nanos.mutable_timestamp()->set_nanos(-1);
  ExpectStatus(Stream("bad-nanos", 2, std::move(bad_nanos)), StatusCode::kInvalidArgument,
               "timestamp nanos -1 is not in 0..999999999");
}

// 5. The first half of a PNG was accepted and stored (only the first rows real).
TEST_F(HostileInputTest, TruncatedImagesAreInvalidArgument) {
  const cv::Mat bgr = testing::TexturedImage(160, 120, 3);
  const std::string png = testing::EncodePng(bgr);
  std::vector<uchar> jpeg_bytes;
  ASSERT_TRUE(cv::imencode(".jpg", bgr, jpeg_bytes));
  const std::string jpeg(jpeg_bytes.begin(), jpeg_bytes.end());
  const std::string depth_png = testing::EncodePng(testing::PlaneDepth(160, 120));
  for (const auto& [name, format, bytes, is_depth] :
       std::vector<std::tuple<std::string, std::string, std::string, bool>>{
           {"png", "png", png, false},
           {"jpeg", "jpeg", jpeg, false},
           {"depth", "png", depth_png, true}}) {
    v1::Frame frame = MakeFrame(2, At(0.4));
    v1::CompressedImage* compressed =
        is_depth ? frame.mutable_depth()->mutable_image()->mutable_compressed()
                 : frame.mutable_colour()->mutable_compressed();
    compressed->set_format(format);
    compressed->set_data(testing::Truncated(bytes, 0.5));
    const Status status = Stream("cut-" + name, 2, std::move(frame));
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << name << ": " << status.ToString();
    EXPECT_NE(status.message().find("frame seq 2"), std::string::npos) << status.message();
    EXPECT_NE(status.message().find("damaged"), std::string::npos) << status.message();
    EXPECT_EQ(StoredFrames("cut-" + name), 2u);
  }
}

// 6. A thread that could not be started destroyed a joinable std::thread (std::terminate), or
// answered UNIMPLEMENTED with an empty message.
TEST_F(HostileInputTest, ThreadStartFailureIsResourceExhausted) {
  auto calls = std::make_shared<std::atomic<int>>(0);
  auto fail_at = std::make_shared<std::atomic<int>>(0);  // 0: never
  options_.ingest.launch_thread = [calls,
                                   fail_at](std::function<void()> body) -> StatusOr<std::thread> {
    if (++*calls == fail_at->load()) return ResourceExhaustedError("no threads left (test)");
    return LaunchThread(std::move(body));
  };
  RestartServer();
  for (int which : {1, 2}) {  // the stream's first thread, then its second
    *calls = 0;
    *fail_at = which;
    const Status status = Stream("threads-" + std::to_string(which), 2, std::nullopt);
    ExpectStatus(status, StatusCode::kResourceExhausted, "no threads left (test)");
  }
  *fail_at = 0;
  ExpectServing();
}

// 7. A 425 kB PNG claiming 20000 x 20000 pixels cost 390 MB before it was refused.
TEST_F(HostileInputTest, DecompressionBombsAreRefusedFromTheirHeader) {
  const std::string bomb = testing::PngBomb(20000, 20000);
  const int64_t before_kb = PeakRssKb();
  v1::Frame frame = MakeFrame(2, At(0.4));
  frame.mutable_colour()->mutable_compressed()->set_data(bomb);
  const Status status = Stream("bomb", 2, std::move(frame));
  ExpectStatus(status, StatusCode::kInvalidArgument,
               "colour image is 20000x20000 but the session camera is 160x120");
  EXPECT_EQ(StoredFrames("bomb"), 2u);
  // Object photos have no camera to match: a pixel cap, read from the header too.
  std::vector<EncodedImage> photos = {{"png", bomb}};
  const Status photo = client_->RegisterObject("bomb", "", photos, std::nullopt).status();
  ExpectStatus(photo, StatusCode::kInvalidArgument, "the limit is 24 megapixels");
  const int64_t after_kb = PeakRssKb();
  EXPECT_LT(after_kb - before_kb, 100 * 1024)
      << "peak RSS grew from " << before_kb << " to " << after_kb << " kB";
}

// 8. Streams were not capped and never timed out: 300 idle streams held 619 threads.
TEST_F(HostileInputTest, StreamsAreCappedAndIdleOnesTimeOut) {
  options_.ingest.max_streams = 2;
  options_.ingest.idle_timeout_s = 1.0;
  RestartServer();
  auto first = client_->Ingest(KnownPosesStart("m", "idle-1"));
  auto second = client_->Ingest(KnownPosesStart("m", "idle-2"));
  ASSERT_TRUE(first.ok() && second.ok());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE((*second)->Write(MakeFrame(i, At(0.2 * i))).ok());
  auto third = client_->Ingest(KnownPosesStart("m", "one-too-many"));
  ASSERT_FALSE(third.ok());
  ExpectStatus(third.status(), StatusCode::kResourceExhausted,
               "limit of 2 concurrent ingest streams");
  std::this_thread::sleep_for(std::chrono::milliseconds(1800));
  for (auto* stream : {&*first, &*second}) {
    const Status late = (*stream)->Write(MakeFrame(10, At(2)));
    const Status final = late.ok() ? (*stream)->Finish().status() : late;
    ExpectStatus(final, StatusCode::kDeadlineExceeded, "no message from the client for 1 s");
  }
  EXPECT_EQ(StoredFrames("idle-2"), 3u);  // what it sent is kept
  const SessionInfo idle = StoredSession("idle-2");
  EXPECT_EQ(idle.end_reason, SessionEndReason::kIdleTimeout);
  EXPECT_NE(idle.end_message.find("DEADLINE_EXCEEDED"), std::string::npos) << idle.end_message;
  // Their places are free again.
  EXPECT_TRUE(Stream("after-idle", 2, std::nullopt).ok());
}

// The operator's frame-rate limit per session (issue 15): a stream over it ends with
// RESOURCE_EXHAUSTED naming the limit and keeps what came before; other streams are unaffected.
TEST_F(HostileInputTest, StreamsFasterThanTheSessionFrameRateLimitEnd) {
  options_.ingest.max_frames_per_second = 5;  // bursts of 10 frames
  RestartServer();
  const Status flood = Stream("flood", 60, std::nullopt);
  ExpectStatus(flood, StatusCode::kResourceExhausted,
               "limit of 5 frames/s per session (semmapd --max-session-fps)");
  const size_t stored = StoredFrames("flood");
  EXPECT_GE(stored, 10u);  // the burst
  EXPECT_LT(stored, 60u);
  EXPECT_EQ(StoredSession("flood").end_reason, SessionEndReason::kError);
  EXPECT_TRUE(Stream("within-burst", 8, std::nullopt).ok());
  EXPECT_EQ(StoredFrames("within-burst"), 8u);
  ExpectServing();
}

// 9. SessionInfo.ended did not say what happened; now end_reason does.
TEST_F(HostileInputTest, SessionsSayHowTheyEnded) {
  ASSERT_TRUE(Stream("completed", 2, std::nullopt).ok());
  v1::Frame stale = MakeFrame(0, At(0));
  EXPECT_FALSE(Stream("error", 2, std::move(stale)).ok());
  {
    auto stream = client_->Ingest(KnownPosesStart("m", "cancelled"));
    ASSERT_TRUE(stream.ok());
    ASSERT_TRUE((*stream)->Write(MakeFrame(0, At(0))).ok());
    (*stream)->Cancel();
  }
  auto stopped = client_->Ingest(KnownPosesStart("m", "stopped"));
  ASSERT_TRUE(stopped.ok());
  ASSERT_TRUE((*stopped)->Write(MakeFrame(0, At(0))).ok());
  for (int i = 0; i < 200 && (*stopped)->acks() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(server_->Shutdown().ok());
  stopped->reset();
  client_.reset();
  server_.reset();
  {
    // What a crashed server leaves: a session that never ended.
    auto store = SqliteMapStore::Open(dir_.File("semmap.db"), SqliteOptions{});
    ASSERT_TRUE(store.ok());
    auto map = (*store)->GetOrCreateMap("m");
    SessionInfo open;
    open.map_id = map->id;
    open.name = "crashed";
    open.camera = testing::TestCamera();
    ASSERT_TRUE((*store)->CreateSession(open).ok());
  }
  StartServer();
  const std::pair<const char*, SessionEndReason> expected[] = {
      {"completed", SessionEndReason::kCompleted},
      {"error", SessionEndReason::kError},
      {"cancelled", SessionEndReason::kCancelled},
      {"stopped", SessionEndReason::kServerStopped},
      {"crashed", SessionEndReason::kCrashed}};
  for (const auto& [name, reason] : expected) {
    const SessionInfo s = StoredSession(name);
    EXPECT_EQ(s.end_reason, reason) << name << ": " << SessionEndReasonName(s.end_reason);
    EXPECT_EQ(s.ended_unix_ns == 0, reason == SessionEndReason::kCrashed) << name;
  }
  EXPECT_NE(StoredSession("error").end_message.find("INVALID_ARGUMENT"), std::string::npos);
  EXPECT_NE(StoredSession("stopped").end_message.find("UNAVAILABLE"), std::string::npos);
}

// 10. RegisterObject with a 1 ms deadline answered DEADLINE_EXCEEDED, yet registered the object.
TEST_F(HostileInputTest, ACallPastItsDeadlineTakesNoEffect) {
  auto stub = v1::MapService::NewStub(channel_);
  v1::RegisterObjectRequest request;
  request.set_label("book");
  v1::CompressedImage* photo = request.add_photos();
  photo->set_format("png");
  photo->set_data(testing::EncodePng(testing::TexturedImage(640, 480, 9)));
  {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(1));
    v1::RegisterObjectResponse response;
    const grpc::Status status = stub->RegisterObject(&context, request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  }
  // The server may still be describing the photo: give it time to finish, then look.
  std::this_thread::sleep_for(std::chrono::seconds(2));
  auto types = client_->ListObjectTypes("");
  ASSERT_TRUE(types.ok());
  EXPECT_TRUE(types->empty()) << types->size() << " types; first " << (*types)[0].label;
  // With time to finish, the same request registers.
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::RegisterObjectResponse response;
  const grpc::Status status = stub->RegisterObject(&context, request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(client_->ListObjectTypes("")->size(), 1u);
}

// Unary requests that do not parse are refused and change nothing (gRPC itself answered them
// UNIMPLEMENTED with an empty message).
TEST_F(HostileInputTest, UnparseableUnaryRequestsAreRefused) {
  grpc::GenericStub stub(channel_);
  grpc::CompletionQueue cq;
  const std::string garbage("\x0a\xff\xff\xff\xff\x0f truncated", 16);
  grpc::ClientContext context;
  grpc::Slice slice(garbage);
  grpc::ByteBuffer request(&slice, 1), response;
  auto call = stub.PrepareUnaryCall(&context, "/semmap.v1.MapService/RegisterObject", request, &cq);
  call->StartCall();
  grpc::Status status;
  call->Finish(&response, &status, this);
  void* tag = nullptr;
  bool ok = false;
  ASSERT_TRUE(cq.Next(&tag, &ok));
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find(
                "the request (16 bytes) is not a valid semmap.v1.RegisterObjectRequest"),
            std::string::npos)
      << status.error_message();
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  EXPECT_TRUE(client_->ListObjectTypes("")->empty());
}

}  // namespace
}  // namespace semmap
