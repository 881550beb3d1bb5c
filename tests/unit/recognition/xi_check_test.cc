// The xi neighbour check: the rule and its edge cases, and on rendered keyframes, a real
// object (seen by its neighbours too) is accepted while a transient picture of an object
// (pasted into one keyframe only: a perceptual alias) is detected but rejected.
#include "common/xi_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/recognition/keyframe_recognition.h"
#include "tests/testing/synth/object_template.h"
#include "tests/unit/recognition/recognition_scene.h"

namespace semmap {
namespace {

using recognition_test::FacingPose;
using recognition_test::Keyframe;
using recognition_test::MakeKeyframe;
using recognition_test::Room;
using recognition_test::RoomCamera;
using recognition_test::RoomModels;

TEST(XiCheckTest, TheRule) {
  XiDecision d = CheckXi(30, {28, 20}, 1.25);
  EXPECT_TRUE(d.accepted());
  EXPECT_EQ(d.verdict, XiVerdict::kAccepted);
  EXPECT_EQ(d.n_c, 30);
  EXPECT_EQ(d.n_n, 28);  // the best neighbour
  EXPECT_DOUBLE_EQ(d.xi, 30.0 / 28.0);

  d = CheckXi(30, {20, 10}, 1.25);
  EXPECT_FALSE(d.accepted());
  EXPECT_EQ(d.verdict, XiVerdict::kRejected);
  EXPECT_DOUBLE_EQ(d.xi, 1.5);
  EXPECT_EQ(XiVerdictName(d.verdict), "xi too high");

  // Exactly max_xi is accepted; just above is not.
  EXPECT_TRUE(CheckXi(25, {20}, 1.25).accepted());
  EXPECT_FALSE(CheckXi(26, {20}, 1.25).accepted());
  // Fewer matches than the neighbours: fine (the object is better seen from there).
  EXPECT_TRUE(CheckXi(10, {40}, 1.25).accepted());
  // Another threshold.
  EXPECT_TRUE(CheckXi(30, {20}, 2.0).accepted());
}

TEST(XiCheckTest, EdgeCases) {
  // No neighbours: accepted (a session's only keyframe), xi not computed; or held back.
  XiDecision d = CheckXi(30, {}, 1.25);
  EXPECT_TRUE(d.accepted());
  EXPECT_EQ(d.verdict, XiVerdict::kAcceptedWithoutNeighbours);
  EXPECT_EQ(d.xi, 0.0);
  d = CheckXi(30, {}, 1.25, /*allow_without_neighbours=*/false);
  EXPECT_FALSE(d.accepted());
  EXPECT_EQ(d.verdict, XiVerdict::kNoNeighbours);
  // Neighbours that see none of it: infinite xi, rejected.
  d = CheckXi(30, {0, 0}, 1.25);
  EXPECT_FALSE(d.accepted());
  EXPECT_EQ(d.xi, std::numeric_limits<double>::infinity());
  // Nothing in this keyframe: xi 0, nothing to reject.
  d = CheckXi(0, {0}, 1.25);
  EXPECT_TRUE(d.accepted());
  EXPECT_EQ(d.xi, 0.0);
  // Negative counts read as 0.
  d = CheckXi(-3, {-1}, 1.25);
  EXPECT_TRUE(d.accepted());
  EXPECT_EQ(d.n_c, 0);
  EXPECT_EQ(d.n_n, 0);
}

// Pastes `object`'s photo, 160 px tall, into the left of the image.
void Paste(const synth::NamedObject& object, cv::Mat* bgr) {
  StatusOr<cv::Mat> photo = synth::RenderObjectTemplate(recognition_test::RoomRenderer(), object);
  ASSERT_TRUE(photo.ok());
  cv::Mat small;
  cv::resize(*photo, small, cv::Size(photo->cols * 160 / photo->rows, 160), 0, 0, cv::INTER_AREA);
  small.copyTo((*bgr)(cv::Rect(40, 200, small.cols, small.rows)));
}

TEST(XiCheckTest, ARealObjectPassesAndATransientPictureOfOneIsRejected) {
  // Three keyframes 5 degrees apart looking at the poster (type 3); the book (type 1) is out of
  // view, but the middle keyframe shows a picture of it (a page held up for a moment).
  const synth::NamedObject& poster = Room().objects[2];
  const synth::NamedObject& book = Room().objects[0];
  std::vector<Keyframe> kfs;
  for (double yaw : {-0.087, 0.0, 0.087}) kfs.push_back(MakeKeyframe(FacingPose(poster, 1.8, yaw)));
  Paste(book, &kfs[1].frame.bgr);
  kfs[1].features = recognition_test::ExtractFeatures(kfs[1].frame);

  StatusOr<KeyframeRecognition> r =
      RecogniseKeyframe(kfs[1].features, RoomCamera(), {&kfs[0].features, &kfs[2].features},
                        RoomModels(), ObjectRecognitionOptions());
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const RecognisedObject* poster_found = nullptr;
  const RecognisedObject* book_found = nullptr;
  for (const RecognisedObject& x : r->found) {
    if (x.detection.label == "mug_poster") poster_found = &x;
    if (x.detection.label == "book") book_found = &x;
  }
  ASSERT_NE(poster_found, nullptr);
  ASSERT_NE(book_found, nullptr) << "the pasted picture should pass the geometric check";
  std::printf("poster: xi %.2f (N_c %d, N_n %d); pasted book: xi %.2f (N_c %d, N_n %d)\n",
              poster_found->xi.xi, poster_found->xi.n_c, poster_found->xi.n_n, book_found->xi.xi,
              book_found->xi.n_c, book_found->xi.n_n);
  EXPECT_TRUE(poster_found->xi.accepted());
  EXPECT_LT(poster_found->xi.xi, 1.25);
  EXPECT_FALSE(book_found->xi.accepted());
  EXPECT_GT(book_found->xi.xi, 2.0);
  ASSERT_EQ(r->Accepted().size(), 1u);
  EXPECT_EQ(r->Accepted()[0]->detection.label, "mug_poster");

  // Without neighbours (a one-keyframe session) both are accepted, xi unknown.
  StatusOr<KeyframeRecognition> alone = RecogniseKeyframe(kfs[1].features, RoomCamera(), {},
                                                          RoomModels(), ObjectRecognitionOptions());
  ASSERT_TRUE(alone.ok());
  EXPECT_EQ(alone->Accepted().size(), 2u);
  // And with the check off, too.
  StatusOr<KeyframeRecognition> off =
      RecogniseKeyframe(kfs[1].features, RoomCamera(), {&kfs[0].features, &kfs[2].features},
                        RoomModels(), ObjectRecognitionOptions(), /*apply_xi=*/false);
  ASSERT_TRUE(off.ok());
  EXPECT_EQ(off->Accepted().size(), 2u);
}

}  // namespace
}  // namespace semmap
