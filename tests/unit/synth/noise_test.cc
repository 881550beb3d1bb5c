#include "tests/testing/synth/noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_frame.h"
#include "tests/testing/synth/trajectory.h"
#include "tests/unit/synth/synth_test_util.h"

namespace semmap::synth {
namespace {

cv::Mat FlatDepth(double metres) {
  cv::Mat d(240, 320, CV_16UC1, cv::Scalar(metres * kDepthScale));
  d(cv::Rect(0, 0, 320, 10)).setTo(0);  // a band of no return
  return d;
}

// Mean and standard deviation in metres of the non-zero pixels.
void Stats(const cv::Mat& depth, double* mean, double* sd) {
  cv::Scalar m, s;
  cv::meanStdDev(depth, m, s, depth > 0);
  *mean = m[0] / kDepthScale;
  *sd = s[0] / kDepthScale;
}

TEST(NoiseTest, DepthNoiseGrowsWithTheSquareOfDepth) {
  NoiseOptions options;
  options.depth_noise = true;
  EXPECT_NEAR(DepthNoiseSigma(options, 0.4), 0.0012, 1e-12);
  EXPECT_NEAR(DepthNoiseSigma(options, 3.4), 0.0012 + 0.0019 * 9.0, 1e-12);
  for (double z : {1.0, 2.0, 4.0}) {
    cv::Mat d = FlatDepth(z);
    AddDepthNoise(options, kDepthScale, 11, &d);
    double mean = 0, sd = 0;
    Stats(d, &mean, &sd);
    EXPECT_NEAR(mean, z, 0.001);
    EXPECT_NEAR(sd, DepthNoiseSigma(options, z), 0.1 * DepthNoiseSigma(options, z)) << z;
    EXPECT_EQ(cv::countNonZero(d(cv::Rect(0, 0, 320, 10))), 0);  // no return stays none
  }
}

TEST(NoiseTest, DropsTheRequestedShareOfDepthPixels) {
  for (double p : {0.0, 0.1, 0.5, 1.0}) {
    cv::Mat d(240, 320, CV_16UC1, cv::Scalar(10000));
    DropDepthPixels(p, 3, &d);
    const double dropped = 1.0 - cv::countNonZero(d) / static_cast<double>(d.total());
    EXPECT_NEAR(dropped, p, 0.01) << p;
  }
}

TEST(NoiseTest, ColourNoiseHasTheRequestedSigma) {
  cv::Mat image(240, 320, CV_8UC3, cv::Scalar(100, 128, 160));
  const cv::Mat original = image.clone();
  AddColourNoise(4.0, 5, &image);
  cv::Mat diff;
  image.convertTo(diff, CV_32FC3);
  diff -= cv::Scalar(100, 128, 160);
  cv::Scalar mean, sd;
  cv::meanStdDev(diff.reshape(1), mean, sd);
  EXPECT_NEAR(mean[0], 0.0, 0.1);
  EXPECT_NEAR(sd[0], 4.0, 0.3);
  cv::Mat again = original.clone();
  AddColourNoise(4.0, 5, &again);
  EXPECT_EQ(cv::norm(image, again, cv::NORM_INF), 0);  // same seed, same noise
  again = original.clone();
  AddColourNoise(4.0, 6, &again);
  EXPECT_GT(cv::norm(image, again, cv::NORM_INF), 0);
}

TEST(NoiseTest, Validation) {
  EXPECT_TRUE(ValidateNoiseOptions({}).ok());
  NoiseOptions o;
  o.drop_depth_probability = 1.5;
  EXPECT_FALSE(ValidateNoiseOptions(o).ok());
  o = {};
  o.colour_noise_sigma = -1;
  EXPECT_FALSE(ValidateNoiseOptions(o).ok());
  o = {};
  o.depth_sigma_b = std::nan("");
  EXPECT_FALSE(ValidateNoiseOptions(o).ok());
  o = {};
  o.motion_blur_samples = 100;
  EXPECT_FALSE(ValidateNoiseOptions(o).ok());
  o = {};
  o.exposure = 0;
  EXPECT_FALSE(ValidateNoiseOptions(o).ok());
}

class SequenceFrameTest : public ::testing::Test {
 protected:
  void SetUp() override {
    StatusOr<Renderer> r = Renderer::Create(test::DefaultScene(), test::Camera640());
    ASSERT_TRUE(r.ok());
    renderer_.emplace(std::move(r).value());
    TrajectoryOptions options;
    options.frames = 30;
    StatusOr<std::vector<StampedPose>> t = FastMotionTrajectory(test::DefaultScene().room, options);
    ASSERT_TRUE(t.ok());
    poses_ = *t;
  }
  std::optional<Renderer> renderer_;
  std::vector<StampedPose> poses_;
};

double Sharpness(const cv::Mat& bgr) {
  cv::Mat grey, lap;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::Laplacian(grey, lap, CV_32F);
  cv::Scalar mean, sd;
  cv::meanStdDev(lap, mean, sd);
  return sd[0];
}

TEST_F(SequenceFrameTest, WithoutNoiseItIsThePlainRender) {
  const RenderedFrame f = RenderSequenceFrame(*renderer_, poses_, 10, {}, 1);
  const RenderedFrame plain = renderer_->Render(poses_[10].T_world_camera);
  EXPECT_EQ(cv::norm(f.bgr, plain.bgr, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(f.depth, plain.depth, cv::NORM_INF), 0);
}

TEST_F(SequenceFrameTest, MotionBlurSmearsColourButNotDepth) {
  NoiseOptions blur;
  blur.motion_blur_samples = 5;
  const RenderedFrame f = RenderSequenceFrame(*renderer_, poses_, 10, blur, 1);
  const RenderedFrame plain = renderer_->Render(poses_[10].T_world_camera);
  EXPECT_EQ(cv::norm(f.depth, plain.depth, cv::NORM_INF), 0);
  EXPECT_LT(Sharpness(f.bgr), 0.8 * Sharpness(plain.bgr));
  // The first frame blurs towards its only neighbour and still works.
  EXPECT_EQ(RenderSequenceFrame(*renderer_, poses_, 0, blur, 1).bgr.size(), plain.bgr.size());
}

TEST_F(SequenceFrameTest, NoiseIsPerFrameAndReproducible) {
  NoiseOptions noise;
  noise.depth_noise = true;
  noise.colour_noise_sigma = 3;
  noise.drop_depth_probability = 0.05;
  const RenderedFrame a = RenderSequenceFrame(*renderer_, poses_, 4, noise, 9);
  const RenderedFrame b = RenderSequenceFrame(*renderer_, poses_, 4, noise, 9);
  const RenderedFrame c = RenderSequenceFrame(*renderer_, poses_, 4, noise, 10);
  EXPECT_EQ(cv::norm(a.bgr, b.bgr, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0);
  EXPECT_GT(cv::norm(a.depth, c.depth, cv::NORM_INF), 0);
  const double valid = cv::countNonZero(a.depth) / static_cast<double>(a.depth.total());
  EXPECT_NEAR(valid, 0.95, 0.01);
}

}  // namespace
}  // namespace semmap::synth
