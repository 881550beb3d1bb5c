#include "core/odometry/feature_matcher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/features2d.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "core/odometry/feature_extractor.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::Circle;
using odometry_test::Extract;
using odometry_test::MakeRenderer;
using odometry_test::Project;

class FeatureMatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::vector<StampedPose> poses = Circle(120);
    T_w_a_ = poses[10].T_world_camera;
    T_w_b_ = poses[13].T_world_camera;  // about 14 cm and 9 degrees apart
    const synth::Renderer renderer = MakeRenderer(camera_);
    StatusOr<FeatureExtractor> e = FeatureExtractor::Create({}, camera_);
    ASSERT_TRUE(e.ok());
    a_ = Extract(*e, renderer.Render(T_w_a_));
    b_ = Extract(*e, renderer.Render(T_w_b_));
  }

  // Where keypoint i of view a appears in view b (ground truth), when it has depth.
  std::optional<cv::Point2f> TrueProjection(size_t i) const {
    if (!a_.has_depth[i]) return std::nullopt;
    const Eigen::Vector3d q = T_w_b_.inverse() * (T_w_a_ * a_.points_camera[i]);
    if (q.z() <= 0) return std::nullopt;
    const Eigen::Vector2d uv = Project(camera_, q);
    return cv::Point2f(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
  }

  // Counts matches whose b keypoint lies within 3 px of the true projection.
  std::pair<int, int> CorrectOfChecked(const std::vector<cv::DMatch>& matches) const {
    int correct = 0, checked = 0;
    for (const cv::DMatch& m : matches) {
      const std::optional<cv::Point2f> p = TrueProjection(static_cast<size_t>(m.queryIdx));
      if (!p) continue;
      ++checked;
      if (cv::norm(b_.keypoints[static_cast<size_t>(m.trainIdx)].pt - *p) < 3.0) ++correct;
    }
    return {correct, checked};
  }

  CameraCalibration camera_ = synth::DefaultSyntheticCamera();
  Eigen::Isometry3d T_w_a_, T_w_b_;
  FrameFeatures a_, b_;
};

TEST_F(FeatureMatcherTest, FullMatchingFindsTrueCorrespondences) {
  StatusOr<std::vector<cv::DMatch>> matches = MatchDescriptors(a_.descriptors, b_.descriptors, {});
  ASSERT_TRUE(matches.ok()) << matches.status().ToString();
  const auto [correct, checked] = CorrectOfChecked(*matches);
  EXPECT_GT(checked, 250);
  EXPECT_GT(correct, checked * 9 / 10) << correct << " of " << checked;
  // Mutual check: no train keypoint is used twice.
  std::vector<int> used(b_.size(), 0);
  for (const cv::DMatch& m : *matches) EXPECT_EQ(used[static_cast<size_t>(m.trainIdx)]++, 0);
}

TEST_F(FeatureMatcherTest, GuidedMatchingAroundTruePredictionsIsAtLeastAsGood) {
  std::vector<std::optional<cv::Point2f>> predicted(a_.size());
  for (size_t i = 0; i < a_.size(); ++i) predicted[i] = TrueProjection(i);
  StatusOr<std::vector<cv::DMatch>> guided =
      MatchGuided(a_.descriptors, predicted, b_.descriptors, b_.keypoints, {});
  ASSERT_TRUE(guided.ok()) << guided.status().ToString();
  StatusOr<std::vector<cv::DMatch>> full = MatchDescriptors(a_.descriptors, b_.descriptors, {});
  ASSERT_TRUE(full.ok());
  const auto [correct, checked] = CorrectOfChecked(*guided);
  EXPECT_GE(static_cast<double>(guided->size()), 0.9 * static_cast<double>(full->size()));
  EXPECT_GT(correct, checked * 95 / 100) << correct << " of " << checked;
  // Without predictions nothing matches.
  std::vector<std::optional<cv::Point2f>> none(a_.size());
  StatusOr<std::vector<cv::DMatch>> empty =
      MatchGuided(a_.descriptors, none, b_.descriptors, b_.keypoints, {});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->empty());
}

TEST(FeatureMatcherInputTest, RejectsMismatchedDescriptorsAndAcceptsEmpty) {
  const cv::Mat binary(10, 32, CV_8UC1, cv::Scalar(1));
  const cv::Mat floats(10, 32, CV_32FC1, cv::Scalar(1));
  EXPECT_EQ(MatchDescriptors(binary, floats, {}).status().code(), StatusCode::kInvalidArgument);
  StatusOr<std::vector<cv::DMatch>> none = MatchDescriptors(cv::Mat(), binary, {});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  std::vector<std::optional<cv::Point2f>> two(2);
  EXPECT_EQ(MatchGuided(binary, two, binary, std::vector<cv::KeyPoint>(10), {}).status().code(),
            StatusCode::kInvalidArgument);
  FeatureMatcherOptions bad;
  bad.ratio = 1.5;
  EXPECT_FALSE(bad.Validate().ok());
}

TEST(FeatureMatcherInputTest, FloatDescriptorsMatchByL2) {
  cv::Mat a(3, 4, CV_32FC1), b(3, 4, CV_32FC1);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      a.at<float>(i, j) = static_cast<float>(10 * i + j);
      b.at<float>(2 - i, j) = static_cast<float>(10 * i + j) + 0.1f;
    }
  }
  StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(a, b, {});
  ASSERT_TRUE(m.ok());
  ASSERT_EQ(m->size(), 3u);
  for (const cv::DMatch& d : *m) EXPECT_EQ(d.trainIdx, 2 - d.queryIdx);
}

// The matcher as it was before the one-pass POPCNT kernel (two cv::BFMatcher passes; OpenCV's
// Hamming in guided matching): the new one must give exactly the same matches.
namespace reference {

struct Best {
  int index = -1;
  float distance = std::numeric_limits<float>::max();
  float second = std::numeric_limits<float>::max();
  void Offer(int i, float d) {
    if (d < distance) {
      second = distance;
      distance = d;
      index = i;
    } else if (d < second) {
      second = d;
    }
  }
};

std::vector<cv::DMatch> Select(const std::vector<Best>& query_best,
                               const std::vector<int>& train_best, double max_distance,
                               const FeatureMatcherOptions& options) {
  std::vector<cv::DMatch> out;
  for (size_t i = 0; i < query_best.size(); ++i) {
    const Best& b = query_best[i];
    if (b.index < 0 || b.distance > max_distance) continue;
    if (options.ratio < 1.0 && b.second < std::numeric_limits<float>::max() &&
        !(b.distance < options.ratio * b.second)) {
      continue;
    }
    if (options.cross_check && train_best[static_cast<size_t>(b.index)] != static_cast<int>(i)) {
      continue;
    }
    out.emplace_back(static_cast<int>(i), b.index, b.distance);
  }
  return out;
}

std::vector<cv::DMatch> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                         const FeatureMatcherOptions& options) {
  const bool binary = query.type() == CV_8UC1;
  cv::BFMatcher matcher(binary ? cv::NORM_HAMMING : cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(query, train, knn, 2);
  std::vector<Best> query_best(static_cast<size_t>(query.rows));
  for (const std::vector<cv::DMatch>& m : knn) {
    if (m.empty()) continue;
    Best& b = query_best[static_cast<size_t>(m[0].queryIdx)];
    for (const cv::DMatch& d : m) b.Offer(d.trainIdx, d.distance);
  }
  std::vector<int> train_best(static_cast<size_t>(train.rows), -1);
  if (options.cross_check) {
    std::vector<cv::DMatch> reverse;
    matcher.match(train, query, reverse);
    for (const cv::DMatch& d : reverse) train_best[static_cast<size_t>(d.queryIdx)] = d.trainIdx;
  }
  return Select(query_best, train_best, binary ? options.max_hamming : options.max_l2, options);
}

std::vector<cv::DMatch> MatchGuided(const cv::Mat& query,
                                    const std::vector<std::optional<cv::Point2f>>& predicted,
                                    const cv::Mat& train,
                                    const std::vector<cv::KeyPoint>& train_keypoints,
                                    const FeatureMatcherOptions& options) {
  const bool binary = query.type() == CV_8UC1;
  const float cell = static_cast<float>(options.guided_radius_px);
  float max_x = 0, max_y = 0;
  for (const cv::KeyPoint& k : train_keypoints) {
    max_x = std::max(max_x, k.pt.x);
    max_y = std::max(max_y, k.pt.y);
  }
  const int cols = static_cast<int>(max_x / cell) + 1;
  const int rows = static_cast<int>(max_y / cell) + 1;
  std::vector<std::vector<int>> grid(static_cast<size_t>(cols * rows));
  for (size_t j = 0; j < train_keypoints.size(); ++j) {
    const cv::Point2f& p = train_keypoints[j].pt;
    if (!(p.x >= 0 && p.y >= 0)) continue;
    const int index = static_cast<int>(p.y / cell) * cols + static_cast<int>(p.x / cell);
    grid[static_cast<size_t>(index)].push_back(static_cast<int>(j));
  }
  const float r2 = cell * cell;
  std::vector<Best> query_best(static_cast<size_t>(query.rows));
  std::vector<Best> train_best_dist(static_cast<size_t>(train.rows));
  for (int i = 0; i < query.rows; ++i) {
    const std::optional<cv::Point2f>& p = predicted[static_cast<size_t>(i)];
    if (!p || !std::isfinite(p->x) || !std::isfinite(p->y)) continue;
    const int gx = static_cast<int>(std::floor(p->x / cell));
    const int gy = static_cast<int>(std::floor(p->y / cell));
    for (int y = std::max(0, gy - 1); y <= std::min(rows - 1, gy + 1); ++y) {
      for (int x = std::max(0, gx - 1); x <= std::min(cols - 1, gx + 1); ++x) {
        const int index = y * cols + x;
        for (int j : grid[static_cast<size_t>(index)]) {
          const cv::Point2f d = train_keypoints[static_cast<size_t>(j)].pt - *p;
          if (d.x * d.x + d.y * d.y > r2) continue;
          const float dist = binary ? static_cast<float>(cv::hal::normHamming(
                                          query.ptr<uchar>(i), train.ptr<uchar>(j), query.cols))
                                    : std::sqrt(cv::hal::normL2Sqr_(
                                          query.ptr<float>(i), train.ptr<float>(j), query.cols));
          query_best[static_cast<size_t>(i)].Offer(j, dist);
          train_best_dist[static_cast<size_t>(j)].Offer(i, dist);
        }
      }
    }
  }
  std::vector<int> train_best(static_cast<size_t>(train.rows), -1);
  for (size_t j = 0; j < train_best.size(); ++j) train_best[j] = train_best_dist[j].index;
  return Select(query_best, train_best, binary ? options.max_hamming : options.max_l2, options);
}

}  // namespace reference

// Binary descriptors with many equal distances: each bit is set with probability `density`, and
// a quarter of the train rows are copies of query rows with a few bits flipped (some exact
// duplicates), so best, second best and the cross check all see ties.
struct RandomPair {
  cv::Mat query, train;
};

RandomPair MakeBinary(int query_rows, int train_rows, int bytes, double density, uint32_t seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution bit(density);
  const auto fill = [&](cv::Mat& m) {
    for (int r = 0; r < m.rows; ++r) {
      for (int c = 0; c < m.cols; ++c) {
        int v = 0;
        for (int b = 0; b < 8; ++b) v |= bit(rng) ? 1 << b : 0;
        m.at<uint8_t>(r, c) = static_cast<uint8_t>(v);
      }
    }
  };
  RandomPair p{cv::Mat(query_rows, bytes, CV_8UC1), cv::Mat(train_rows, bytes, CV_8UC1)};
  fill(p.query);
  fill(p.train);
  std::uniform_int_distribution<int> row(0, query_rows - 1), col(0, bytes - 1), flips(0, 3);
  for (int j = 0; j < train_rows; j += 4) {
    p.query.row(row(rng)).copyTo(p.train.row(j));
    for (int f = flips(rng); f > 0; --f) p.train.at<uint8_t>(j, col(rng)) ^= 1 << (rng() % 8);
  }
  // Duplicate query rows too: the cross check's ties are among queries.
  for (int i = 1; i < query_rows; i += 7) p.query.row(i - 1).copyTo(p.query.row(i));
  return p;
}

std::string Describe(const std::vector<cv::DMatch>& m) {
  std::string s;
  for (const cv::DMatch& d : m) {
    s += std::to_string(d.queryIdx) + "->" + std::to_string(d.trainIdx) + "@" +
         std::to_string(d.distance) + " ";
  }
  return s;
}

void ExpectSameMatches(const std::vector<cv::DMatch>& expected,
                       const std::vector<cv::DMatch>& actual, const std::string& what) {
  bool same = expected.size() == actual.size();
  for (size_t k = 0; same && k < expected.size(); ++k) {
    same = expected[k].queryIdx == actual[k].queryIdx &&
           expected[k].trainIdx == actual[k].trainIdx && expected[k].imgIdx == actual[k].imgIdx &&
           expected[k].distance == actual[k].distance;
  }
  EXPECT_TRUE(same) << what << "\nexpected " << Describe(expected) << "\nactual   "
                    << Describe(actual);
}

std::vector<FeatureMatcherOptions> OptionVariants() {
  std::vector<FeatureMatcherOptions> out;
  for (double ratio : {0.8, 0.95, 1.0}) {
    for (bool cross : {true, false}) {
      for (double max_hamming : {24.0, 64.0, 1e6}) {
        FeatureMatcherOptions o;
        o.ratio = ratio;
        o.cross_check = cross;
        o.max_hamming = max_hamming;
        o.max_l2 = max_hamming;
        out.push_back(o);
      }
    }
  }
  return out;
}

std::string Name(const FeatureMatcherOptions& o) {
  return "ratio " + std::to_string(o.ratio) + " cross " + std::to_string(o.cross_check) + " max " +
         std::to_string(o.max_hamming);
}

TEST(FeatureMatcherEquivalenceTest, BinaryMatchesEqualTwoPassBruteForce) {
  struct Case {
    int query_rows, train_rows, bytes;
    double density;
  };
  // ORB (32 bytes) and BRISK (64) take the fixed-width kernels, the rest the general one; single
  // rows give no second best; low densities give many ties.
  const Case cases[] = {{300, 400, 32, 0.5}, {400, 300, 32, 0.1}, {257, 129, 32, 0.02},
                        {100, 120, 64, 0.5}, {90, 150, 64, 0.05}, {120, 100, 61, 0.3},
                        {80, 90, 8, 0.2},    {70, 60, 5, 0.1},    {50, 40, 1, 0.5},
                        {1, 50, 32, 0.5},    {50, 1, 32, 0.5},    {1, 1, 32, 0.5},
                        {33, 2, 32, 0.01},   {64, 64, 16, 0.0}};
  uint32_t seed = 1;
  for (const Case& c : cases) {
    const RandomPair p = MakeBinary(c.query_rows, c.train_rows, c.bytes, c.density, seed++);
    for (const FeatureMatcherOptions& o : OptionVariants()) {
      StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(p.query, p.train, o);
      ASSERT_TRUE(m.ok()) << m.status().ToString();
      ExpectSameMatches(reference::MatchDescriptors(p.query, p.train, o), *m,
                        std::to_string(c.query_rows) + "x" + std::to_string(c.train_rows) + "x" +
                            std::to_string(c.bytes) + " density " + std::to_string(c.density) +
                            ", " + Name(o));
    }
  }
}

TEST(FeatureMatcherEquivalenceTest, NonContiguousRowsAndEqualDistances) {
  // Descriptors as a column range of wider rows (row step != width).
  const RandomPair wide = MakeBinary(200, 220, 40, 0.3, 99);
  const cv::Mat query = wide.query.colRange(3, 35), train = wide.train.colRange(5, 37);
  ASSERT_FALSE(query.isContinuous());
  for (const FeatureMatcherOptions& o : OptionVariants()) {
    StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(query, train, o);
    ASSERT_TRUE(m.ok());
    ExpectSameMatches(reference::MatchDescriptors(query, train, o), *m, "ROI, " + Name(o));
  }

  // Query 0 equals train rows 2 and 5: the lower train index wins, and the equal second best
  // fails any ratio test below 1. Queries 1 and 3 both equal train row 7: the lower query wins
  // the cross check.
  cv::Mat q(4, 32, CV_8UC1, cv::Scalar(0)), t(8, 32, CV_8UC1, cv::Scalar(0xff));
  q.row(0).setTo(0x0f);
  t.row(2).setTo(0x0f);
  t.row(5).setTo(0x0f);
  q.row(1).setTo(0x33);
  q.row(3).setTo(0x33);
  t.row(7).setTo(0x33);
  q.row(2).setTo(0x55);
  FeatureMatcherOptions no_ratio;
  no_ratio.ratio = 1.0;
  no_ratio.max_hamming = 256;
  StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(q, t, no_ratio);
  ASSERT_TRUE(m.ok());
  ASSERT_EQ(m->size(), 2u) << Describe(*m);
  EXPECT_EQ((*m)[0].queryIdx, 0);
  EXPECT_EQ((*m)[0].trainIdx, 2);
  EXPECT_EQ((*m)[1].queryIdx, 1);
  EXPECT_EQ((*m)[1].trainIdx, 7);
  ExpectSameMatches(reference::MatchDescriptors(q, t, no_ratio), *m, "ties");
  StatusOr<std::vector<cv::DMatch>> ratio = MatchDescriptors(q, t, {});
  ASSERT_TRUE(ratio.ok());
  ExpectSameMatches(reference::MatchDescriptors(q, t, {}), *ratio, "ties with ratio");
  for (const cv::DMatch& d : *ratio) EXPECT_NE(d.queryIdx, 0);
}

TEST(FeatureMatcherEquivalenceTest, FloatMatchesEqualTwoPassBruteForce) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> value(0, 3);  // small integers: equal distances
  cv::Mat query(60, 8, CV_32FC1), train(70, 8, CV_32FC1);
  for (cv::Mat* m : {&query, &train}) {
    for (int r = 0; r < m->rows; ++r) {
      for (int c = 0; c < m->cols; ++c) m->at<float>(r, c) = static_cast<float>(value(rng));
    }
  }
  for (const FeatureMatcherOptions& o : OptionVariants()) {
    StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(query, train, o);
    ASSERT_TRUE(m.ok());
    ExpectSameMatches(reference::MatchDescriptors(query, train, o), *m, "float, " + Name(o));
  }
}

TEST(FeatureMatcherEquivalenceTest, GuidedMatchesEqualFormerImplementation) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> coord(0, 120);
  std::normal_distribution<float> offset(0, 6);
  std::bernoulli_distribution has_prediction(0.8);
  for (int bytes : {32, 64, 13}) {
    for (double density : {0.5, 0.05}) {
      const RandomPair p = MakeBinary(300, 350, bytes, density, static_cast<uint32_t>(bytes));
      std::vector<cv::KeyPoint> keypoints(static_cast<size_t>(p.train.rows));
      for (cv::KeyPoint& k : keypoints) k.pt = cv::Point2f(coord(rng), coord(rng));
      keypoints[3].pt = cv::Point2f(-1, 5);  // outside the grid: never a candidate
      std::vector<std::optional<cv::Point2f>> predicted(static_cast<size_t>(p.query.rows));
      for (size_t i = 0; i < predicted.size(); ++i) {
        if (!has_prediction(rng)) continue;
        const cv::Point2f base = keypoints[i % keypoints.size()].pt;
        predicted[i] = base + cv::Point2f(offset(rng), offset(rng));
      }
      predicted[5] = cv::Point2f(std::numeric_limits<float>::quiet_NaN(), 3);
      for (FeatureMatcherOptions o : OptionVariants()) {
        for (double radius : {4.0, 12.0, 40.0}) {
          o.guided_radius_px = radius;
          StatusOr<std::vector<cv::DMatch>> m =
              MatchGuided(p.query, predicted, p.train, keypoints, o);
          ASSERT_TRUE(m.ok()) << m.status().ToString();
          ExpectSameMatches(reference::MatchGuided(p.query, predicted, p.train, keypoints, o), *m,
                            "guided " + std::to_string(bytes) + " bytes, density " +
                                std::to_string(density) + ", radius " + std::to_string(radius) +
                                ", " + Name(o));
        }
      }
    }
  }
}

TEST_F(FeatureMatcherTest, RealOrbMatchesEqualFormerImplementation) {
  for (const FeatureMatcherOptions& o : OptionVariants()) {
    StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(a_.descriptors, b_.descriptors, o);
    ASSERT_TRUE(m.ok());
    ExpectSameMatches(reference::MatchDescriptors(a_.descriptors, b_.descriptors, o), *m,
                      "ORB, " + Name(o));
  }
  std::vector<std::optional<cv::Point2f>> predicted(a_.size());
  for (size_t i = 0; i < a_.size(); ++i) predicted[i] = TrueProjection(i);
  StatusOr<std::vector<cv::DMatch>> guided =
      MatchGuided(a_.descriptors, predicted, b_.descriptors, b_.keypoints, {});
  ASSERT_TRUE(guided.ok());
  ExpectSameMatches(
      reference::MatchGuided(a_.descriptors, predicted, b_.descriptors, b_.keypoints, {}), *guided,
      "guided ORB");
}

}  // namespace
}  // namespace semmap
