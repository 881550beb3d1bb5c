#include "tests/testing/synth/texture.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace semmap::synth {
namespace {

cv::Mat Texture(int cols, int rows, TextureStyle style, uint64_t seed) {
  StatusOr<cv::Mat> t = GenerateTexture(cols, rows, style, seed);
  EXPECT_TRUE(t.ok()) << t.status().ToString();
  return t.ok() ? *t : cv::Mat();
}

bool Identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST(TextureTest, IsBgr8OfTheRequestedSize) {
  const cv::Mat t = Texture(300, 200, TextureStyle::kWall, 1);
  EXPECT_EQ(t.type(), CV_8UC3);
  EXPECT_EQ(t.cols, 300);
  EXPECT_EQ(t.rows, 200);
}

TEST(TextureTest, SameSeedSameTexelsOtherSeedOtherTexels) {
  for (TextureStyle style : {TextureStyle::kWall, TextureStyle::kFloor, TextureStyle::kCeiling,
                             TextureStyle::kFurniture, TextureStyle::kObject}) {
    const cv::Mat a = Texture(240, 160, style, 42);
    EXPECT_TRUE(Identical(a, Texture(240, 160, style, 42)));
    const cv::Mat b = Texture(240, 160, style, 43);
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    // Most texels differ (not a shifted or recoloured copy).
    cv::Mat grey;
    cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
    EXPECT_GT(cv::countNonZero(grey > 10), grey.total() / 2);
  }
}

TEST(TextureTest, RejectsBadSizes) {
  EXPECT_EQ(GenerateTexture(4, 100, TextureStyle::kWall, 1).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(GenerateTexture(100, 20000, TextureStyle::kWall, 1).status().code(),
            StatusCode::kInvalidArgument);
}

TEST(TextureTest, HasManyCornersEverywhere) {
  const cv::Mat t = Texture(640, 480, TextureStyle::kWall, 7);
  cv::Ptr<cv::ORB> orb = cv::ORB::create(3000);
  std::vector<cv::KeyPoint> keypoints;
  orb->detect(t, keypoints);
  EXPECT_GT(keypoints.size(), 1500u);
  // Spread: every cell of a 4x4 grid holds keypoints (no blank regions).
  int cells[16] = {};
  for (const cv::KeyPoint& k : keypoints) {
    ++cells[static_cast<int>(k.pt.y / 120) * 4 + static_cast<int>(k.pt.x / 160)];
  }
  for (int c : cells) EXPECT_GT(c, 20);
}

TEST(TextureTest, ObjectTextureCarriesTheCaptionDeterministically) {
  StatusOr<cv::Mat> with = GenerateTexture(300, 300, TextureStyle::kObject, 5, "MUG");
  StatusOr<cv::Mat> without = GenerateTexture(300, 300, TextureStyle::kObject, 5);
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_FALSE(Identical(*with, *without));
  EXPECT_TRUE(Identical(*with, *GenerateTexture(300, 300, TextureStyle::kObject, 5, "MUG")));
}

}  // namespace
}  // namespace semmap::synth
