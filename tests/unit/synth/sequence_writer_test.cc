#include "tests/testing/synth/sequence_writer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "client/datasets/camera_yaml.h"
#include "client/datasets/dataset.h"
#include "tests/testing/synth/dataset_files.h"
#include "tests/testing/synth/trajectory.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/synth/synth_test_util.h"

namespace semmap::synth {
namespace {

namespace fs = std::filesystem;
using semmap::testing::TempDir;
using test::DefaultScene;

constexpr int kFrames = 24;

std::vector<StampedPose> Circle(int frames = kFrames) {
  TrajectoryOptions options;
  options.frames = frames;
  StatusOr<std::vector<StampedPose>> t = CircleTrajectory(DefaultScene().room, options);
  EXPECT_TRUE(t.ok());
  return *t;
}

SequenceOptions Options() {
  SequenceOptions options;
  options.camera = DefaultSyntheticCamera();
  return options;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

class SequenceWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    poses_ = Circle();
    size_t calls = 0;
    SequenceOptions options = Options();
    options.progress = [&](size_t done, size_t total) {
      EXPECT_EQ(done, ++calls);
      EXPECT_EQ(total, poses_.size());
    };
    const Status written = WriteTumSequence(dir_.path(), DefaultScene(), poses_, options);
    ASSERT_TRUE(written.ok()) << written.ToString();
    EXPECT_EQ(calls, poses_.size());
    StatusOr<Dataset> dataset = OpenDataset(dir_.path());
    ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
    dataset_ = *dataset;
  }

  TempDir dir_;
  std::vector<StampedPose> poses_;
  Dataset dataset_;
};

TEST_F(SequenceWriterTest, OpensAsATumDatasetWithDepthAndGroundTruth) {
  EXPECT_EQ(dataset_.kind, "tum");
  EXPECT_EQ(dataset_.depth_scale, 5000.0);
  ASSERT_EQ(dataset_.frames.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(dataset_.ground_truth.size(), static_cast<size_t>(kFrames));
  for (size_t i = 0; i < dataset_.frames.size(); ++i) {
    const DatasetFrame& f = dataset_.frames[i];
    ASSERT_TRUE(f.depth_path.has_value());
    EXPECT_EQ(f.stamp_ns, poses_[i].stamp_ns);
    EXPECT_EQ(dataset_.ground_truth[i].stamp_ns, poses_[i].stamp_ns);
    EXPECT_TRUE(dataset_.ground_truth[i].T_world_camera.isApprox(poses_[i].T_world_camera, 1e-7));
    const cv::Mat colour = cv::imread(f.colour_path, cv::IMREAD_UNCHANGED);
    const cv::Mat depth = cv::imread(*f.depth_path, cv::IMREAD_UNCHANGED);
    EXPECT_EQ(colour.type(), CV_8UC3);
    EXPECT_EQ(colour.size(), cv::Size(640, 480));
    EXPECT_EQ(depth.type(), CV_16UC1);
    EXPECT_EQ(cv::countNonZero(depth), 640 * 480);
  }
}

TEST_F(SequenceWriterTest, CameraYamlRoundTrips) {
  StatusOr<CameraYaml> yaml = ReadCameraYaml(dir_.File("camera.yaml"));
  ASSERT_TRUE(yaml.ok()) << yaml.status().ToString();
  const CameraCalibration expected = DefaultSyntheticCamera();
  EXPECT_EQ(yaml->camera.width, expected.width);
  EXPECT_EQ(yaml->camera.height, expected.height);
  EXPECT_EQ(yaml->camera.fx, expected.fx);
  EXPECT_EQ(yaml->camera.fy, expected.fy);
  EXPECT_EQ(yaml->camera.cx, expected.cx);
  EXPECT_EQ(yaml->camera.cy, expected.cy);
  EXPECT_FALSE(yaml->camera.HasDistortion());
  EXPECT_EQ(yaml->depth_scale, 5000.0);
  // Odd intrinsics survive exactly too.
  CameraCalibration odd = expected;
  odd.fx = 531.123456789;
  odd.cy = 241.1;
  TempDir other;
  ASSERT_TRUE(WriteTextFile(other.File("camera.yaml"), FormatCameraYaml(odd, 5000)).ok());
  StatusOr<CameraYaml> back = ReadCameraYaml(other.File("camera.yaml"));
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->camera.fx, odd.fx);
  EXPECT_EQ(back->camera.cy, odd.cy);
}

TEST_F(SequenceWriterTest, ObjectsFileAndTemplatesDescribeTheSceneObjects) {
  StatusOr<std::vector<ObjectRecord>> records = ReadObjectsFile(dir_.File("objects.txt"));
  ASSERT_TRUE(records.ok()) << records.status().ToString();
  const std::vector<NamedObject>& objects = DefaultScene().objects;
  ASSERT_EQ(records->size(), objects.size());
  for (size_t i = 0; i < objects.size(); ++i) {
    EXPECT_EQ((*records)[i].label, objects[i].label);
    EXPECT_LT(((*records)[i].centre - objects[i].centre).norm(), 2e-6);
    EXPECT_LT(((*records)[i].size - objects[i].size).norm(), 2e-6);
    const cv::Mat image = cv::imread(dir_.File("objects/" + objects[i].label + ".png"));
    ASSERT_FALSE(image.empty()) << objects[i].label;
    // One pixel per millimetre of the front face plus a 6% margin on each side.
    EXPECT_NEAR(image.cols, objects[i].front.width * 1000 * 1.12, 2);
    EXPECT_NEAR(image.rows, objects[i].front.height * 1000 * 1.12, 2);
  }
  const std::string text = ReadBytes(dir_.File("objects.txt"));
  EXPECT_EQ(text.rfind("# ", 0), 0u);  // starts with a header comment
  EXPECT_NE(text.find("label cx cy cz sx sy sz"), std::string::npos);
}

TEST_F(SequenceWriterTest, GroundTruthDepthAndObjectsAgree) {
  // In every frame that sees an object (its centre projects into the image and the camera is
  // in front of its front face; nothing stands between the camera path and the objects), the
  // pixel the centre projects to has a depth that, unprojected with the ground-truth pose,
  // lands on the object: inside its bounding box from objects.txt (+1 cm).
  StatusOr<std::vector<ObjectRecord>> records = ReadObjectsFile(dir_.File("objects.txt"));
  StatusOr<CameraYaml> yaml = ReadCameraYaml(dir_.File("camera.yaml"));
  ASSERT_TRUE(records.ok() && yaml.ok());
  ASSERT_EQ(records->size(), DefaultScene().objects.size());
  const CameraCalibration& c = yaml->camera;
  std::map<std::string, int> seen;
  for (size_t i = 0; i < dataset_.frames.size(); ++i) {
    const Eigen::Isometry3d& T = dataset_.ground_truth[i].T_world_camera;
    const cv::Mat depth = cv::imread(*dataset_.frames[i].depth_path, cv::IMREAD_UNCHANGED);
    for (size_t k = 0; k < records->size(); ++k) {
      const ObjectRecord& o = (*records)[k];
      const Surface& front = DefaultScene().objects[k].front;
      const std::optional<Eigen::Vector2d> px = test::Project(c, T, o.centre);
      if (!px || px->x() < 10 || px->y() < 10 || px->x() > c.width - 11 ||
          px->y() > c.height - 11 || (T.translation() - front.Centre()).dot(front.Normal()) <= 0) {
        continue;
      }
      const double u = std::round(px->x()), v = std::round(px->y());
      const double z =
          depth.at<uint16_t>(static_cast<int>(v), static_cast<int>(u)) / dataset_.depth_scale;
      const Eigen::Vector3d p = test::Unproject(c, T, u, v, z);
      const Eigen::AlignedBox3d box(o.centre - 0.5 * o.size, o.centre + 0.5 * o.size);
      EXPECT_LT(box.exteriorDistance(p), 0.01)
          << o.label << " frame " << i << ": depth " << z << " puts the point at " << p.transpose();
      ++seen[o.label];
    }
  }
  // The circle looks at all four walls, so every object is seen in some frames.
  for (const ObjectRecord& o : *records) EXPECT_GT(seen[o.label], 0) << o.label;
}

TEST_F(SequenceWriterTest, SameInputsGiveIdenticalFiles) {
  TempDir again;
  ASSERT_TRUE(WriteTumSequence(again.path(), DefaultScene(), poses_, Options()).ok());
  size_t files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir_.path())) {
    if (!entry.is_regular_file()) continue;
    const std::string rel = fs::relative(entry.path(), dir_.path()).string();
    EXPECT_EQ(ReadBytes(entry.path().string()), ReadBytes(again.File(rel))) << rel;
    ++files;
  }
  // Colour + depth per frame; camera.yaml, objects.txt, groundtruth, rgb and depth lists;
  // four templates.
  EXPECT_EQ(files, 2u * kFrames + 5u + 4u);
}

TEST(SequenceWriterErrorsTest, RefusesBadInput) {
  const std::vector<StampedPose> poses = Circle(3);
  TempDir dir;
  // A non-empty directory.
  ASSERT_TRUE(WriteTextFile(dir.File("stale.txt"), "x").ok());
  EXPECT_EQ(WriteTumSequence(dir.path(), DefaultScene(), poses, Options()).code(),
            StatusCode::kFailedPrecondition);
  // Repeated stamps, no poses, a distorted camera, bad noise options.
  std::vector<StampedPose> repeated = poses;
  repeated[2].stamp_ns = repeated[1].stamp_ns;
  EXPECT_EQ(WriteTumSequence(dir.File("a"), DefaultScene(), repeated, Options()).code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(WriteTumSequence(dir.File("b"), DefaultScene(), {}, Options()).code(),
            StatusCode::kInvalidArgument);
  SequenceOptions distorted = Options();
  distorted.camera.distortion[0] = 0.2;
  EXPECT_FALSE(WriteTumSequence(dir.File("c"), DefaultScene(), poses, distorted).ok());
  SequenceOptions noisy = Options();
  noisy.noise.drop_depth_probability = 2;
  EXPECT_FALSE(WriteTumSequence(dir.File("d"), DefaultScene(), poses, noisy).ok());
  EXPECT_FALSE(fs::exists(dir.File("a")) || fs::exists(dir.File("b")) ||
               fs::exists(dir.File("c")) || fs::exists(dir.File("d")));
}

TEST(ObjectsFileTest, ParsesAndRejects) {
  TempDir dir;
  ASSERT_TRUE(WriteTextFile(dir.File("ok.txt"), "# c\n\ncup 1 2 3 0.1 0.2 0.3  # trailing\n").ok());
  StatusOr<std::vector<ObjectRecord>> ok = ReadObjectsFile(dir.File("ok.txt"));
  ASSERT_TRUE(ok.ok()) << ok.status().ToString();
  ASSERT_EQ(ok->size(), 1u);
  EXPECT_EQ((*ok)[0].label, "cup");
  EXPECT_TRUE((*ok)[0].centre.isApprox(Eigen::Vector3d(1, 2, 3)));
  for (const char* bad : {"cup 1 2 3 0.1 0.2\n", "cup 1 2 x 0.1 0.2 0.3\n",
                          "cup 1 2 3 0.1 -0.2 0.3\n", "cup 1 2 3 1 1 1\ncup 1 2 3 1 1 1\n"}) {
    ASSERT_TRUE(WriteTextFile(dir.File("bad.txt"), bad).ok());
    const Status s = ReadObjectsFile(dir.File("bad.txt")).status();
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(s.message().find("bad.txt:"), std::string::npos) << s.message();
  }
  EXPECT_EQ(ReadObjectsFile(dir.File("missing.txt")).status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace semmap::synth
