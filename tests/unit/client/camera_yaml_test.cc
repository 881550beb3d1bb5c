#include "client/datasets/camera_yaml.h"

#include <gtest/gtest.h>

#include "tests/testing/temp_dir.h"
#include "tests/unit/client/dataset_test_util.h"

namespace semmap {
namespace {

using testing::TempDir;
using testing::WriteFile;

StatusOr<CameraYaml> ReadText(const TempDir& tmp, const std::string& text) {
  WriteFile(tmp.File("camera.yaml"), text);
  return ReadCameraYaml(tmp.File("camera.yaml"));
}

TEST(CameraYamlTest, ReadsAllKeys) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml = ReadText(tmp, testing::kCameraYaml);
  ASSERT_TRUE(yaml.ok()) << yaml.status().ToString();
  EXPECT_EQ(yaml->camera.width, 640);
  EXPECT_EQ(yaml->camera.height, 480);
  EXPECT_DOUBLE_EQ(yaml->camera.fx, 525.0);
  EXPECT_DOUBLE_EQ(yaml->camera.cy, 239.5);
  EXPECT_DOUBLE_EQ(yaml->depth_scale, 5000);
  EXPECT_DOUBLE_EQ(yaml->camera.distortion[0], 0.1);
  EXPECT_DOUBLE_EQ(yaml->camera.distortion[4], 0.05);
}

TEST(CameraYamlTest, OptionalKeysDefault) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml =
      ReadText(tmp, "width: 10\r\nheight: 8\r\nfx: 5\r\nfy: 5\r\ncx: 5\r\ncy: 4\r\n");
  ASSERT_TRUE(yaml.ok()) << yaml.status().ToString();
  EXPECT_EQ(yaml->depth_scale, 0);
  EXPECT_FALSE(yaml->camera.HasDistortion());
}

TEST(CameraYamlTest, FourDistortionValuesLeaveK3Zero) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml =
      ReadText(tmp, "width: 10\nheight: 8\nfx: 5\nfy: 5\ncx: 5\ncy: 4\ndistortion: [1, 2, 3, 4]\n");
  ASSERT_TRUE(yaml.ok()) << yaml.status().ToString();
  EXPECT_EQ(yaml->camera.distortion[3], 4);
  EXPECT_EQ(yaml->camera.distortion[4], 0);
}

TEST(CameraYamlTest, UnknownKeyNamesTheLine) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml = ReadText(tmp, std::string(testing::kCameraYaml) + "fxx: 3\n");
  ASSERT_FALSE(yaml.ok());
  EXPECT_EQ(yaml.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(yaml.status().message().find("camera.yaml:10"), std::string::npos)
      << yaml.status().message();
  EXPECT_NE(yaml.status().message().find("unknown key 'fxx'"), std::string::npos);
}

TEST(CameraYamlTest, MissingKeysAreNamed) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml = ReadText(tmp, "width: 640\nheight: 480\nfy: 500\ncx: 320\n");
  ASSERT_FALSE(yaml.ok());
  EXPECT_NE(yaml.status().message().find("missing required keys: fx, cy"), std::string::npos)
      << yaml.status().message();
}

TEST(CameraYamlTest, RejectsMalformedLines) {
  TempDir tmp;
  const std::string base = "width: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n";
  for (const std::string bad :
       {"fx 500\n", "depth_scale:\n", "width: 640.5\n", "fx: abc\n", "distortion: [1, 2]\n",
        "distortion: 1, 2, 3, 4, 5\n", "distortion: [1, 2, x, 4, 5]\n", "depth_scale: -1\n"}) {
    StatusOr<CameraYaml> yaml = ReadText(tmp, std::string("# header\n").append(bad).append(base));
    ASSERT_FALSE(yaml.ok()) << bad;
    EXPECT_EQ(yaml.status().code(), StatusCode::kInvalidArgument) << bad;
    if (bad != "depth_scale: -1\n") {  // range checks run after the last line
      EXPECT_NE(yaml.status().message().find("camera.yaml:2"), std::string::npos)
          << bad << " -> " << yaml.status().message();
    }
  }
}

TEST(CameraYamlTest, RejectsRepeatedKey) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml = ReadText(tmp, std::string(testing::kCameraYaml) + "fx: 1\n");
  ASSERT_FALSE(yaml.ok());
  EXPECT_NE(yaml.status().message().find("appears twice"), std::string::npos);
}

TEST(CameraYamlTest, ValidatesCalibration) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml =
      ReadText(tmp, "width: 640\nheight: 480\nfx: -5\nfy: 500\ncx: 320\ncy: 240\n");
  ASSERT_FALSE(yaml.ok());
  EXPECT_NE(yaml.status().message().find("focal"), std::string::npos) << yaml.status().message();
}

TEST(CameraYamlTest, MissingFileIsNotFound) {
  TempDir tmp;
  StatusOr<CameraYaml> yaml = ReadCameraYaml(tmp.File("nope.yaml"));
  ASSERT_FALSE(yaml.ok());
  EXPECT_EQ(yaml.status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace semmap
