// The readers on the shared real datasets (skipped when ../shared/data is absent).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "client/datasets/dataset.h"
#include "client/datasets/image_file.h"
#include "client/datasets/pose_lookup.h"
#include "client/datasets/trajectory_io.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

// Where the shared data is looked for ($SEMMAP_SHARED_DATA_DIR overrides the build's default).
std::string SharedDataRoot() {
  const char* env = std::getenv("SEMMAP_SHARED_DATA_DIR");
  return env != nullptr && *env ? env : SEMMAP_SHARED_DATA_DIR;
}

// The dataset's directory, or "" (and the test skips) when the shared data is not there.
std::string DatasetDir(const std::string& name) {
  const std::string root = testing::SharedDataDir();
  if (root.empty()) return "";
  const std::string dir = (std::filesystem::path(root) / name).string();
  return std::filesystem::is_directory(dir) ? dir : "";
}

#define SKIP_WITHOUT(dir, name)                                                       \
  if ((dir).empty()) {                                                                \
    GTEST_SKIP() << "shared data not found at " << SharedDataRoot() << "/" << (name); \
  }

TEST(RealDataTest, TumTeddy) {
  const std::string dir = DatasetDir("tum_fr3_teddy_200");
  SKIP_WITHOUT(dir, "tum_fr3_teddy_200");
  StatusOr<Dataset> dataset = OpenDataset(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->kind, "tum");
  ASSERT_EQ(dataset->frames.size(), 200u);
  int with_depth = 0;
  for (const DatasetFrame& f : dataset->frames) with_depth += f.depth_path ? 1 : 0;
  EXPECT_EQ(with_depth, 193);
  EXPECT_EQ(dataset->camera.width, 640);
  EXPECT_EQ(dataset->camera.height, 480);
  EXPECT_DOUBLE_EQ(dataset->camera.fx, 535.4);
  EXPECT_DOUBLE_EQ(dataset->depth_scale, 5000);
  EXPECT_EQ(dataset->frames.front().stamp_ns, 1341841873273798000LL);
  ASSERT_FALSE(dataset->ground_truth.empty());

  const PoseLookup lookup(dataset->ground_truth);
  for (const DatasetFrame& f : dataset->frames) {
    EXPECT_TRUE(lookup.At(f.stamp_ns)) << "no pose for frame " << f.seq;
  }
  // The ground truth starts 0.14 s after the first image: the first frame's pose is the first
  // ground-truth pose.
  EXPECT_TRUE(lookup.At(dataset->frames.front().stamp_ns)
                  ->isApprox(dataset->ground_truth.front().T_world_camera));

  StatusOr<EncodedFile> colour = ReadImageFile(dataset->frames.front().colour_path);
  ASSERT_TRUE(colour.ok()) << colour.status().ToString();
  EXPECT_EQ(colour->format, "png");
  EXPECT_EQ(*PngSize(colour->bytes), std::make_pair(640, 480));
}

TEST(RealDataTest, TumGroundTruthRoundTrip) {
  const std::string dir = DatasetDir("tum_fr3_teddy_200");
  SKIP_WITHOUT(dir, "tum_fr3_teddy_200");
  StatusOr<std::vector<StampedPose>> gt = ReadTumTrajectory(dir + "/groundtruth.txt");
  ASSERT_TRUE(gt.ok()) << gt.status().ToString();
  testing::TempDir tmp;
  ASSERT_TRUE(WriteTumTrajectory(tmp.File("gt.txt"), *gt).ok());
  StatusOr<std::vector<StampedPose>> again = ReadTumTrajectory(tmp.File("gt.txt"));
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  ASSERT_EQ(again->size(), gt->size());
  for (size_t i = 0; i < gt->size(); ++i) {
    EXPECT_EQ((*again)[i].stamp_ns, (*gt)[i].stamp_ns);
    EXPECT_TRUE((*again)[i].T_world_camera.isApprox((*gt)[i].T_world_camera, 1e-8));
  }
}

TEST(RealDataTest, Kitti07) {
  const std::string dir = DatasetDir("kitti_07_first160");
  SKIP_WITHOUT(dir, "kitti_07_first160");
  StatusOr<Dataset> dataset = OpenDataset(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->kind, "kitti");
  EXPECT_TRUE(dataset->colour_is_grey);
  ASSERT_EQ(dataset->frames.size(), 160u);
  EXPECT_EQ(dataset->camera.width, 1226);
  EXPECT_EQ(dataset->camera.height, 370);
  EXPECT_DOUBLE_EQ(dataset->camera.fx, 707.0912);
  EXPECT_EQ(dataset->frames[1].stamp_ns, 103'875'200);
  ASSERT_EQ(dataset->ground_truth.size(), 160u);
  EXPECT_EQ(dataset->ground_truth[1].stamp_ns, 103'875'200);
  const PoseLookup lookup(dataset->ground_truth);
  for (const DatasetFrame& f : dataset->frames) EXPECT_TRUE(lookup.At(f.stamp_ns));
}

TEST(RealDataTest, KittiPosesMatchTheSequenceExcerpt) {
  const std::string dir = DatasetDir("kitti_07_first160");
  const std::string all = DatasetDir("kitti_poses");
  SKIP_WITHOUT(dir, "kitti_07_first160");
  SKIP_WITHOUT(all, "kitti_poses");
  StatusOr<std::vector<StampedPose>> excerpt = ReadKittiPoses(dir + "/poses.txt");
  StatusOr<std::vector<StampedPose>> sequence = ReadKittiPoses(all + "/07.txt");
  ASSERT_TRUE(excerpt.ok()) << excerpt.status().ToString();
  ASSERT_TRUE(sequence.ok()) << sequence.status().ToString();
  EXPECT_EQ(sequence->size(), 1101u);
  ASSERT_EQ(excerpt->size(), 160u);
  for (size_t i = 0; i < excerpt->size(); ++i) {
    EXPECT_TRUE((*excerpt)[i].T_world_camera.isApprox((*sequence)[i].T_world_camera, 1e-5)) << i;
  }
}

TEST(RealDataTest, KinectCafe) {
  const std::string dir = DatasetDir("kinect_cafe_391_nogt");
  SKIP_WITHOUT(dir, "kinect_cafe_391_nogt");
  StatusOr<Dataset> dataset = OpenDataset(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  ASSERT_EQ(dataset->frames.size(), 391u);
  EXPECT_TRUE(dataset->ground_truth.empty());
  EXPECT_DOUBLE_EQ(dataset->depth_scale, 1000);
  for (const DatasetFrame& f : dataset->frames) EXPECT_TRUE(f.depth_path) << f.seq;
  StatusOr<EncodedFile> colour = ReadImageFile(dataset->frames.back().colour_path);
  ASSERT_TRUE(colour.ok()) << colour.status().ToString();
  EXPECT_EQ(colour->format, "jpeg");
}

}  // namespace
}  // namespace semmap
