#include "core/slam/bundle_adjustment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/testing/pinhole_camera.h"

namespace semmap {
namespace {

CameraCalibration TestCamera() { return testing::PinholeCamera(640, 480, 525); }

Eigen::Isometry3d Perturbed(const Eigen::Isometry3d& T, std::mt19937& rng, double sigma_t,
                            double sigma_r) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Vector3d w;
  for (int i = 0; i < 3; ++i) w[i] = n(rng) * sigma_r;
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) t[i] = n(rng) * sigma_t;
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  D.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  D.translation() = t;
  return T * D;
}

double RotationDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180 / M_PI;
}

// Eight keyframes on an arc looking at a cloud of 300 points 2-4 m away; every point is
// observed (exact pixels and inverse depth) by each keyframe that sees it.
struct Scene {
  std::vector<Eigen::Isometry3d> T_world_camera;
  std::vector<Eigen::Vector3d> points;
  std::vector<BundleAdjustmentKeyframe> keyframes;
  std::vector<BundleAdjustmentPoint> ba_points;
  std::vector<BundleAdjustmentObservation> observations;
  CameraCalibration camera = TestCamera();

  explicit Scene(uint32_t seed = 3) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int i = 0; i < 300; ++i) points.emplace_back(1.2 * u(rng), 0.9 * u(rng), 3 + u(rng));
    for (int k = 0; k < 8; ++k) {
      const double a = (k - 3.5) * 0.06;
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() << 3 * std::sin(a), 0.05 * k, 3 - 3 * std::cos(a);
      T.linear() = Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitY()).toRotationMatrix();
      T_world_camera.push_back(T);
    }
    for (size_t k = 0; k < T_world_camera.size(); ++k) {
      keyframes.push_back({static_cast<int64_t>(100 + k), T_world_camera[k], camera, false});
    }
    for (size_t i = 0; i < points.size(); ++i) {
      ba_points.push_back({static_cast<int64_t>(i), points[i], false});
      for (size_t k = 0; k < T_world_camera.size(); ++k) {
        const Eigen::Vector3d p = T_world_camera[k].inverse() * points[i];
        const Eigen::Vector2d px(camera.fx * p.x() / p.z() + camera.cx,
                                 camera.fy * p.y() / p.z() + camera.cy);
        if (px.x() < 0 || px.y() < 0 || px.x() >= camera.width || px.y() >= camera.height) continue;
        observations.push_back({keyframes[k].id, static_cast<int64_t>(i), px, 1.0, 1 / p.z()});
      }
    }
  }

  // Free keyframes moved by ~2 cm / 1 deg, free points by ~3 cm; the first `fixed` keyframes
  // stay where they are and are marked fixed.
  void Perturb(int fixed, uint32_t seed = 11) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0, 0.03);
    for (size_t k = 0; k < keyframes.size(); ++k) {
      keyframes[k].fixed = static_cast<int>(k) < fixed;
      if (!keyframes[k].fixed) {
        keyframes[k].T_world_camera = Perturbed(T_world_camera[k], rng, 0.02, 1.0 * M_PI / 180);
      }
    }
    for (auto& p : ba_points) p.position_world += Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
};

TEST(BundleAdjustmentTest, RecoversPerturbedPosesAndPointsToUnderAMillimetre) {
  Scene scene;
  scene.Perturb(/*fixed=*/2);
  const auto result =
      BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, BundleAdjustmentOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_EQ(result->num_outliers, 0);
  EXPECT_EQ(result->num_points_optimised, 300);
  EXPECT_LT(result->final_cost, 1e-6 * result->initial_cost);
  for (size_t k = 0; k < scene.keyframes.size(); ++k) {
    const Eigen::Isometry3d& T = result->T_world_keyframe[k].second;
    EXPECT_EQ(result->T_world_keyframe[k].first, scene.keyframes[k].id);
    EXPECT_LT((T.translation() - scene.T_world_camera[k].translation()).norm(), 1e-3) << k;
    EXPECT_LT(RotationDeg(T, scene.T_world_camera[k]), 0.01) << k;
  }
  for (size_t i = 0; i < scene.points.size(); ++i) {
    EXPECT_LT((result->position_world[i].second - scene.points[i]).norm(), 1e-3) << i;
  }
}

TEST(BundleAdjustmentTest, FixedKeyframesAndPointsStayExactlyWhereTheyAre) {
  Scene scene;
  scene.Perturb(/*fixed=*/3);
  scene.ba_points[7].fixed = true;
  const Eigen::Vector3d fixed_point = scene.ba_points[7].position_world;
  const auto result =
      BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, BundleAdjustmentOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(result->T_world_keyframe[k].second.matrix().isApprox(
        scene.keyframes[k].T_world_camera.matrix(), 1e-12))
        << k;
  }
  EXPECT_EQ(result->position_world[7].second, fixed_point);
  // The others moved (they were perturbed and the data pull them back).
  EXPECT_GT((result->T_world_keyframe[5].second.translation() -
             scene.keyframes[5].T_world_camera.translation())
                .norm(),
            1e-3);
}

TEST(BundleAdjustmentTest, RejectsGrossOutlierObservationsAndStillRecoversTheScene) {
  Scene scene;
  scene.Perturb(/*fixed=*/2);
  std::mt19937 rng(5);
  std::vector<bool> corrupted(scene.observations.size(), false);
  for (size_t i = 0; i < scene.observations.size(); i += 20) {  // 5 %
    scene.observations[i].pixel += Eigen::Vector2d(25, -18);
    corrupted[i] = true;
  }
  const auto result =
      BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, BundleAdjustmentOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  int flagged_corrupted = 0, flagged_clean = 0;
  for (size_t i = 0; i < corrupted.size(); ++i) {
    if (!result->outlier[i]) continue;
    (corrupted[i] ? flagged_corrupted : flagged_clean)++;
  }
  const int num_corrupted = static_cast<int>((scene.observations.size() + 19) / 20);
  EXPECT_EQ(flagged_corrupted, num_corrupted);
  EXPECT_EQ(flagged_clean, 0);
  for (size_t k = 0; k < scene.keyframes.size(); ++k) {
    EXPECT_LT(
        (result->T_world_keyframe[k].second.translation() - scene.T_world_camera[k].translation())
            .norm(),
        1e-3)
        << k;
  }
}

TEST(BundleAdjustmentTest, ReprojectionOnlyRecoversTheSceneWhenTwoKeyframesFixTheScale) {
  Scene scene;
  scene.Perturb(/*fixed=*/2);
  BundleAdjustmentOptions options;
  options.use_depth = false;
  options.refine_iterations = 30;
  const auto result = BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, options);
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_EQ(result->num_outliers, 0);
  for (size_t k = 0; k < scene.keyframes.size(); ++k) {
    EXPECT_LT(
        (result->T_world_keyframe[k].second.translation() - scene.T_world_camera[k].translation())
            .norm(),
        1e-3)
        << k;
  }
}

TEST(BundleAdjustmentTest, PointsBehindTheCameraAreOutliersAndUndeterminedPointsStay) {
  Scene scene;
  // A point behind keyframe 0 (observed with a made-up pixel), and a point seen once without
  // depth: neither can be solved for.
  scene.ba_points.push_back({1000, Eigen::Vector3d(0, 0, -2), false});
  scene.observations.push_back({scene.keyframes[0].id, 1000, Eigen::Vector2d(320, 240), 1.0, 0});
  scene.observations.push_back({scene.keyframes[1].id, 1000, Eigen::Vector2d(320, 240), 1.0, 0});
  scene.ba_points.push_back({1001, Eigen::Vector3d(0.1, 0.2, 3.5), false});
  const Eigen::Vector3d p =
      scene.keyframes[2].T_world_camera.inverse() * Eigen::Vector3d(0.1, 0.2, 3.5);
  scene.observations.push_back(
      {scene.keyframes[2].id, 1001,
       Eigen::Vector2d(525 * p.x() / p.z() + 319.5 + 1, 525 * p.y() / p.z() + 239.5), 1.0, 0});
  const auto result =
      BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, BundleAdjustmentOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  const size_t n = scene.observations.size();
  EXPECT_TRUE(result->outlier[n - 3]);
  EXPECT_TRUE(result->outlier[n - 2]);
  EXPECT_EQ(result->position_world[scene.ba_points.size() - 1].second,
            Eigen::Vector3d(0.1, 0.2, 3.5));
  EXPECT_EQ(result->num_points_optimised, 300);
}

TEST(BundleAdjustmentTest, StopsAtTheTimeLimit) {
  Scene scene;
  scene.Perturb(/*fixed=*/1);
  BundleAdjustmentOptions options;
  options.max_solve_seconds = 1e-6;
  const auto result = BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, options);
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_TRUE(result->hit_time_limit);
  EXPECT_LE(result->iterations, 2);
}

TEST(BundleAdjustmentTest, RefusesBadInputNamingIt) {
  Scene scene;
  auto observations = scene.observations;
  observations[3].keyframe_id = 7;
  auto result = BundleAdjust(scene.keyframes, scene.ba_points, observations, {});
  ASSERT_EQ(result.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("unknown keyframe 7"), std::string::npos);

  observations = scene.observations;
  observations[3].inverse_depth = -1;
  EXPECT_EQ(BundleAdjust(scene.keyframes, scene.ba_points, observations, {}).status().code(),
            StatusCode::kInvalidArgument);
  observations[3].inverse_depth = 0;
  observations[3].pixel_sigma = 0;
  EXPECT_EQ(BundleAdjust(scene.keyframes, scene.ba_points, observations, {}).status().code(),
            StatusCode::kInvalidArgument);

  auto keyframes = scene.keyframes;
  keyframes[1].id = keyframes[0].id;
  EXPECT_EQ(BundleAdjust(keyframes, scene.ba_points, scene.observations, {}).status().code(),
            StatusCode::kInvalidArgument);
  keyframes = scene.keyframes;
  keyframes[2].T_world_camera.linear() *= 1.1;
  EXPECT_EQ(BundleAdjust(keyframes, scene.ba_points, scene.observations, {}).status().code(),
            StatusCode::kInvalidArgument);
  auto points = scene.ba_points;
  points[4].position_world.x() = std::nan("");
  EXPECT_EQ(BundleAdjust(scene.keyframes, points, scene.observations, {}).status().code(),
            StatusCode::kInvalidArgument);

  BundleAdjustmentOptions options;
  options.chi2_2dof = 0;
  EXPECT_EQ(
      BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, options).status().code(),
      StatusCode::kInvalidArgument);
  EXPECT_TRUE(BundleAdjust({}, {}, {}, {}).ok());

  PoseGraphEdge loop;
  loop.from = scene.keyframes[0].id;
  loop.to = 42;
  loop.kind = PoseGraphEdgeKind::kLoop;
  result = BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, {}, {loop});
  ASSERT_EQ(result.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("pose constraint 0 names unknown keyframe 42"),
            std::string::npos);
  loop.to = loop.from;
  EXPECT_EQ(BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, {}, {loop})
                .status()
                .code(),
            StatusCode::kInvalidArgument);
  loop.to = scene.keyframes[1].id;
  loop.information(0, 1) = 5;  // not symmetric
  EXPECT_EQ(BundleAdjust(scene.keyframes, scene.ba_points, scene.observations, {}, {loop})
                .status()
                .code(),
            StatusCode::kInvalidArgument);
}

// Two halves of a path that share no map points (the two sides of a loop before fusion): only
// the loop edge ties the second half to the first. With it, a half shifted as a whole (points
// and keyframes together, so every observation still fits) returns to where the loop says;
// without it, nothing in the data moves it.
TEST(BundleAdjustmentTest, LoopConstraintHoldsTwoHalvesThatShareNoPointsTogether) {
  Scene scene;
  const auto second_half = [](int64_t keyframe_id) { return keyframe_id >= 104; };
  std::vector<BundleAdjustmentObservation> observations;
  for (const BundleAdjustmentObservation& o : scene.observations) {
    if (second_half(o.keyframe_id) == (o.point_id >= 150)) observations.push_back(o);
  }
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() << 0.05, -0.03, 0.02;
  shift.linear() =
      Eigen::AngleAxisd(2 * M_PI / 180, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  auto keyframes = scene.keyframes;
  auto points = scene.ba_points;
  keyframes[0].fixed = true;
  for (auto& k : keyframes) {
    if (second_half(k.id)) k.T_world_camera = shift * k.T_world_camera;
  }
  for (auto& p : points) {
    if (p.id >= 150) p.position_world = shift * p.position_world;
  }
  PoseGraphEdge loop;
  loop.from = 103;
  loop.to = 104;
  loop.T_from_to = scene.T_world_camera[3].inverse() * scene.T_world_camera[4];
  loop.information = Eigen::Matrix<double, 6, 6>::Identity() * 1e4;  // 1 cm, 0.01 rad
  loop.kind = PoseGraphEdgeKind::kLoop;

  const auto with_loop = BundleAdjust(keyframes, points, observations, {}, {loop});
  ASSERT_TRUE(with_loop.ok()) << with_loop.status().ToString();
  EXPECT_EQ(with_loop->num_outliers, 0);
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const Eigen::Isometry3d& T = with_loop->T_world_keyframe[k].second;
    EXPECT_LT((T.translation() - scene.T_world_camera[k].translation()).norm(), 1e-3) << k;
    EXPECT_LT(RotationDeg(T, scene.T_world_camera[k]), 0.01) << k;
  }
  for (size_t i = 0; i < scene.points.size(); ++i) {
    EXPECT_LT((with_loop->position_world[i].second - scene.points[i]).norm(), 1e-3) << i;
  }

  const auto without = BundleAdjust(keyframes, points, observations, {});
  ASSERT_TRUE(without.ok()) << without.status().ToString();
  EXPECT_GT(
      (without->T_world_keyframe[6].second.translation() - scene.T_world_camera[6].translation())
          .norm(),
      0.04);
}

}  // namespace
}  // namespace semmap
