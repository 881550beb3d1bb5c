#include "core/odometry/rgbd_refiner.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "core/odometry/local_map.h"
#include "tests/testing/pinhole_camera.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

CameraCalibration Camera() { return testing::PinholeCamera(640, 480, 525); }

Eigen::Isometry3d TruePose() {  // T_current_reference
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.05, -0.02, 0.1);
  return T;
}

// Points 1-4 m in front, observed with pixel noise and depth noise sigma_z = 1.5e-3 z^2;
// every fifth observation is an outlier (pixel moved by 30 px or depth by 30%).
std::vector<RgbdObservation> Observations(const CameraCalibration& c, int n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-1.0, 1.0), depth(1.0, 4.0);
  std::normal_distribution<double> unit(0.0, 1.0);
  const Eigen::Isometry3d T = TruePose();
  std::vector<RgbdObservation> obs;
  while (static_cast<int>(obs.size()) < n) {
    const double z = depth(rng);
    const Eigen::Vector3d p(xy(rng) * 0.5 * z, xy(rng) * 0.4 * z, z);  // current camera frame
    RgbdObservation o;
    o.point = T.inverse() * p;
    o.pixel = odometry_test::Project(c, p) + 0.7 * Eigen::Vector2d(unit(rng), unit(rng));
    o.inverse_depth = 1.0 / (z + 1.5e-3 * z * z * unit(rng));
    if (obs.size() % 5 == 4) {
      if (obs.size() % 10 == 4) {
        o.pixel.x() += 30;
      } else {
        o.inverse_depth *= 1.3;
      }
    }
    obs.push_back(o);
  }
  return obs;
}

TEST(RgbdRefinerTest, RecoversThePoseAndRejectsPixelAndDepthOutliers) {
  const CameraCalibration c = Camera();
  const std::vector<RgbdObservation> obs = Observations(c, 300);
  Eigen::Isometry3d start = TruePose();
  start.translation() += Eigen::Vector3d(0.02, 0.01, -0.03);
  const RgbdRefinement r = RefinePoseRgbd(obs, c, RgbdRefinerOptions{}, start);
  const Eigen::Isometry3d error = TruePose().inverse() * r.T_current_reference;
  EXPECT_LT(error.translation().norm(), 2e-3);
  EXPECT_LT(odometry_test::AngleDeg(error), 0.1);
  int outliers_kept = 0, inliers_dropped = 0;
  for (size_t i = 0; i < obs.size(); ++i) {
    if (i % 5 == 4) {
      outliers_kept += r.inlier[i] ? 1 : 0;
    } else {
      inliers_dropped += r.inlier[i] ? 0 : 1;
    }
  }
  EXPECT_EQ(outliers_kept, 0);
  EXPECT_LT(inliers_dropped, 24);  // about 5% of 240 fail a 95% gate
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(r.information);
  EXPECT_GT(eigen.eigenvalues().minCoeff(), 0);
}

TEST(RgbdRefinerTest, DepthTermAddsInformationOnTheOpticalAxis) {
  const CameraCalibration c = Camera();
  std::vector<RgbdObservation> clean;
  const std::vector<RgbdObservation> obs = Observations(c, 300);
  for (size_t i = 0; i < obs.size(); ++i) {
    if (i % 5 != 4) clean.push_back(obs[i]);
  }
  RgbdRefinerOptions with_depth, without_depth;
  without_depth.use_depth = false;
  const RgbdRefinement a = RefinePoseRgbd(clean, c, with_depth, TruePose());
  const RgbdRefinement b = RefinePoseRgbd(clean, c, without_depth, TruePose());
  EXPECT_GT(a.information(2, 2), 1.5 * b.information(2, 2));
}

TEST(LocalMapTest, FusesDepthObservationsAndFollowsACorrection) {
  const CameraCalibration c = Camera();
  LocalMap map(LocalMapOptions{}, c);
  // One point seen by two keyframes from different sides with depth errors of 2 cm.
  const Eigen::Vector3d X(0.1, 0.0, 2.0);
  Eigen::Isometry3d T_w_a = Eigen::Isometry3d::Identity(), T_w_b = Eigen::Isometry3d::Identity();
  T_w_a.translation() = Eigen::Vector3d(-0.5, 0, 0);
  T_w_b.translation() = Eigen::Vector3d(2.1, 0, 2.0);  // 2 m to the side, looking along -x
  T_w_b.linear() = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const auto frame = [&](const Eigen::Isometry3d& T_w_c, double depth_error) {
    FrameFeatures f;
    Eigen::Vector3d p = T_w_c.inverse() * X;
    p *= (p.z() + depth_error) / p.z();  // along the ray
    const Eigen::Vector2d u = odometry_test::Project(c, p);
    f.keypoints.emplace_back(static_cast<float>(u.x()), static_cast<float>(u.y()), 31.f);
    f.descriptors = cv::Mat(1, 32, CV_8U, cv::Scalar(7));
    f.points_camera.push_back(p);
    f.has_depth.push_back(true);
    return f;
  };
  map.AddKeyframe(0, frame(T_w_a, 0.02), T_w_a, {});
  ASSERT_EQ(map.size(), 1u);
  const double first_error = (map.point(0).position_world - X).norm();
  map.AddKeyframe(1, frame(T_w_b, 0.02), T_w_b, {0});
  ASSERT_EQ(map.size(), 1u);
  EXPECT_EQ(map.point(0).num_depth_observations, 2);
  // The rays cross at ~70 degrees: each view's precise bearing fixes the other's depth.
  EXPECT_LT((map.point(0).position_world - X).norm(), 0.5 * first_error);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(1, 2, 3);
  const Eigen::Vector3d before = map.point(0).position_world;
  map.Transform(T);
  EXPECT_LT((map.point(0).position_world - T * before).norm(), 1e-9);
  // Outside the keyframe window the point is dropped.
  FrameFeatures empty;
  empty.descriptors = cv::Mat(0, 32, CV_8U);
  map.AddKeyframe(1 + LocalMapOptions{}.window_keyframes, empty, T_w_a, {});
  EXPECT_EQ(map.size(), 0u);
}

TEST(LocalMapTest, PointsKeepTheirIdsAndTakeTheBackEndsPositions) {
  const CameraCalibration c = Camera();
  LocalMap map(LocalMapOptions{}, c);
  FrameFeatures f;
  for (int k = 0; k < 3; ++k) {
    f.keypoints.emplace_back(100.0f + 50 * k, 100.0f, 31.f);
    f.points_camera.emplace_back(0.1 * k, 0, k == 2 ? 0.0 : 2.0);
    f.has_depth.push_back(k != 2);
  }
  f.descriptors = cv::Mat(3, 32, CV_8U, cv::Scalar(7));
  std::vector<int64_t> ids;
  map.AddKeyframe(0, f, Eigen::Isometry3d::Identity(), {}, &ids);
  ASSERT_EQ(ids.size(), 3u);
  EXPECT_EQ(ids[2], -1);  // no depth: no point
  EXPECT_NE(ids[0], ids[1]);
  std::vector<int64_t> again;
  map.AddKeyframe(1, f, Eigen::Isometry3d::Identity(), {1, -1, -1}, &again);
  EXPECT_EQ(again[0], map.point(1).id);  // matched: that point's id
  EXPECT_GT(again[1], ids[1]);           // unmatched with depth: a new point, a new id

  // The back end's update: a known point moves, a forgotten one comes back (shifted by the
  // correction that arrived after the update).
  const size_t before = map.size();
  LocalMapUpdate update;
  update.ids = {ids[0], 999};
  update.positions_world = {Eigen::Vector3d(0, 0, 2.5), Eigen::Vector3d(1, 1, 3)};
  update.octaves = {0, 2};
  update.descriptors = cv::Mat(2, 32, CV_8U, cv::Scalar(9));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = 0.5;
  map.Merge(update, T, 1);
  ASSERT_EQ(map.size(), before + 1);
  EXPECT_TRUE(map.point(0).position_world.isApprox(Eigen::Vector3d(0.5, 0, 2.5)));
  EXPECT_EQ(map.point(before).id, 999);
  EXPECT_TRUE(map.point(before).position_world.isApprox(Eigen::Vector3d(1.5, 1, 3)));
  EXPECT_EQ(map.point(before).octave, 2);
  EXPECT_EQ(map.descriptors().rows, static_cast<int>(map.size()));
  EXPECT_EQ(map.descriptors().at<uint8_t>(static_cast<int>(before), 0), 9);
  // A malformed update (sizes disagree) changes nothing.
  update.octaves.pop_back();
  map.Merge(update, Eigen::Isometry3d::Identity(), 1);
  EXPECT_EQ(map.size(), before + 1);

  // A point the back end fused into another is retired (even by an update with no points)
  // and gone at the next keyframe; the rest stay.
  LocalMapUpdate retire;
  retire.retired_ids = {ids[0]};
  map.Merge(retire, Eigen::Isometry3d::Identity(), 1);
  EXPECT_TRUE(map.point(0).retired);
  EXPECT_FALSE(map.point(before).retired);
  map.AddKeyframe(2, f, Eigen::Isometry3d::Identity(), {});
  for (size_t i = 0; i < map.size(); ++i) {
    EXPECT_NE(map.point(i).id, ids[0]);
    EXPECT_FALSE(map.point(i).retired);
  }
  bool kept_999 = false;
  for (size_t i = 0; i < map.size(); ++i) kept_999 |= map.point(i).id == 999;
  EXPECT_TRUE(kept_999);
}

// A revisit: the tracker makes no keyframes while the back end refreshes its map with the
// points around each mapped keyframe it passes. A refresh forgets the points earlier updates
// brought that it does not hold; the tracker's own keyframes' points stay.
TEST(LocalMapTest, ARefreshReplacesThePointsOnlyUpdatesBrought) {
  LocalMap map(LocalMapOptions{}, Camera());
  FrameFeatures f;
  f.keypoints.emplace_back(100.0f, 100.0f, 31.f);
  f.points_camera.emplace_back(0, 0, 2.0);
  f.has_depth.push_back(true);
  f.descriptors = cv::Mat(1, 32, CV_8U, cv::Scalar(7));
  std::vector<int64_t> own;
  map.AddKeyframe(0, f, Eigen::Isometry3d::Identity(), {}, &own);
  const auto update_of = [](std::vector<int64_t> ids, bool refresh) {
    LocalMapUpdate u;
    u.ids = ids;
    for (size_t i = 0; i < ids.size(); ++i) {
      u.positions_world.emplace_back(static_cast<double>(i), 0, 3);
      u.octaves.push_back(0);
    }
    u.descriptors = cv::Mat(static_cast<int>(ids.size()), 32, CV_8U,
                            cv::Scalar(static_cast<double>(ids.front() % 200)));
    u.refresh = refresh;
    return u;
  };
  const auto ids = [&] {
    std::set<int64_t> out;
    for (size_t i = 0; i < map.size(); ++i) out.insert(map.point(i).id);
    return out;
  };
  map.Merge(update_of({100, 101}, false), Eigen::Isometry3d::Identity(), 0);
  map.Merge(update_of({102}, false), Eigen::Isometry3d::Identity(), 0);  // adds
  EXPECT_EQ(ids(), (std::set<int64_t>{own[0], 100, 101, 102}));
  map.Merge(update_of({101, 103}, true), Eigen::Isometry3d::Identity(), 0);
  EXPECT_EQ(ids(), (std::set<int64_t>{own[0], 101, 103}));
  ASSERT_EQ(map.descriptors().rows, 3);
  for (size_t i = 0; i < map.size(); ++i) {
    // Each point's descriptor row followed it through the compaction.
    const int expected = map.point(i).id == own[0] ? 7 : (map.point(i).id == 103 ? 101 : 100);
    EXPECT_EQ(map.descriptors().at<uint8_t>(static_cast<int>(i), 0), expected) << i;
  }
}

}  // namespace
}  // namespace semmap
