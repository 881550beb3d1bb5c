// A plain folder of images with a camera.yaml (a phone video's frames) as a MONO dataset.
#include "client/datasets/image_folder_dataset.h"

#include <gtest/gtest.h>

#include "client/datasets/dataset.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/client/dataset_test_util.h"

namespace semmap {
namespace {

using testing::TempDir;
using testing::WriteFile;

TEST(ImageFolderDatasetTest, FramesInNameOrderAtTheCamerasFrameRate) {
  TempDir tmp;
  WriteFile(tmp.File("camera.yaml"), std::string(testing::kCameraYaml) + "fps: 10\n");
  for (const char* name : {"frame_0002.jpg", "frame_0000.PNG", "frame_0001.jpeg", "notes.txt"}) {
    WriteFile(tmp.File(name), "");
  }
  StatusOr<Dataset> dataset = OpenDataset(tmp.path());
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->kind, "images");
  EXPECT_EQ(dataset->depth_scale, 0);  // an image folder never has depth
  ASSERT_EQ(dataset->frames.size(), 3u);
  EXPECT_NE(dataset->frames[0].colour_path.find("frame_0000.PNG"), std::string::npos);
  EXPECT_NE(dataset->frames[2].colour_path.find("frame_0002.jpg"), std::string::npos);
  EXPECT_EQ(dataset->frames[1].stamp_ns, 100'000'000);  // 10 frames per second
  EXPECT_FALSE(dataset->frames[1].depth_path.has_value());
  EXPECT_TRUE(dataset->ground_truth.empty());
}

TEST(ImageFolderDatasetTest, DefaultsTo30FpsAndNeedsImages) {
  TempDir tmp;
  WriteFile(tmp.File("camera.yaml"), testing::kCameraYaml);
  const Status empty = OpenDataset(tmp.path()).status();
  EXPECT_EQ(empty.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(empty.message().find(".png or .jpg frames"), std::string::npos) << empty.message();
  WriteFile(tmp.File("a.png"), "");
  WriteFile(tmp.File("b.png"), "");
  StatusOr<Dataset> dataset = OpenDataset(tmp.path());
  ASSERT_TRUE(dataset.ok());
  EXPECT_EQ(dataset->frames[1].stamp_ns, 33'333'333);
  WriteFile(tmp.File("camera.yaml"), std::string(testing::kCameraYaml) + "fps: 0\n");
  EXPECT_EQ(OpenDataset(tmp.path()).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
