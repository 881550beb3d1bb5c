#include "core/slam/point_fusion.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>

namespace semmap {
namespace {

const CameraCalibration kFusionCamera{640, 480, 525, 525, 319.5, 239.5, {}};

// A wall of points 2-3 m ahead of the origin, each with its own random ORB-like descriptor.
struct Wall {
  std::vector<Eigen::Vector3d> points_world;
  cv::Mat descriptors;

  explicit Wall(int n) : descriptors(n, 32, CV_8U) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> x(-1.0, 1.0), y(-0.7, 0.7), z(2.0, 3.0);
    for (int i = 0; i < n; ++i) points_world.emplace_back(x(rng), y(rng), z(rng));
    cv::randu(descriptors, cv::Scalar(0), cv::Scalar(256));
  }
};

// What a camera at T_world_camera sees of the wall: one keypoint per point in view (octave 0),
// at its projection, with its depth and descriptor; `wall_index`, when given, gets the wall
// point of each keypoint.
std::shared_ptr<FrameFeatures> Observe(const Wall& wall, const Eigen::Isometry3d& T_world_camera,
                                       std::vector<int64_t>* wall_index = nullptr) {
  auto f = std::make_shared<FrameFeatures>();
  for (size_t i = 0; i < wall.points_world.size(); ++i) {
    const Eigen::Vector3d p = T_world_camera.inverse() * wall.points_world[i];
    const double u = kFusionCamera.fx * p.x() / p.z() + kFusionCamera.cx;
    const double v = kFusionCamera.fy * p.y() / p.z() + kFusionCamera.cy;
    if (u < 0 || v < 0 || u >= kFusionCamera.width || v >= kFusionCamera.height) continue;
    f->keypoints.emplace_back(static_cast<float>(u), static_cast<float>(v), 31.0f);
    f->points_camera.push_back(p);
    f->has_depth.push_back(true);
    f->descriptors.push_back(wall.descriptors.row(static_cast<int>(i)));
    if (wall_index != nullptr) wall_index->push_back(static_cast<int64_t>(i));
  }
  return f;
}

PointFusionOptions FusionOn() {
  PointFusionOptions o;
  o.enabled = true;
  return o;
}

Eigen::Isometry3d SidewaysBy(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  return T;
}

// Two keyframes of one session seeing the same wall from 10 cm apart, each with its own
// tracker ids (the second visit started new points beside the first's).
struct TwoVisits {
  Wall wall{200};
  KeyframeGraph graph;
  MapPoints points;
  std::shared_ptr<FrameFeatures> second_features;

  // `second_ids(k)`: the tracker id keypoint k of the second keyframe names (-1 for none).
  template <typename Ids>
  explicit TwoVisits(Ids second_ids) {
    for (int visit = 0; visit < 2; ++visit) {
      GraphKeyframe kf;
      kf.session_id = 1;
      kf.seq = visit;
      kf.camera = &kFusionCamera;
      kf.T_world_keyframe = SidewaysBy(0.1 * visit);
      std::shared_ptr<FrameFeatures> features = Observe(wall, kf.T_world_keyframe);
      kf.features = features;
      std::vector<int64_t> ids;
      for (size_t k = 0; k < features->size(); ++k) {
        ids.push_back(visit == 0 ? static_cast<int64_t>(k) : second_ids(static_cast<int>(k)));
      }
      const int index = graph.Add(kf);
      points.AddKeyframe(1, index, index, *features, kf.T_world_keyframe, ids);
      if (visit == 1) second_features = features;
    }
  }
};

// Two visits of two keyframes each (2 cm apart within a visit, 10 cm between the visits): the
// points of each visit are established, observed by both of its keyframes.
struct TwoEstablishedVisits {
  Wall wall{200};
  KeyframeGraph graph;
  MapPoints points;

  TwoEstablishedVisits() {
    for (int visit = 0; visit < 2; ++visit) {
      for (int step = 0; step < 2; ++step) {
        GraphKeyframe kf;
        kf.session_id = 1;
        kf.seq = 2 * visit + step;
        kf.camera = &kFusionCamera;
        kf.T_world_keyframe = SidewaysBy(0.1 * visit + 0.02 * step);
        std::vector<int64_t> ids;
        kf.features = Observe(wall, kf.T_world_keyframe, &ids);
        for (int64_t& id : ids) id += 1000 * visit;
        const int index = graph.Add(kf);
        points.AddKeyframe(1, index, index, *kf.features, kf.T_world_keyframe, ids);
      }
    }
  }
};

TEST(PointFusionTest, EstablishedDuplicatesAreMergedOnlyWhenAsked) {
  {
    TwoEstablishedVisits scene;
    ASSERT_EQ(scene.points.Find(scene.points.PointsOf(3).front())->observations.size(), 2u);
    const size_t before = scene.points.size();
    const PointFusionResult r =
        FusePointsIntoKeyframe(3, {0, 1, 2}, scene.graph, scene.points, FusionOn());
    EXPECT_EQ(r.points_fused, 0);  // the default: both sides established, both stay
    EXPECT_EQ(scene.points.size(), before);
  }
  {
    TwoEstablishedVisits scene;
    const size_t before = scene.points.size();
    PointFusionOptions all = FusionOn();
    all.merge_established = true;
    const PointFusionResult r =
        FusePointsIntoKeyframe(3, {0, 1, 2}, scene.graph, scene.points, all);
    EXPECT_GT(r.points_fused, 100);
    EXPECT_EQ(scene.points.size(), before - static_cast<size_t>(r.points_fused));
    const MapPointState* fused = scene.points.Find(scene.points.PointsOf(3).front());
    ASSERT_NE(fused, nullptr);
    EXPECT_EQ(fused->observations.size(), 4u);
  }
}

TEST(PointFusionTest, DuplicatePointsOfARevisitAreFused) {
  TwoVisits scene([](int k) { return 1000 + k; });
  const size_t first = scene.points.PointsOf(0).size();
  const size_t second = scene.points.PointsOf(1).size();
  ASSERT_GT(first, 100u);
  ASSERT_GT(second, 100u);
  EXPECT_TRUE(scene.points.Covisible(1).empty());  // nothing links the two visits yet

  const PointFusionResult result =
      FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, FusionOn());
  EXPECT_EQ(result.observations_added, 0);
  // Every point both keyframes see is one point now, observed by both.
  const std::vector<std::pair<int, int>> covisible = scene.points.Covisible(1);
  ASSERT_EQ(covisible.size(), 1u);
  EXPECT_GE(covisible[0].second, static_cast<int>(std::min(first, second)) - 5);
  EXPECT_EQ(result.points_fused, covisible[0].second);
  EXPECT_EQ(scene.points.size(), first + second - static_cast<size_t>(result.points_fused));
  // The second visit's tracker ids name the fused points.
  const MapPointState* fused = scene.points.Find(scene.points.PointsOf(1).front());
  ASSERT_NE(fused, nullptr);
  EXPECT_EQ(fused->observations.size(), 2u);
}

TEST(PointFusionTest, KeypointsWithoutAPointJoinTheNeighboursPoints) {
  TwoVisits scene([](int) { return int64_t{-1}; });
  ASSERT_TRUE(scene.points.PointsOf(1).empty());
  const PointFusionResult result =
      FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, FusionOn());
  EXPECT_EQ(result.points_fused, 0);
  EXPECT_GT(result.observations_added, 100);
  EXPECT_EQ(scene.points.PointsOf(1).size(), static_cast<size_t>(result.observations_added));
  // Each joined the point of its own 3D position: keypoint k of the second keyframe sees the
  // point whose first observation has the same descriptor.
  for (const auto& [keypoint, id] : scene.points.PointsByKeypoint(1)) {
    const MapPointState* point = scene.points.Find(id);
    ASSERT_NE(point, nullptr);
    const cv::Mat a =
        scene.graph.node(0).features->descriptors.row(point->observations[0].keypoint);
    const cv::Mat b = scene.second_features->descriptors.row(keypoint);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_HAMMING), 0);
  }
}

TEST(PointFusionTest, WrongDescriptorsDepthsOrPosesFuseNothing) {
  {
    TwoVisits scene([](int k) { return 1000 + k; });
    // Every descriptor of the second keyframe changed: nothing looks the same.
    cv::randu(scene.second_features->descriptors, cv::Scalar(0), cv::Scalar(256));
    const PointFusionResult r =
        FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, FusionOn());
    EXPECT_EQ(r.points_fused + r.observations_added, 0);
  }
  {
    TwoVisits scene([](int k) { return 1000 + k; });
    // Depths 30 % further than the points: a different surface behind them.
    for (Eigen::Vector3d& p : scene.second_features->points_camera) p *= 1.3;
    const PointFusionResult r =
        FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, FusionOn());
    EXPECT_EQ(r.points_fused + r.observations_added, 0);
  }
  {
    TwoVisits scene([](int k) { return 1000 + k; });
    // Depths 10 cm further (at 2-3 m): what bundle adjustment's depth term would reject.
    for (Eigen::Vector3d& p : scene.second_features->points_camera) p *= (p.z() + 0.1) / p.z();
    const PointFusionResult r =
        FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, FusionOn());
    EXPECT_EQ(r.points_fused + r.observations_added, 0);
  }
  {
    TwoVisits scene([](int k) { return 1000 + k; });
    // The second keyframe's pose 5 cm off sideways: projections miss by ~10 px.
    scene.graph.SetPose(1, SidewaysBy(0.15));
    const PointFusionResult r =
        FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, FusionOn());
    EXPECT_LT(r.points_fused, 5);
  }
  {
    TwoVisits scene([](int k) { return 1000 + k; });
    const PointFusionOptions off;  // the default
    EXPECT_EQ(FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, off).points_fused, 0);
    // Itself, unknown and culled neighbours are passed over.
    EXPECT_EQ(
        FusePointsIntoKeyframe(1, {1, 7, -2}, scene.graph, scene.points, FusionOn()).points_fused,
        0);
    scene.graph.Cull(0);
    EXPECT_EQ(FusePointsIntoKeyframe(1, {0}, scene.graph, scene.points, FusionOn()).points_fused,
              0);
  }
}

TEST(PointFusionTest, OptionsAreValidated) {
  EXPECT_TRUE(PointFusionOptions{}.Validate().ok());
  PointFusionOptions o;
  o.search_radius_px = 0;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.octave_scale = 0.5;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.max_descriptor_distance = -1;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.inverse_depth_sigma = std::nan("");
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.max_chi2_with_depth = -1;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.max_reprojection_chi2 = 0;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
