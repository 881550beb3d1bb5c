#include "client/datasets/kitti_dataset.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "client/datasets/dataset.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/client/dataset_test_util.h"

namespace semmap {
namespace {

using testing::TempDir;
using testing::WriteFile;

bool Contains(const Status& status, const std::string& text) {
  return status.message().find(text) != std::string::npos;
}

constexpr char kCalib[] =
    "P0: 7.070912000000e+02 0.000000000000e+00 6.018873000000e+02 0.000000000000e+00 "
    "0.000000000000e+00 7.070912000000e+02 1.831104000000e+02 0.000000000000e+00 "
    "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n"
    "P1: 7.070912000000e+02 0 6.018873000000e+02 -3.798145000000e+02 0 7.070912000000e+02 "
    "1.831104000000e+02 0 0 0 1 0\n";

// Three frames, 1226x370, scientific-notation times.
class KittiDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteFile(tmp_.File("calib.txt"), kCalib);
    WriteFile(tmp_.File("times.txt"), "0.000000e+00\n1.038752e-01\n2.078941e-01\n");
    for (int i = 0; i < 3; ++i) WriteFile(Image(i), testing::PngHeader(1226, 370));
  }
  std::string Image(int i) const {
    char name[32];
    std::snprintf(name, sizeof(name), "image_0/%06d.png", i);
    return tmp_.File(name);
  }

  TempDir tmp_;
};

TEST_F(KittiDatasetTest, ReadsCalibTimesAndImageSize) {
  StatusOr<Dataset> dataset = OpenDataset(tmp_.path());
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->kind, "kitti");
  EXPECT_TRUE(dataset->colour_is_grey);
  EXPECT_EQ(dataset->depth_scale, 0);
  EXPECT_EQ(dataset->camera.width, 1226);
  EXPECT_EQ(dataset->camera.height, 370);
  EXPECT_DOUBLE_EQ(dataset->camera.fx, 707.0912);
  EXPECT_DOUBLE_EQ(dataset->camera.fy, 707.0912);
  EXPECT_DOUBLE_EQ(dataset->camera.cx, 601.8873);
  EXPECT_DOUBLE_EQ(dataset->camera.cy, 183.1104);
  EXPECT_FALSE(dataset->camera.HasDistortion());
  ASSERT_EQ(dataset->frames.size(), 3u);
  EXPECT_EQ(dataset->frames[0].stamp_ns, 0);
  EXPECT_EQ(dataset->frames[1].stamp_ns, 103'875'200);
  EXPECT_EQ(dataset->frames[2].stamp_ns, 207'894'100);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(dataset->frames[i].seq, i);
    EXPECT_EQ(dataset->frames[i].colour_path, Image(i));
    EXPECT_FALSE(dataset->frames[i].depth_path);
  }
  EXPECT_TRUE(dataset->ground_truth.empty());
}

TEST_F(KittiDatasetTest, PosesBecomeGroundTruthWithFrameStamps) {
  WriteFile(tmp_.File("poses.txt"),
            "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 1.5\n1 0 0 0 0 1 0 0 0 0 1 3\n");
  StatusOr<Dataset> dataset = OpenDataset(tmp_.path());
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  ASSERT_EQ(dataset->ground_truth.size(), 3u);
  EXPECT_EQ(dataset->ground_truth[2].stamp_ns, 207'894'100);
  EXPECT_DOUBLE_EQ(dataset->ground_truth[1].T_world_camera.translation().z(), 1.5);
}

TEST_F(KittiDatasetTest, PoseCountMustMatchTimes) {
  WriteFile(tmp_.File("poses.txt"), "1 0 0 0 0 1 0 0 0 0 1 0\n");
  StatusOr<Dataset> dataset = OpenDataset(tmp_.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "1 poses but 3 timestamps")) << dataset.status().message();
}

TEST_F(KittiDatasetTest, MissingImageIsNotFoundNamingIt) {
  std::filesystem::remove(Image(2));
  StatusOr<Dataset> dataset = OpenDataset(tmp_.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_EQ(dataset.status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(Contains(dataset.status(), Image(2))) << dataset.status().message();
}

TEST_F(KittiDatasetTest, BadTimesNameTheLine) {
  WriteFile(tmp_.File("times.txt"), "0.0\n1.0e-01\nabc\n");
  StatusOr<Dataset> dataset = OpenDataset(tmp_.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "times.txt:3:")) << dataset.status().message();
  WriteFile(tmp_.File("times.txt"), "0.0\n1.0e-01\n1.0e-01\n");
  dataset = OpenDataset(tmp_.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "times.txt:3: times must increase"))
      << dataset.status().message();
}

TEST_F(KittiDatasetTest, CalibNeedsP0) {
  WriteFile(tmp_.File("calib.txt"), "P1: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  StatusOr<Dataset> dataset = OpenDataset(tmp_.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "no 'P0:' row")) << dataset.status().message();
  WriteFile(tmp_.File("calib.txt"), "P0: 1 0 0 0 0 1 0\n");
  dataset = OpenDataset(tmp_.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "calib.txt:1:")) << dataset.status().message();
}

TEST_F(KittiDatasetTest, FirstImageMustBeAPng) {
  WriteFile(Image(0), "\xff\xd8\xff\xe0 not a png");
  StatusOr<Dataset> dataset = OpenDataset(tmp_.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), Image(0))) << dataset.status().message();
}

}  // namespace
}  // namespace semmap
