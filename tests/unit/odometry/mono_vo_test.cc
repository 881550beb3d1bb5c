// The learned VO as the server runs it: the sidecar, pose composition from the network's
// relative outputs, and (with the shipped model) the recurrent state carried and reset.
#include "core/odometry/mono_vo.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/odometry/mono_vo_model.h"

namespace semmap {
namespace {

const char kSidecar[] = R"({
  "format": "semmap_vo/1",
  "sha256": "0000000000000000000000000000000000000000000000000000000000000000",
  "input": {"width": 128, "height": 96,
            "normalisation": {"mean": [0.45, 0.45, 0.45], "std": [0.225, 0.225, 0.225]},
            "canonical_camera": {"fx": 105.0, "fy": 105.0, "cx": 63.5, "cy": 47.5}},
  "inputs": {"image": [1, 3, 96, 128], "prev_f1": [1, 16, 48, 64],
             "prev_f2": [1, 32, 24, 32], "prev_f3": [1, 64, 12, 16], "h": [1, 256], "c": [1, 256]},
  "state": [{"input": "prev_f1", "output": "f1"}, {"input": "prev_f2", "output": "f2"},
            {"input": "prev_f3", "output": "f3"},
            {"input": "h", "output": "h_out", "first_frame": "discard"},
            {"input": "c", "output": "c_out", "first_frame": "discard"}]
})";

TEST(MonoVoSidecarTest, ParsesTheExportersSidecar) {
  StatusOr<MonoVoModelInfo> info = ParseMonoVoSidecar(kSidecar);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->camera.width, 128);
  EXPECT_EQ(info->camera.height, 96);
  EXPECT_EQ(info->camera.f, 105.0);
  EXPECT_EQ(info->camera.cx, 63.5);
  ASSERT_EQ(info->state.size(), 5u);
  EXPECT_EQ(info->state[1].input, "prev_f2");
  EXPECT_EQ(info->state[1].output, "f2");
  EXPECT_EQ(info->state[1].shape, (std::vector<int>{1, 32, 24, 32}));
  EXPECT_FALSE(info->state[1].discard_first);
  EXPECT_EQ(info->state[3].shape, (std::vector<int>{1, 256}));
  EXPECT_TRUE(info->state[3].discard_first);
  EXPECT_EQ(info->stddev[2], 0.225);
}

TEST(MonoVoSidecarTest, NamesWhatIsWrong) {
  auto error = [](std::string text, const std::string& from, const std::string& to) {
    text.replace(text.find(from), from.size(), to);
    return ParseMonoVoSidecar(text).status();
  };
  const std::string good = kSidecar;
  EXPECT_NE(error(good, "semmap_vo/1", "other/2").message().find("format"), std::string::npos);
  EXPECT_NE(error(good, "\"width\": 128", "\"width\": -1").message().find("input.width"),
            std::string::npos);
  EXPECT_NE(error(good, "\"fy\": 105.0", "\"fy\": 100.0").message().find("fx == fy"),
            std::string::npos);
  EXPECT_NE(error(good, "[1, 32, 24, 32]", "[2, 32, 24]").message().find("inputs.prev_f2"),
            std::string::npos);
  EXPECT_NE(error(good, "\"prev_f3\": [1, 64, 12, 16], ", "").message().find("inputs.prev_f3"),
            std::string::npos);
  EXPECT_NE(error(good, "\"output\": \"f2\"", "\"output\": \"f1\"").message().find("twice"),
            std::string::npos);
  EXPECT_NE(error(good, "\"first_frame\": \"discard\"", "\"first_frame\": 1")
                .message()
                .find("first_frame"),
            std::string::npos);
  EXPECT_NE(error(good, "\"std\": [0.225, 0.225, 0.225]", "\"std\": [0.225, 0, 0.225]")
                .message()
                .find("std"),
            std::string::npos);
  EXPECT_NE(error(good, "\"image\": [1, 3, 96, 128]", "\"image\": [1, 3, 96, 127]")
                .message()
                .find("inputs.image"),
            std::string::npos);
  EXPECT_EQ(ParseMonoVoSidecar("{").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ParseMonoVoSidecar("[]").status().code(), StatusCode::kInvalidArgument);
}

// pose6 = (t, axis-angle) is T_prev_cur; chaining gives T_world_cur = T_world_prev * T_prev_cur.
TEST(MonoVoPoseTest, RelativeOutputsComposeIntoTheTrajectory) {
  StatusOr<Eigen::Isometry3d> step =
      PoseFromPose6({0.1f, 0, 0, 0, static_cast<float>(M_PI / 2), 0});
  ASSERT_TRUE(step.ok());
  // The camera moved 0.1 m along its x, then turned 90 degrees about its y (down) axis.
  EXPECT_NEAR((step->linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitX()).norm(), 0,
              1e-6);
  Eigen::Isometry3d T_world = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 4; ++i) T_world = T_world * *step;
  // Four such steps: a square of side 0.1 m, back where it started, facing the same way.
  EXPECT_NEAR(T_world.translation().norm(), 0, 1e-6);
  EXPECT_NEAR((T_world.linear() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-5);

  EXPECT_TRUE(PoseFromPose6({0, 0, 0, 0, 0, 0}).ok());
  EXPECT_EQ(PoseFromPose6({NAN, 0, 0, 0, 0, 0}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(PoseFromPose6({20, 0, 0, 0, 0, 0}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(PoseFromPose6({0, 0, 0, 4, 0, 0}).status().code(), StatusCode::kInvalidArgument);
}

std::string ShippedModel() { return std::string(SEMMAP_SOURCE_DIR) + "/models/vo/semmap_vo.onnx"; }

TEST(MonoVoModelTest, AMissingOrDamagedModelSaysWhat) {
  EXPECT_EQ(MonoVoModel::Load("/nonexistent/vo.onnx").status().code(), StatusCode::kNotFound);
  const std::string shipped = ShippedModel();
  if (!std::filesystem::exists(shipped)) GTEST_SKIP() << "no trained model at " << shipped;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mono_vo_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ifstream in(shipped, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  std::string damaged = bytes.str();
  damaged[damaged.size() / 2] ^= 0x5a;
  std::ofstream(dir / "vo.onnx", std::ios::binary) << damaged;
  std::filesystem::copy_file(std::filesystem::path(shipped).replace_extension(".json"),
                             dir / "vo.json");
  const Status status = MonoVoModel::Load((dir / "vo.onnx").string()).status();
  EXPECT_EQ(status.code(), StatusCode::kDataLoss) << status.ToString();
  EXPECT_NE(status.message().find("sha256"), std::string::npos);
  std::filesystem::remove(dir / "vo.json");
  EXPECT_EQ(MonoVoModel::Load((dir / "vo.onnx").string()).status().code(), StatusCode::kNotFound);
  std::filesystem::remove_all(dir);
}

cv::Mat Frame(const MonoVoModelInfo& info, int shift) {
  cv::Mat image(info.camera.height, info.camera.width, CV_8UC3);
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) {
      const auto value =
          static_cast<uint8_t>(128 + 100 * std::sin(0.3 * (u + shift)) * std::cos(0.2 * v));
      image.at<cv::Vec3b>(v, u) = cv::Vec3b(value, static_cast<uint8_t>(255 - value), value);
    }
  }
  return image;
}

// The recurrent state: carried from step to step (the same frames give the same outputs in a
// fresh runner, a different history gives different ones) and reset per session.
TEST(MonoVoModelTest, StateIsCarriedAndReset) {
  const std::string shipped = ShippedModel();
  if (!std::filesystem::exists(shipped)) GTEST_SKIP() << "no trained model at " << shipped;
  StatusOr<std::shared_ptr<const MonoVoModel>> model = MonoVoModel::Load(shipped);
  ASSERT_TRUE(model.ok()) << model.status().ToString();
  const MonoVoModelInfo& info = (*model)->info();
  auto run = [&](MonoVoRunner& runner, std::initializer_list<int> shifts) {
    StatusOr<MonoVoStep> last = InternalError("no step");
    for (const int shift : shifts) last = runner.Step(Frame(info, shift));
    return last;
  };
  std::unique_ptr<MonoVoRunner> a = (*model)->NewRunner().value();
  std::unique_ptr<MonoVoRunner> b = (*model)->NewRunner().value();
  StatusOr<MonoVoStep> first = a->Step(Frame(info, 0));
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  EXPECT_FALSE(first->T_prev_cur.has_value());  // nothing to move from yet
  EXPECT_EQ(first->depth.size(), cv::Size(info.camera.width, info.camera.height));
  double min_depth = 0, max_depth = 0;
  cv::minMaxLoc(first->depth, &min_depth, &max_depth);
  EXPECT_GT(min_depth, 0.0);

  const StatusOr<MonoVoStep> a3 = run(*a, {1, 2});
  const StatusOr<MonoVoStep> b3 = run(*b, {0, 1, 2});
  ASSERT_TRUE(a3.ok() && b3.ok());
  ASSERT_TRUE(a3->T_prev_cur && b3->T_prev_cur);
  EXPECT_TRUE(a3->T_prev_cur->isApprox(*b3->T_prev_cur, 1e-6));  // same history, same answer
  std::unique_ptr<MonoVoRunner> c = (*model)->NewRunner().value();
  const StatusOr<MonoVoStep> c3 = run(*c, {5, 9, 1, 2});
  ASSERT_TRUE(c3.ok());
  EXPECT_FALSE(c3->T_prev_cur->isApprox(*b3->T_prev_cur, 1e-9));  // the history counts

  c->Reset();
  EXPECT_FALSE(c->has_state());
  const StatusOr<MonoVoStep> again = run(*c, {0, 1, 2});
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->T_prev_cur->isApprox(*b3->T_prev_cur, 1e-6));  // as a new session
}

}  // namespace
}  // namespace semmap
