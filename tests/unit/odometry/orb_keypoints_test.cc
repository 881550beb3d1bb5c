#include "core/odometry/internal/orb_keypoints.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap::internal {
namespace {

using odometry_test::Circle;
using odometry_test::MakeRenderer;

cv::Mat RenderedGrey() {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const synth::RenderedFrame frame = MakeRenderer(camera).Render(Circle(8)[0].T_world_camera);
  cv::Mat grey;
  cv::cvtColor(frame.bgr, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

double AngleGap(double a, double b) {
  const double d = std::abs(a - b);
  return std::min(d, 360.0 - d);
}

TEST(OrbKeypointsTest, LevelBudgetsSplitLikeOrb) {
  EXPECT_EQ(OrbLevelBudgets(2000, 4, 1.2), (std::vector<int>{644, 537, 447, 372}));
  for (const auto& [total, levels] : {std::pair{1000, 8}, std::pair{7, 3}, std::pair{50, 1}}) {
    const std::vector<int> b = OrbLevelBudgets(total, levels, 1.2);
    ASSERT_EQ(b.size(), static_cast<size_t>(levels));
    int sum = 0;
    for (size_t l = 0; l < b.size(); ++l) {
      sum += b[l];
      if (l > 0 && l + 1 < b.size()) {
        EXPECT_LE(b[l], b[l - 1]);
      }
    }
    EXPECT_EQ(sum, total);
  }
}

// cv::ORB is the reference: the same corners, Harris responses and orientations, so its
// compute() describes them as it describes its own and the trained vocabulary stays valid.
TEST(OrbKeypointsTest, SameKeypointsAsCvOrbDetect) {
  const cv::Mat grey = RenderedGrey();
  const cv::Ptr<cv::ORB> orb =
      cv::ORB::create(2000, 1.2f, 4, kOrbEdge, 0, 2, cv::ORB::HARRIS_SCORE, kOrbPatchSize, 20);
  std::vector<cv::KeyPoint> reference;
  orb->detect(grey, reference);
  const OrbPyramid pyramid = BuildOrbPyramid(grey, 4, 1.2);
  ASSERT_EQ(pyramid.levels.size(), 4u);
  std::vector<cv::KeyPoint> ours =
      DetectOrbKeypoints(pyramid, 20, OrbLevelBudgets(2000, 4, 1.2), {});
  for (const cv::KeyPoint& k : ours) EXPECT_EQ(k.angle, -1.0f);  // not oriented yet
  OrientOrbKeypoints(pyramid, &ours);
  ASSERT_EQ(ours.size(), reference.size());
  using Key = std::tuple<int, long, long>;
  const auto key = [](const cv::KeyPoint& k) {
    return Key{k.octave, std::lround(k.pt.x * 8), std::lround(k.pt.y * 8)};
  };
  std::map<Key, cv::KeyPoint> by_position;
  for (const cv::KeyPoint& k : ours) by_position[key(k)] = k;
  size_t common = 0;
  for (const cv::KeyPoint& r : reference) {
    const auto it = by_position.find(key(r));
    if (it == by_position.end()) continue;  // a tie at a level's budget, broken otherwise
    ++common;
    EXPECT_NEAR(it->second.response, r.response, 1e-6 * std::abs(r.response) + 1e-12);
    EXPECT_LT(AngleGap(it->second.angle, r.angle), 0.05) << r.pt;
    EXPECT_FLOAT_EQ(it->second.size, r.size);
  }
  EXPECT_GT(common, reference.size() * 97 / 100) << common << " of " << reference.size();
}

// The extractor's ORB settings with `levels` pyramid levels.
cv::Ptr<cv::ORB> Orb(int levels) {
  return cv::ORB::create(1000, 1.2f, levels, kOrbEdge, 0, 2, cv::ORB::HARRIS_SCORE, kOrbPatchSize,
                         20);
}

// A frame's 4-level pyramid and its detected, oriented keypoints.
struct DetectedFrame {
  OrbPyramid pyramid;
  std::vector<cv::KeyPoint> keypoints;
};
DetectedFrame Detect(const cv::Mat& grey) {
  DetectedFrame out{BuildOrbPyramid(grey, 4, 1.2), {}};
  out.keypoints = DetectOrbKeypoints(out.pyramid, 20, OrbLevelBudgets(1000, 4, 1.2), {});
  OrientOrbKeypoints(out.pyramid, &out.keypoints);
  return out;
}

// Descriptors from the frame's own pyramid, a level at a time, must be cv::ORB::compute()'s to
// the bit: the place-recognition vocabulary and every stored keyframe were made with it.
void ExpectDescriptorsOfCvOrbCompute(const cv::Mat& grey, const std::string& what) {
  const cv::Ptr<cv::ORB> full = Orb(4), one_level = Orb(1);
  auto [pyramid, keypoints] = Detect(grey);
  std::vector<cv::KeyPoint> reference = keypoints;
  cv::Mat expected;
  full->compute(grey, reference, expected);
  cv::Mat ours;
  DescribeOrbKeypoints(pyramid, 1.2f, *one_level, &keypoints, &ours);
  ASSERT_EQ(keypoints.size(), reference.size()) << what;
  ASSERT_EQ(ours.rows, expected.rows) << what;
  ASSERT_GT(ours.rows, 300) << what;
  std::set<int> levels;
  for (size_t i = 0; i < keypoints.size(); ++i) {
    ASSERT_EQ(keypoints[i].pt, reference[i].pt) << what;
    levels.insert(keypoints[i].octave);
  }
  EXPECT_EQ(levels.size(), 4u) << what;
  EXPECT_EQ(cv::norm(ours, expected, cv::NORM_HAMMING), 0) << what;
}

TEST(OrbKeypointsTest, LevelByLevelDescriptorsAreCvOrbComputes) {
  ExpectDescriptorsOfCvOrbCompute(RenderedGrey(), "synthetic frame");
  const std::string teddy = std::string(SEMMAP_SHARED_DATA_DIR) + "/tum_fr3_teddy_200/rgb/";
  for (const char* name : {"1341841873.273798.png", "1341841878.294986.png"}) {
    const cv::Mat grey = cv::imread(teddy + name, cv::IMREAD_GRAYSCALE);
    if (grey.empty()) GTEST_SKIP() << teddy << name << " absent (../shared/data)";
    ExpectDescriptorsOfCvOrbCompute(grey, name);
  }
}

TEST(OrbKeypointsTest, KeypointsALevelCannotDescribeAreDroppedTheRestStayAligned) {
  const cv::Ptr<cv::ORB> one_level = Orb(1);
  const auto [pyramid, keypoints] = Detect(RenderedGrey());
  ASSERT_GT(keypoints.size(), 10u);
  cv::Mat before;
  std::vector<cv::KeyPoint> untouched = keypoints;
  DescribeOrbKeypoints(pyramid, 1.2f, *one_level, &untouched, &before);
  // Keypoint 3 moved onto level 2's border: nothing to describe there.
  std::vector<cv::KeyPoint> with_bad = keypoints;
  with_bad[3].octave = 2;
  with_bad[3].pt = cv::Point2f(1.0f, 1.0f);
  cv::Mat after;
  DescribeOrbKeypoints(pyramid, 1.2f, *one_level, &with_bad, &after);
  ASSERT_EQ(with_bad.size(), untouched.size() - 1);
  ASSERT_EQ(after.rows, before.rows - 1);
  for (size_t i = 0, j = 0; i < untouched.size(); ++i) {
    if (i == 3) continue;
    ASSERT_EQ(with_bad[j].pt, untouched[i].pt);
    EXPECT_EQ(
        cv::norm(after.row(static_cast<int>(j)), before.row(static_cast<int>(i)), cv::NORM_HAMMING),
        0);
    ++j;
  }
}

TEST(OrbKeypointsTest, RegionsKeepOnlyTheirOwnCornersOnce) {
  const cv::Mat grey = RenderedGrey();
  const OrbPyramid pyramid = BuildOrbPyramid(grey, 4, 1.2);
  const std::vector<int> unlimited(4, 100000);
  const std::vector<cv::Rect2f> left{{80, 80, 100, 120}}, right{{180, 80, 100, 120}},
      both{{80, 80, 100, 120}, {180, 80, 100, 120}};
  const auto a = DetectOrbKeypoints(pyramid, 7, unlimited, left);
  const auto b = DetectOrbKeypoints(pyramid, 7, unlimited, right);
  const auto ab = DetectOrbKeypoints(pyramid, 7, unlimited, both);
  ASSERT_GT(a.size(), 20u);
  ASSERT_GT(b.size(), 20u);
  for (const cv::KeyPoint& k : a) {
    EXPECT_TRUE(k.pt.x >= 80 && k.pt.x < 180 && k.pt.y >= 80 && k.pt.y < 200) << k.pt;
  }
  EXPECT_EQ(ab.size(), a.size() + b.size());
  // Every level searched, each corner in level-0 pixels.
  std::vector<int> per_level(4, 0);
  for (const cv::KeyPoint& k : ab) ++per_level[static_cast<size_t>(k.octave)];
  for (int n : per_level) EXPECT_GT(n, 0);
}

// What the level budgets cut is handed back: the kept keypoints do not change, and kept and
// passed over together are every corner FAST finds in each level's interior, the passed-over
// ones in level pixels with their FAST score.
TEST(OrbKeypointsTest, CornersCutByTheBudgetsArePassedOver) {
  const cv::Mat grey = RenderedGrey();
  const OrbPyramid pyramid = BuildOrbPyramid(grey, 4, 1.2);
  const std::vector<int> budgets = OrbLevelBudgets(600, 4, 1.2);
  std::vector<cv::KeyPoint> passed_over;
  const std::vector<cv::KeyPoint> plain = DetectOrbKeypoints(pyramid, 20, budgets, {});
  const std::vector<cv::KeyPoint> kept = DetectOrbKeypoints(pyramid, 20, budgets, {}, &passed_over);
  ASSERT_EQ(kept.size(), plain.size());
  for (size_t i = 0; i < kept.size(); ++i) {
    EXPECT_EQ(kept[i].pt, plain[i].pt);
    EXPECT_EQ(kept[i].response, plain[i].response);
    EXPECT_EQ(kept[i].octave, plain[i].octave);
  }
  ASSERT_GT(passed_over.size(), 100u);
  std::vector<size_t> per_level(4, 0);
  for (const cv::KeyPoint& k : kept) ++per_level[static_cast<size_t>(k.octave)];
  for (const cv::KeyPoint& k : passed_over) {
    ASSERT_TRUE(k.octave >= 0 && k.octave < 4);
    const cv::Mat& level = pyramid.levels[static_cast<size_t>(k.octave)];
    EXPECT_TRUE(k.pt.x >= kOrbEdge && k.pt.x < level.cols - kOrbEdge && k.pt.y >= kOrbEdge &&
                k.pt.y < level.rows - kOrbEdge)
        << k.pt << " at level " << k.octave;
    EXPECT_GE(k.response, 20.0f);  // a FAST score, not a Harris response
    ++per_level[static_cast<size_t>(k.octave)];
  }
  for (size_t l = 0; l < 4; ++l) {
    const cv::Mat& level = pyramid.levels[l];
    const cv::Rect interior(kOrbEdge, kOrbEdge, level.cols - 2 * kOrbEdge,
                            level.rows - 2 * kOrbEdge);
    // FAST over the interior and the 3 pixels its circle needs around it, as detection runs it.
    const cv::Rect padded(interior.x - 3, interior.y - 3, interior.width + 6, interior.height + 6);
    std::vector<cv::KeyPoint> all;
    cv::FAST(level(padded), all, 20, true);
    const size_t inside =
        static_cast<size_t>(std::count_if(all.begin(), all.end(), [&](const cv::KeyPoint& k) {
          return interior.contains(
              cv::Point(static_cast<int>(k.pt.x) + padded.x, static_cast<int>(k.pt.y) + padded.y));
        }));
    EXPECT_EQ(per_level[l], inside) << "level " << l;
  }
}

TEST(OrbKeypointsTest, CentroidAngleFollowsTheBrightSide) {
  cv::Mat right(64, 64, CV_8UC1), down(64, 64, CV_8UC1);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      right.at<uint8_t>(y, x) = static_cast<uint8_t>(2 * x + 30);
      down.at<uint8_t>(y, x) = static_cast<uint8_t>(2 * y + 30);
    }
  }
  EXPECT_LT(AngleGap(IntensityCentroidAngle(right, {32, 32}, 15), 0.0), 1e-3);
  EXPECT_LT(AngleGap(IntensityCentroidAngle(down, {32, 32}, 15), 90.0), 1e-3);
  // The disc is the same turned by 90 degrees, so a turned patch turns its angle exactly.
  cv::Mat patch(64, 64, CV_8UC1), turned;
  cv::RNG rng(7);
  rng.fill(patch, cv::RNG::UNIFORM, 0, 256);
  cv::rotate(patch, turned, cv::ROTATE_90_CLOCKWISE);  // (x, y) -> (63 - y, x)
  const float a = IntensityCentroidAngle(patch, {32, 31}, 15);
  const float b = IntensityCentroidAngle(turned, {63 - 31, 32}, 15);
  EXPECT_LT(AngleGap(b, std::fmod(a + 90.0, 360.0)), 1e-3) << a << " " << b;
}

TEST(OrbKeypointsTest, WeakCornersKeptOnlyWithinTheirLevelsBudget) {
  const auto at = [](int octave, float response) {
    cv::KeyPoint k({10, 10}, 31, -1, response, octave);
    return k;
  };
  const std::vector<cv::KeyPoint> strong{at(0, 9), at(0, 7), at(0, 5), at(1, 4)};
  std::vector<cv::KeyPoint> weak{at(0, 8), at(0, 6), at(0, 1), at(1, 3), at(1, 2), at(2, 1)};
  // Level 0 keeps 4 of {9 8 7 6 5 1}: the weak 8 and 6; level 1 keeps 3 of {4 3 2}: both weak;
  // level 2 has no budget.
  KeepWithinLevelBudgets(strong, {4, 3, 0}, &weak);
  std::vector<float> kept(weak.size());
  std::transform(weak.begin(), weak.end(), kept.begin(),
                 [](const cv::KeyPoint& k) { return k.response; });
  EXPECT_EQ(kept, (std::vector<float>{8, 6, 3, 2}));
}

}  // namespace
}  // namespace semmap::internal
