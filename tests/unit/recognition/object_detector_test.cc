// DetectObjects on rendered keyframes of the synthetic room: every object is found from in
// front and at an angle, at the centre of its front face; nothing is found where nothing is;
// the homography sanity check and the input checks.
#include "core/recognition/object_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/recognition/keyframe_recognition.h"
#include "tests/testing/synth/trajectory.h"
#include "tests/unit/recognition/recognition_scene.h"

namespace semmap {
namespace {

using recognition_test::FacingPose;
using recognition_test::Keyframe;
using recognition_test::MakeKeyframe;
using recognition_test::Room;
using recognition_test::RoomCamera;
using recognition_test::RoomModels;
using recognition_test::VisibleFraction;

const ObjectDetection* Find(const KeyframeDetections& d, int model) {
  for (const ObjectDetection& x : d.detections) {
    if (x.model_index == model) return &x;
  }
  return nullptr;
}

// Distances at which each room object fills 130-250 px of the 640 x 480 view.
double ViewingDistance(const synth::NamedObject& o) {
  return std::max(0.8, 525.0 * std::max(o.front.width, o.front.height) / 320.0);
}

void ExpectFoundAtFaceCentre(const Eigen::Isometry3d& T, int model, const char* what) {
  const synth::NamedObject& object = Room().objects[static_cast<size_t>(model)];
  const Keyframe kf = MakeKeyframe(T);
  ASSERT_EQ(VisibleFraction(object, T, kf.frame), 1.0) << object.label << " " << what;
  StatusOr<KeyframeDetections> d =
      DetectObjects(kf.features, RoomCamera(), RoomModels(), ObjectRecognitionOptions());
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  const ObjectDetection* det = Find(*d, model);
  ASSERT_NE(det, nullptr) << object.label << " " << what << ": good matches "
                          << d->good_matches[static_cast<size_t>(model)];
  EXPECT_EQ(det->label, object.label);
  EXPECT_EQ(det->type_id, model + 1);
  EXPECT_EQ(det->view_index, 0);
  EXPECT_GE(det->inliers, 12);
  EXPECT_GE(det->inliers_with_depth, 8);
  EXPECT_EQ(static_cast<int>(det->inlier_indices.size()), det->inliers);
  EXPECT_TRUE(std::is_sorted(det->inlier_indices.begin(), det->inlier_indices.end()));
  EXPECT_EQ(det->matches, d->good_matches[static_cast<size_t>(model)]);
  // Truth: the centre of the front face (the photo's centre), not the bounding box's.
  const Eigen::Vector3d p_world = T * det->p_keyframe;
  const double error = (p_world - object.front.Centre()).norm();
  const double box_error = (p_world - object.centre).norm();
  std::printf("%-10s %-8s inliers %3d/%3d  error %.4f m (%s; box centre %.3f m away)\n",
              object.label.c_str(), what, det->inliers, det->matches, error,
              std::string(PositionSourceName(det->position_source)).c_str(), box_error);
  EXPECT_LT(error, 0.05) << object.label << " " << what;
  EXPECT_EQ(det->position_source, PositionSource::kPlane) << object.label << " " << what;
  // The extent: within the face's size (plus a little depth), not nothing.
  const double diagonal = std::hypot(object.front.width, object.front.height);
  EXPECT_LT(det->extent.norm(), 1.1 * diagonal) << object.label;
  EXPECT_GT(det->extent.norm(), 0.25 * diagonal) << object.label;
  // Only this object is in view (the others are elsewhere in the room).
  for (const ObjectDetection& other : d->detections) {
    if (other.model_index == model) continue;
    EXPECT_GT(VisibleFraction(Room().objects[static_cast<size_t>(other.model_index)], T, kf.frame),
              0.0)
        << other.label << " detected in a view of " << object.label;
  }
}

TEST(ObjectDetectorTest, FindsEveryObjectHeadOnAtItsFaceCentre) {
  for (size_t i = 0; i < Room().objects.size(); ++i) {
    const synth::NamedObject& o = Room().objects[i];
    ExpectFoundAtFaceCentre(FacingPose(o, ViewingDistance(o)), static_cast<int>(i), "head-on");
  }
}

TEST(ObjectDetectorTest, FindsEveryObjectAtAnAngleAndFromAbove) {
  const double deg = std::numbers::pi / 180.0;
  for (size_t i = 0; i < Room().objects.size(); ++i) {
    const synth::NamedObject& o = Room().objects[i];
    const double d = ViewingDistance(o);
    ExpectFoundAtFaceCentre(FacingPose(o, d, 35 * deg), static_cast<int>(i), "35 deg");
    ExpectFoundAtFaceCentre(FacingPose(o, d, -25 * deg, 0.4), static_cast<int>(i), "above");
  }
}

TEST(ObjectDetectorTest, NothingIsFoundWhereNoObjectIs) {
  // Bare walls and the floor: views that see none of the objects.
  const std::vector<Eigen::Isometry3d> views = {
      synth::LookingPose({0.0, 0.0, 1.4}, 0.5 * std::numbers::pi, 0.5),    // +y wall, high
      synth::LookingPose({0.5, 0.0, 1.3}, 0.0, 0.4),                       // +x wall, high
      synth::LookingPose({0.0, 0.5, 1.3}, -0.5 * std::numbers::pi, -1.0),  // the floor
      synth::LookingPose({0.0, 0.0, 1.3}, std::numbers::pi, 0.35)};        // -x wall, high
  for (const Eigen::Isometry3d& T : views) {
    const Keyframe kf = MakeKeyframe(T);
    for (const synth::NamedObject& o : Room().objects) {
      ASSERT_EQ(VisibleFraction(o, T, kf.frame), 0.0) << o.label;
    }
    StatusOr<KeyframeDetections> d =
        DetectObjects(kf.features, RoomCamera(), RoomModels(), ObjectRecognitionOptions());
    ASSERT_TRUE(d.ok());
    EXPECT_TRUE(d->detections.empty()) << d->detections.front().label;
    for (int n : d->good_matches) EXPECT_LT(n, 30);  // chance level: ~8-20
  }
}

TEST(ObjectDetectorTest, CountGoodMatchesAgreesWithDetect) {
  const synth::NamedObject& book = Room().objects[0];
  const Keyframe kf = MakeKeyframe(FacingPose(book, 1.0));
  StatusOr<KeyframeDetections> d =
      DetectObjects(kf.features, RoomCamera(), RoomModels(), ObjectRecognitionOptions());
  ASSERT_TRUE(d.ok());
  for (size_t i = 0; i < RoomModels().size(); ++i) {
    StatusOr<int> n =
        CountGoodMatches(RoomModels()[i], kf.features, ObjectRecognitionOptions().matcher);
    ASSERT_TRUE(n.ok());
    EXPECT_EQ(*n, d->good_matches[i]);
  }
}

TEST(ObjectDetectorTest, TheBestOfSeveralViewsIsReported) {
  // A model with a useless view (another object's photo) first and the right one second.
  ObjectModel two = RoomModels()[0];
  two.views.insert(two.views.begin(), RoomModels()[3].views[0]);
  const Keyframe kf = MakeKeyframe(FacingPose(Room().objects[0], 1.0));
  StatusOr<KeyframeDetections> d =
      DetectObjects(kf.features, RoomCamera(), {two}, ObjectRecognitionOptions());
  ASSERT_TRUE(d.ok());
  ASSERT_EQ(d->detections.size(), 1u);
  EXPECT_EQ(d->detections[0].view_index, 1);
}

TEST(ObjectDetectorTest, BadInputsAreInvalidArgument) {
  const Keyframe kf = MakeKeyframe(FacingPose(Room().objects[0], 1.0));
  const ObjectRecognitionOptions options;
  FrameFeatures broken = kf.features;
  broken.has_depth.pop_back();
  EXPECT_EQ(DetectObjects(broken, RoomCamera(), RoomModels(), options).status().code(),
            StatusCode::kInvalidArgument);
  ObjectModel wide = RoomModels()[0];
  wide.views[0].features.descriptors =
      cv::Mat(static_cast<int>(wide.views[0].features.size()), 64, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(DetectObjects(kf.features, RoomCamera(), {wide}, options).status().code(),
            StatusCode::kInvalidArgument);
  ObjectRecognitionOptions bad = options;
  bad.min_inliers = 2;
  EXPECT_EQ(DetectObjects(kf.features, RoomCamera(), RoomModels(), bad).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(DetectObjects(kf.features, CameraCalibration(), RoomModels(), options).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(RecogniseKeyframe(kf.features, RoomCamera(), {nullptr}, RoomModels(), options)
                .status()
                .code(),
            StatusCode::kInvalidArgument);

  // Nothing to match: no detections, zero counts; a model without views is skipped.
  StatusOr<KeyframeDetections> none =
      DetectObjects(FrameFeatures(), RoomCamera(), RoomModels(), options);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->detections.empty());
  EXPECT_EQ(none->good_matches, std::vector<int>(RoomModels().size(), 0));
  ObjectModel empty;
  empty.label = "nothing";
  StatusOr<KeyframeDetections> skipped = DetectObjects(kf.features, RoomCamera(), {empty}, options);
  ASSERT_TRUE(skipped.ok());
  EXPECT_TRUE(skipped->detections.empty());
}

TEST(ObjectDetectorTest, ToObservationCopiesTheDetection) {
  ObjectDetection d;
  d.type_id = 3;
  d.label = "mug";
  d.matches = 40;
  d.inliers = 30;
  d.p_keyframe = Eigen::Vector3d(0.1, 0.2, 1.5);
  d.extent = Eigen::Vector3d(0.2, 0.3, 0.05);
  const ObjectObservation o = ToObservation(d, 1.1);
  EXPECT_EQ(o.type_id, 3);
  EXPECT_EQ(o.label, "mug");
  EXPECT_EQ(o.matches, 40);
  EXPECT_EQ(o.inliers, 30);
  EXPECT_EQ(o.p_keyframe, d.p_keyframe);
  EXPECT_EQ(o.extent, d.extent);
  EXPECT_DOUBLE_EQ(o.xi, 1.1);
}

// The outline check on hand-made homographies of a 200 x 100 photo.
TEST(ProjectedOutlineTest, RejectsMirroredDegenerateTinyShearedAndHorizonCrossing) {
  const ObjectRecognitionOptions o;
  std::array<cv::Point2f, 4> outline{};
  const cv::Matx33d identity = cv::Matx33d::eye();
  ASSERT_TRUE(CheckProjectedOutline(identity, 200, 100, o, &outline).ok());
  EXPECT_EQ(outline[2], cv::Point2f(200, 100));
  // A similarity (rotated, scaled to a third, moved) and a moderate perspective are fine.
  const double c = std::cos(0.5), s = std::sin(0.5);
  EXPECT_TRUE(CheckProjectedOutline(cv::Matx33d(c / 3, -s / 3, 300, s / 3, c / 3, 200, 0, 0, 1),
                                    200, 100, o)
                  .ok());
  EXPECT_TRUE(CheckProjectedOutline(cv::Matx33d(1, 0, 0, 0, 1, 0, 0.002, 0, 1), 200, 100, o).ok());

  const auto rejected = [&](const cv::Matx33d& H, const std::string& fragment) {
    const Status st = CheckProjectedOutline(H, 200, 100, o);
    EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(st.message().find(fragment), std::string::npos) << st.message();
  };
  rejected(cv::Matx33d(-1, 0, 400, 0, 1, 0, 0, 0, 1), "mirrored");        // mirror image
  rejected(cv::Matx33d(1, 0, 0, 0.5, 0, 0, 0, 0, 1), "not convex");       // collapsed to a line
  rejected(cv::Matx33d(0.05, 0, 0, 0, 0.05, 0, 0, 0, 1), "covers only");  // 10 x 5 px
  rejected(cv::Matx33d(1, 3, 0, 0, 1, 0, 0, 0, 1), "corner of");          // wild shear
  // A trapezoid with sound corners (51 degrees) whose bottom is a fifth of its top.
  const std::vector<cv::Point2f> photo = {{0, 0}, {200, 0}, {200, 100}, {0, 100}};
  const std::vector<cv::Point2f> trapezoid = {{0, 0}, {200, 0}, {120, 100}, {80, 100}};
  cv::Matx33d H;
  cv::getPerspectiveTransform(photo, trapezoid).convertTo(cv::Mat(H, false), CV_64F);
  rejected(H, "sheared");
  rejected(cv::Matx33d(1, 0, 0, 0, 1, 0, -0.01, 0, 1), "horizon");  // the far corner behind
}

}  // namespace
}  // namespace semmap
