#include "client/datasets/tum_dataset.h"

#include <gtest/gtest.h>

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

// A small TUM dataset: colour at 0, 33, 66, 100 ms (listed out of order) and depth at 1, 35,
// 120 ms after t0 = 1000 s; image files are empty placeholders (nothing decodes them).
class TumDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteFile(tmp_.File("camera.yaml"), testing::kCameraYaml);
    rgb_ =
        "# color images\n"
        "# timestamp filename\n"
        "1000.000000 rgb/a.png\n"
        "1000.066000 rgb/c.png\n"
        "1000.033000 rgb/b.png\n"
        "\n"
        "1000.100000 rgb/d d.png\n";
    depth_ =
        "# depth maps\n"
        "1000.001000 depth/a.png\n"
        "1000.035000 depth/b.png\n"
        "1000.120000 depth/d.png\n";
    for (const char* name : {"rgb/a.png", "rgb/b.png", "rgb/c.png", "rgb/d d.png", "depth/a.png",
                             "depth/b.png", "depth/d.png"}) {
      WriteFile(tmp_.File(name), "");
    }
  }
  StatusOr<Dataset> Open() {
    WriteFile(tmp_.File("rgb.txt"), rgb_);
    WriteFile(tmp_.File("depth.txt"), depth_);
    return OpenDataset(tmp_.path());
  }

  TempDir tmp_;
  std::string rgb_, depth_;
};

TEST_F(TumDatasetTest, ListsEveryColourFrameInTimeOrderWithAssociatedDepth) {
  StatusOr<Dataset> dataset = Open();
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->kind, "tum");
  EXPECT_EQ(dataset->dir, tmp_.path());
  EXPECT_FALSE(dataset->colour_is_grey);
  EXPECT_EQ(dataset->camera.width, 640);
  EXPECT_DOUBLE_EQ(dataset->camera.fx, 525.0);
  EXPECT_DOUBLE_EQ(dataset->depth_scale, 5000);
  EXPECT_TRUE(dataset->ground_truth.empty());
  ASSERT_EQ(dataset->frames.size(), 4u);
  const std::vector<int64_t> stamps = {1000'000'000'000, 1000'033'000'000, 1000'066'000'000,
                                       1000'100'000'000};
  const std::vector<std::string> colour = {"rgb/a.png", "rgb/b.png", "rgb/c.png", "rgb/d d.png"};
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(dataset->frames[i].seq, static_cast<int64_t>(i));
    EXPECT_EQ(dataset->frames[i].stamp_ns, stamps[i]);
    EXPECT_EQ(dataset->frames[i].colour_path, tmp_.File(colour[i]));
  }
  EXPECT_EQ(dataset->frames[0].depth_path, tmp_.File("depth/a.png"));
  EXPECT_EQ(dataset->frames[1].depth_path, tmp_.File("depth/b.png"));
  EXPECT_FALSE(dataset->frames[2].depth_path);  // nearest depth is 31 ms away
  EXPECT_FALSE(dataset->frames[3].depth_path);  // 20 ms exactly: the threshold is strict
}

TEST_F(TumDatasetTest, LoadsGroundTruthSorted) {
  WriteFile(tmp_.File("groundtruth.txt"),
            "# timestamp tx ty tz qx qy qz qw\n"
            "1000.05 1 0 0 0 0 0 1\n"
            "1000.01 0 0 0 0 0 0 1\n");
  StatusOr<Dataset> dataset = Open();
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  ASSERT_EQ(dataset->ground_truth.size(), 2u);
  EXPECT_EQ(dataset->ground_truth[0].stamp_ns, 1000'010'000'000);
  EXPECT_EQ(dataset->ground_truth[1].stamp_ns, 1000'050'000'000);
}

TEST_F(TumDatasetTest, BadGroundTruthLineIsAnError) {
  WriteFile(tmp_.File("groundtruth.txt"), "1000.05 1 0 0 0 0 0\n");
  StatusOr<Dataset> dataset = Open();
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "groundtruth.txt:1:")) << dataset.status().message();
}

TEST_F(TumDatasetTest, WithoutDepthListThereIsNoDepth) {
  WriteFile(tmp_.File("rgb.txt"), rgb_);
  StatusOr<Dataset> dataset = OpenTumDataset(tmp_.path());
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->depth_scale, 0);
  EXPECT_EQ(dataset->frames.size(), 4u);
  for (const DatasetFrame& f : dataset->frames) EXPECT_FALSE(f.depth_path);
}

TEST_F(TumDatasetTest, MissingCameraYamlIsAClearError) {
  std::filesystem::remove(tmp_.File("camera.yaml"));
  StatusOr<Dataset> dataset = Open();
  ASSERT_FALSE(dataset.ok());
  EXPECT_EQ(dataset.status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(Contains(dataset.status(), "no camera.yaml")) << dataset.status().message();
}

TEST_F(TumDatasetTest, BadCameraYamlIsReported) {
  WriteFile(tmp_.File("camera.yaml"), std::string(testing::kCameraYaml) + "zoom: 2\n");
  StatusOr<Dataset> dataset = Open();
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "camera.yaml:10: unknown key 'zoom'"))
      << dataset.status().message();
}

TEST_F(TumDatasetTest, DepthListNeedsDepthScale) {
  WriteFile(tmp_.File("camera.yaml"),
            "width: 640\nheight: 480\nfx: 525\nfy: 525\ncx: 320\ncy: 240\n");
  StatusOr<Dataset> dataset = Open();
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "depth_scale")) << dataset.status().message();
}

TEST_F(TumDatasetTest, MissingImageFileIsNotFoundNamingIt) {
  std::filesystem::remove(tmp_.File("depth/b.png"));
  StatusOr<Dataset> dataset = Open();
  ASSERT_FALSE(dataset.ok());
  EXPECT_EQ(dataset.status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(Contains(dataset.status(), tmp_.File("depth/b.png"))) << dataset.status().message();
  EXPECT_TRUE(Contains(dataset.status(), "depth.txt:3:")) << dataset.status().message();
}

TEST_F(TumDatasetTest, BadLinesNameFileAndLine) {
  for (const std::string bad : {"1000.2\n", "10x0.2 rgb/a.png\n", "1000.2   \n"}) {
    rgb_ = "# colour\n" + bad;
    StatusOr<Dataset> dataset = Open();
    ASSERT_FALSE(dataset.ok()) << bad;
    EXPECT_EQ(dataset.status().code(), StatusCode::kInvalidArgument);
    EXPECT_TRUE(Contains(dataset.status(), "rgb.txt:2:")) << dataset.status().message();
  }
}

TEST_F(TumDatasetTest, RepeatedColourStampIsAnError) {
  rgb_ = "1000.0 rgb/a.png\n1000.0 rgb/b.png\n";
  StatusOr<Dataset> dataset = Open();
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "rgb.txt:2:")) << dataset.status().message();
}

TEST_F(TumDatasetTest, EmptyColourListIsAnError) {
  rgb_ = "# nothing\n";
  StatusOr<Dataset> dataset = Open();
  ASSERT_FALSE(dataset.ok());
  EXPECT_TRUE(Contains(dataset.status(), "lists no images")) << dataset.status().message();
}

TEST_F(TumDatasetTest, CommaSeparatedListsAreAccepted) {
  rgb_ = "1000.000000,rgb/a.png\n1000.033000, rgb/b.png\n";
  StatusOr<Dataset> dataset = Open();
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  ASSERT_EQ(dataset->frames.size(), 2u);
  EXPECT_EQ(dataset->frames[1].colour_path, tmp_.File("rgb/b.png"));
}

TEST(OpenDatasetTest, RejectsUnknownLayoutAndMissingDir) {
  TempDir tmp;
  StatusOr<Dataset> dataset = OpenDataset(tmp.path());
  ASSERT_FALSE(dataset.ok());
  EXPECT_EQ(dataset.status().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(Contains(dataset.status(), "rgb.txt")) << dataset.status().message();
  EXPECT_EQ(OpenDataset(tmp.File("absent")).status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace semmap
