#include "client/eval/plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "client/eval/plot_canvas.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/eval/eval_test_util.h"

namespace semmap {
namespace {

using eval_internal::FormatTick;
using eval_internal::NiceTicks;

AteResult SampleAte() {
  std::vector<StampedPose> gt = eval_test::Helix(300);
  std::vector<StampedPose> est = gt;
  for (size_t i = 0; i < est.size(); ++i) {
    est[i].T_world_camera.translation() +=
        Eigen::Vector3d(0.05 * std::sin(0.3 * static_cast<double>(i)),
                        0.04 * std::cos(0.17 * static_cast<double>(i)), 0);
  }
  return ComputeAte(gt, eval_test::Transformed(est, eval_test::Rot(0.5, {0, 0, 1}), {1, 2, 0}))
      .value();
}

// Pixels close to a BGR colour.
int CountColour(const cv::Mat& image, const cv::Vec3b& colour, int tolerance = 40) {
  int n = 0;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const cv::Vec3b& p = image.at<cv::Vec3b>(y, x);
      if (std::abs(p[0] - colour[0]) + std::abs(p[1] - colour[1]) + std::abs(p[2] - colour[2]) <
          tolerance) {
        ++n;
      }
    }
  }
  return n;
}

TEST(NiceTicksTest, StepsOfOneTwoFive) {
  eval_internal::Ticks t = NiceTicks(0, 10, 5);
  EXPECT_DOUBLE_EQ(t.step, 2);
  EXPECT_EQ(t.values, (std::vector<double>{0, 2, 4, 6, 8, 10}));
  EXPECT_EQ(t.decimals, 0);
  t = NiceTicks(-0.23, 0.41, 6);
  EXPECT_DOUBLE_EQ(t.step, 0.1);
  EXPECT_EQ(t.decimals, 1);
  EXPECT_EQ(t.values.size(), 7u);  // -0.2 .. 0.4
  t = NiceTicks(1000, 3600, 5);
  EXPECT_DOUBLE_EQ(t.step, 500);
  t = NiceTicks(0, 0.0037, 4);
  EXPECT_DOUBLE_EQ(t.step, 0.001);
  EXPECT_EQ(t.decimals, 3);
  EXPECT_EQ(NiceTicks(5, 5, 4).values.size(), 1u);  // empty range: no endless loop
}

TEST(NiceTicksTest, FormatsWithoutNegativeZero) {
  EXPECT_EQ(FormatTick(-1e-17, 1), "0.0");
  EXPECT_EQ(FormatTick(-0.5, 1), "-0.5");
  EXPECT_EQ(FormatTick(2, 0), "2");
}

TEST(PlotTest, TrajectoryFigureShowsAllThreeColours) {
  const AteResult ate = SampleAte();
  StatusOr<cv::Mat> image = RenderTrajectoryPlot(ate);
  ASSERT_TRUE(image.ok()) << image.status().ToString();
  EXPECT_EQ(image->cols, 1000);
  EXPECT_EQ(image->rows, 800);
  EXPECT_EQ(image->type(), CV_8UC3);
  EXPECT_GT(CountColour(*image, {40, 160, 0}), 500);   // ground truth, green
  EXPECT_GT(CountColour(*image, {200, 90, 20}), 500);  // estimate, blue
  EXPECT_GT(CountColour(*image, {40, 40, 220}), 50);   // differences, red
}

TEST(PlotTest, ErrorFigureRenders) {
  PlotOptions options;
  options.width = 640;
  options.height = 400;
  options.title = "helix";
  StatusOr<cv::Mat> image = RenderErrorPlot(SampleAte(), options);
  ASSERT_TRUE(image.ok()) << image.status().ToString();
  EXPECT_EQ(image->cols, 640);
  EXPECT_EQ(image->rows, 400);
  EXPECT_GT(CountColour(*image, {200, 90, 20}), 300);
}

TEST(PlotTest, WritesReadablePngs) {
  testing::TempDir dir;
  const AteResult ate = SampleAte();
  ASSERT_TRUE(PlotTrajectory(ate, dir.File("traj.png")).ok());
  ASSERT_TRUE(PlotErrors(ate, dir.File("errors.png")).ok());
  const cv::Mat traj = cv::imread(dir.File("traj.png"));
  const cv::Mat errors = cv::imread(dir.File("errors.png"));
  EXPECT_EQ(traj.cols, 1000);
  EXPECT_EQ(traj.rows, 800);
  EXPECT_EQ(errors.cols, 1000);
  // A name without .png still gets a PNG.
  ASSERT_TRUE(PlotErrors(ate, dir.File("errors.figure")).ok());
  EXPECT_FALSE(cv::imread(dir.File("errors.figure")).empty());
}

TEST(PlotTest, Errors) {
  const AteResult ate = SampleAte();
  EXPECT_EQ(PlotTrajectory(ate, "/nonexistent-dir/x.png").code(), StatusCode::kUnavailable);
  PlotOptions tiny;
  tiny.width = 10;
  EXPECT_EQ(RenderTrajectoryPlot(ate, tiny).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(RenderErrorPlot(AteResult(), {}).status().code(), StatusCode::kInvalidArgument);
}

TEST(PlotTest, StraightLineAndFlatErrorsStillRender) {
  // Zero extent on two axes and identical errors everywhere must not divide by zero.
  std::vector<StampedPose> gt;
  gt.reserve(20);
  for (int i = 0; i < 20; ++i) {
    gt.push_back(eval_test::MakePose(eval_test::kT0 + i * 100 * kMs, {0, 0, 1.0 * i}));
  }
  const AteResult ate = ComputeAte(gt, gt).value();
  EXPECT_TRUE(RenderTrajectoryPlot(ate).ok());
  EXPECT_TRUE(RenderErrorPlot(ate).ok());
}

TEST(PlotTest, HugeCoordinatesTerminate) {
  // Far from the origin, the tick loop must still end (k + 1 == k in doubles there).
  AteResult ate;
  for (int i = 0; i < 10; ++i) {
    StampedPose p = eval_test::MakePose(eval_test::kT0 + i * kMs, {1e17 + 64.0 * i, 1e17, 5.0 * i});
    ate.ground_truth.push_back(p);
    ate.aligned_estimate.push_back(p);
    AtePair pair;
    pair.gt_stamp_ns = pair.est_stamp_ns = p.stamp_ns;
    pair.gt_position = pair.est_position_aligned = p.T_world_camera.translation();
    ate.pairs.push_back(pair);
  }
  EXPECT_TRUE(RenderTrajectoryPlot(ate).ok());
  EXPECT_TRUE(RenderErrorPlot(ate).ok());
}

}  // namespace
}  // namespace semmap
