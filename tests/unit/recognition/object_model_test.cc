// Object models from photos: the room's object photos build good views at any size and pixel
// type; photos a user could not recognise anything from are INVALID_ARGUMENT with a reason.
#include "core/recognition/object_model.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "tests/testing/synth/object_template.h"
#include "tests/unit/recognition/recognition_scene.h"

namespace semmap {
namespace {

using recognition_test::Room;
using recognition_test::RoomModels;
using recognition_test::RoomRenderer;

cv::Mat Photo(size_t object) {
  StatusOr<cv::Mat> photo = synth::RenderObjectTemplate(RoomRenderer(), Room().objects[object]);
  EXPECT_TRUE(photo.ok());
  return photo.ok() ? *photo : cv::Mat();
}

void ExpectInsidePhoto(const ModelView& view) {
  for (const cv::KeyPoint& k : view.features.keypoints) {
    ASSERT_GE(k.pt.x, 0.0f);
    ASSERT_GE(k.pt.y, 0.0f);
    ASSERT_LT(k.pt.x, static_cast<float>(view.width));
    ASSERT_LT(k.pt.y, static_cast<float>(view.height));
  }
}

TEST(ObjectModelTest, EveryRoomObjectPhotoMakesAView) {
  const std::vector<ObjectModel>& models = RoomModels();
  ASSERT_EQ(models.size(), Room().objects.size());
  for (size_t i = 0; i < models.size(); ++i) {
    const ObjectModel& m = models[i];
    EXPECT_EQ(m.type_id, static_cast<int64_t>(i + 1));
    EXPECT_EQ(m.label, Room().objects[i].label);
    ASSERT_EQ(m.views.size(), 1u);
    const ModelView& v = m.views[0];
    const cv::Mat photo = Photo(i);
    EXPECT_EQ(v.width, photo.cols);
    EXPECT_EQ(v.height, photo.rows);
    EXPECT_GE(v.features.size(), 300u) << m.label;
    EXPECT_EQ(v.features.descriptors.rows, static_cast<int>(v.features.size()));
    EXPECT_EQ(v.features.descriptors.type(), CV_8UC1);
    EXPECT_EQ(v.features.descriptors.cols, 32);
    EXPECT_EQ(v.features.NumWithDepth(), 0u);
    ExpectInsidePhoto(v);
  }
}

TEST(ObjectModelTest, LargePhotosAreShrunkButKeepTheirPixelFrame) {
  const cv::Mat photo = Photo(0);  // the book, 236 x 314
  cv::Mat big;
  cv::resize(photo, big, cv::Size(), 8.0, 8.0, cv::INTER_CUBIC);  // 1888 x 2512
  StatusOr<ModelView> small_view = BuildModelView(photo, ObjectRecognitionOptions());
  StatusOr<ModelView> big_view = BuildModelView(big, ObjectRecognitionOptions());
  ASSERT_TRUE(small_view.ok() && big_view.ok()) << big_view.status().ToString();
  EXPECT_EQ(big_view->width, big.cols);
  EXPECT_EQ(big_view->height, big.rows);
  ExpectInsidePhoto(*big_view);
  // Keypoints reach across the whole big photo, not just its first 640 px.
  float max_y = 0;
  for (const cv::KeyPoint& k : big_view->features.keypoints) max_y = std::max(max_y, k.pt.y);
  EXPECT_GT(max_y, 0.8f * static_cast<float>(big.rows));
  // Extraction ran at <= 640 px: no more features than the budget of all octaves.
  EXPECT_LE(big_view->features.size(), 400u + 200u + 100u + 50u);
}

TEST(ObjectModelTest, GreyBgraAndEncodedPhotosWork) {
  const cv::Mat photo = Photo(2);
  cv::Mat grey, bgra;
  cv::cvtColor(photo, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(photo, bgra, cv::COLOR_BGR2BGRA);
  const ObjectRecognitionOptions options;
  StatusOr<ModelView> from_grey = BuildModelView(grey, options);
  StatusOr<ModelView> from_bgra = BuildModelView(bgra, options);
  ASSERT_TRUE(from_grey.ok()) << from_grey.status().ToString();
  ASSERT_TRUE(from_bgra.ok()) << from_bgra.status().ToString();
  EXPECT_EQ(from_grey->features.size(), from_bgra->features.size());

  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", photo, png));
  StatusOr<ModelView> decoded =
      BuildModelViewFromEncoded(std::string(png.begin(), png.end()), options);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  EXPECT_EQ(decoded->features.size(), RoomModels()[2].views[0].features.size());
}

void ExpectInvalid(const StatusOr<ModelView>& view, const std::string& fragment) {
  ASSERT_FALSE(view.ok());
  EXPECT_EQ(view.status().code(), StatusCode::kInvalidArgument) << view.status().ToString();
  EXPECT_NE(view.status().message().find(fragment), std::string::npos) << view.status().message();
}

TEST(ObjectModelTest, BadPhotosAreInvalidArgumentWithAReason) {
  const ObjectRecognitionOptions options;
  ExpectInvalid(BuildModelView(cv::Mat(), options), "empty");
  ExpectInvalid(BuildModelView(cv::Mat(100, 100, CV_16UC1, cv::Scalar(0)), options), "8-bit");
  // Plain grey: no corners at all.
  ExpectInvalid(BuildModelView(cv::Mat(400, 300, CV_8UC3, cv::Scalar(128, 128, 128)), options),
                "only 0 features");
  // A tiny thumbnail of a textured photo, and a photo blurred past recognition.
  cv::Mat tiny, blurred;
  cv::resize(Photo(0), tiny, cv::Size(24, 32), 0, 0, cv::INTER_AREA);
  ExpectInvalid(BuildModelView(tiny, options), "too small");
  ExpectInvalid(BuildModelView(cv::Mat(1, 1, CV_8UC3, cv::Scalar(0, 0, 0)), options), "too small");
  cv::resize(Photo(0), tiny, cv::Size(48, 64), 0, 0, cv::INTER_AREA);
  ExpectInvalid(BuildModelView(tiny, options), "a recognisable object needs 50");
  cv::GaussianBlur(Photo(0), blurred, cv::Size(0, 0), 12.0);
  ExpectInvalid(BuildModelView(blurred, options), "sharper, more textured or larger photo");
  // Bytes that are no image.
  ExpectInvalid(BuildModelViewFromEncoded("", options), "empty");
  ExpectInvalid(BuildModelViewFromEncoded("definitely not a png", options), "does not decode");
  // A truncated PNG.
  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", Photo(1), png));
  ExpectInvalid(BuildModelViewFromEncoded(std::string(png.begin(), png.begin() + 40), options),
                "does not decode");
}

TEST(ObjectModelTest, AModelNamesItsBadPhoto) {
  StatusOr<ObjectModel> model = BuildObjectModel(
      7, "book", {Photo(0), cv::Mat(50, 50, CV_8UC1, cv::Scalar(0))}, ObjectRecognitionOptions());
  ASSERT_FALSE(model.ok());
  EXPECT_EQ(model.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(model.status().message().rfind("photo 2: ", 0), 0u) << model.status().message();
  EXPECT_FALSE(BuildObjectModel(7, "book", {}, ObjectRecognitionOptions()).ok());
}

TEST(ObjectModelTest, OptionsAreValidated) {
  EXPECT_TRUE(ObjectRecognitionOptions().Validate().ok());
  const auto invalid = [](auto edit) {
    ObjectRecognitionOptions o;
    edit(o);
    return o.Validate().code() == StatusCode::kInvalidArgument;
  };
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.matcher.ratio = 0; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.min_inliers = 3; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.min_good_matches = 5; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.min_inliers_with_depth = 13; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.ransac_reprojection_px = -1; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.max_xi = 0; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.max_xi = NAN; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.max_photo_side_px = 10; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.photo_scales = 0; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.extent_low_percentile = 95; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.min_corner_angle_deg = 90; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.max_side_ratio = 0.5; }));
  EXPECT_TRUE(
      invalid([](ObjectRecognitionOptions& o) { o.photo_features.type = FeatureType::kSift; }));
  EXPECT_TRUE(invalid([](ObjectRecognitionOptions& o) { o.plane_tolerance_m = 0; }));
}

}  // namespace
}  // namespace semmap
