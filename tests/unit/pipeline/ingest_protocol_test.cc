// The stream's protocol rules on their own: start validation and the per-frame order, size and
// presence checks, each with the message a client sees.
#include "core/pipeline/ingest_protocol.h"

#include <gtest/gtest.h>

#include <string>

#include "tests/testing/synthetic_frames.h"

namespace semmap {
namespace {

IngestStartRequest GoodStart() {
  IngestStartRequest start;
  start.map = "lab";
  start.mode = SessionMode::kRgbd;
  start.camera = testing::TestCamera(64, 48);
  return start;
}

IngestFrame GoodFrame(uint64_t seq) {
  IngestFrame frame;
  frame.seq = seq;
  frame.stamp_ns = 1000;
  frame.colour = ImageMessage{};
  frame.payload_bytes = 10;
  return frame;
}

void ExpectError(const Status& status, StatusCode code, const std::string& fragment) {
  EXPECT_EQ(status.code(), code) << status.ToString();
  EXPECT_NE(status.message().find(fragment), std::string::npos) << status.message();
}

TEST(IngestProtocolTest, StartNeedsNamesModeCameraAndValidKeyframeOptions) {
  const KeyframePolicyOptions defaults;
  StatusOr<KeyframePolicyOptions> options = ValidateStart(GoodStart(), defaults);
  ASSERT_TRUE(options.ok()) << options.status().ToString();
  EXPECT_EQ(options->min_motion, defaults.min_motion);

  IngestStartRequest start = GoodStart();
  start.keyframe_min_motion = 0.5;
  options = ValidateStart(start, defaults);
  ASSERT_TRUE(options.ok());
  EXPECT_EQ(options->min_motion, 0.5);  // the session's choice over the server's

  start = GoodStart();
  start.map = "";
  EXPECT_EQ(ValidateStart(start, defaults).status().code(), StatusCode::kInvalidArgument);
  start = GoodStart();
  start.session = "bad\nname";
  EXPECT_EQ(ValidateStart(start, defaults).status().code(), StatusCode::kInvalidArgument);
  start = GoodStart();
  start.mode.reset();
  ExpectError(ValidateStart(start, defaults).status(), StatusCode::kInvalidArgument,
              "start.mode is unspecified");
  start = GoodStart();
  start.camera.fx = -1;
  ExpectError(ValidateStart(start, defaults).status(), StatusCode::kInvalidArgument,
              "start.camera");
  start = GoodStart();
  start.keyframe_min_motion = -1;
  ExpectError(ValidateStart(start, defaults).status(), StatusCode::kInvalidArgument,
              "start.keyframes");
}

TEST(IngestProtocolTest, FramesMustComeInOrderWithinLimitsWithStampAndColour) {
  FrameProtocol protocol(/*max_frame_bytes=*/100);
  EXPECT_TRUE(protocol.Check(GoodFrame(5)).ok());
  protocol.Accept(5);
  ExpectError(protocol.Check(GoodFrame(5)), StatusCode::kInvalidArgument,
              "frame seq 5 is not greater than the previous seq 5");
  ExpectError(protocol.Check(GoodFrame(kMaxFrameSeq + 1)), StatusCode::kInvalidArgument,
              "above the largest allowed seq, 2^63 - 1");
  EXPECT_TRUE(protocol.Check(GoodFrame(kMaxFrameSeq)).ok());

  IngestFrame big = GoodFrame(6);
  big.payload_bytes = 101;
  ExpectError(protocol.Check(big), StatusCode::kResourceExhausted,
              "carries 101 image bytes; the limit is 100");
  IngestFrame no_stamp = GoodFrame(6);
  no_stamp.stamp_ns.reset();
  ExpectError(protocol.Check(no_stamp), StatusCode::kInvalidArgument, "has no timestamp");
  IngestFrame no_colour = GoodFrame(6);
  no_colour.colour.reset();
  ExpectError(protocol.Check(no_colour), StatusCode::kInvalidArgument, "has no colour image");

  // The first failure wins: an old seq is reported before a missing stamp.
  no_stamp.seq = 3;
  ExpectError(protocol.Check(no_stamp), StatusCode::kInvalidArgument, "is not greater");
  EXPECT_EQ(protocol.last_seq(), 5u);
}

TEST(IngestProtocolTest, PosePriorsMustBeValidPoses) {
  IngestFrame frame = GoodFrame(1);
  EXPECT_TRUE(FrameProtocol::CheckPosePrior(frame).ok());  // none
  PoseTq pose;
  frame.pose_prior = pose;
  EXPECT_TRUE(FrameProtocol::CheckPosePrior(frame).ok());
  frame.pose_prior->q = Eigen::Quaterniond(0, 0, 0, 0);
  ExpectError(FrameProtocol::CheckPosePrior(frame), StatusCode::kInvalidArgument,
              "frame seq 1 pose_prior");
}

}  // namespace
}  // namespace semmap
