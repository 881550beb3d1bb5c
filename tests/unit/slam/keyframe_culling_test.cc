#include "core/slam/keyframe_culling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>

namespace semmap {
namespace {

// n keypoints, each with depth 2 m ahead.
std::shared_ptr<const FrameFeatures> CullingFeatures(int n) {
  auto f = std::make_shared<FrameFeatures>();
  for (int k = 0; k < n; ++k) {
    f->keypoints.emplace_back(static_cast<float>(10 * k), 5.0f, 31.0f);
    f->points_camera.emplace_back(0.1 * k, 0, 2.0);
    f->has_depth.push_back(true);
  }
  f->descriptors = cv::Mat::zeros(n, 32, CV_8U);
  return f;
}

// Keyframes 0..n-1 of session 1; keyframe k names tracker points ids[k].
struct CullingScene {
  KeyframeGraph graph;
  MapPoints points;

  explicit CullingScene(const std::vector<std::vector<int64_t>>& ids) {
    for (size_t k = 0; k < ids.size(); ++k) {
      GraphKeyframe kf;
      kf.session_id = 1;
      kf.seq = static_cast<int64_t>(10 * k);
      kf.features = CullingFeatures(static_cast<int>(ids[k].size()));
      const int index = graph.Add(kf);
      points.AddKeyframe(1, index, graph.node(index).index_in_session, *kf.features,
                         Eigen::Isometry3d::Identity(), ids[k]);
    }
  }
};

std::vector<int64_t> PointIds(int first, int count) {
  std::vector<int64_t> ids;
  ids.reserve(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) ids.push_back(first + i);
  return ids;
}

TEST(KeyframeCullingTest, RedundantWhenNinetyPercentOfItsPointsHaveThreeOtherObservers) {
  // Keyframes 0..4 all see points 0..9; keyframe 5 sees 0..8 and its own point 100.
  std::vector<std::vector<int64_t>> ids(5, PointIds(0, 10));
  ids.push_back(PointIds(0, 9));
  ids.back().push_back(100);
  CullingScene scene(ids);
  KeyframeCullingOptions options;
  EXPECT_TRUE(IsRedundantKeyframe(2, scene.points, options));  // 10 of 10
  EXPECT_TRUE(IsRedundantKeyframe(5, scene.points, options));  // 9 of 10: exactly 90 %
  options.redundant_fraction = 0.95;
  EXPECT_FALSE(IsRedundantKeyframe(5, scene.points, options));
  options = {};
  options.min_other_observers = 6;  // 5 others see each point
  EXPECT_FALSE(IsRedundantKeyframe(2, scene.points, options));
  EXPECT_FALSE(IsRedundantKeyframe(42, scene.points, {}));  // no points
}

TEST(KeyframeCullingTest, CullsCovisibleKeyframesOneAtATimeKeepingFirstAndNewest) {
  // Six keyframes over the same ten points.
  CullingScene scene(std::vector<std::vector<int64_t>>(6, PointIds(0, 10)));
  GraphEdge loop;
  loop.from = 0;
  loop.to = 3;
  loop.kind = PoseGraphEdgeKind::kLoop;
  scene.graph.AddEdge(loop);
  const std::vector<int> culled =
      CullRedundantKeyframes(/*newest=*/5, scene.graph, scene.points, {});
  // 0 is the session's first, 5 the newest. Each point starts with six observers; culling 1
  // leaves five (4 others for the rest), 2 four, 3 three: after that a keyframe's points
  // would have 2 others, so 4 stays (and 0 and 5 would anyway).
  EXPECT_EQ(culled, (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(scene.graph.node(1).culled);
  EXPECT_EQ(scene.graph.node(1).features, nullptr);
  EXPECT_TRUE(scene.points.PointsOf(1).empty());
  EXPECT_EQ(scene.points.Find(scene.points.PointsOf(0)[0])->observations.size(), 3u);
  // 3's loop edge stays in the pose graph, 3 a pose node.
  EXPECT_TRUE(scene.graph.node(3).culled);
  EXPECT_TRUE(
      std::any_of(scene.graph.edges().begin(), scene.graph.edges().end(), [](const GraphEdge& e) {
        return e.kind == PoseGraphEdgeKind::kLoop && e.from == 0 && e.to == 3;
      }));
  // Culled keyframes leave loop search and the xi neighbours.
  EXPECT_EQ(scene.graph.SessionNeighbours(4, 1), (std::vector<int>{0, 5}));
  EXPECT_EQ(scene.graph.PreviousKept(4), 0);
  EXPECT_EQ(scene.graph.Near(Eigen::Isometry3d::Identity(), 1, 1, {}).size(), 3u);
  // Disabled: nothing.
  CullingScene again(std::vector<std::vector<int64_t>>(6, PointIds(0, 10)));
  KeyframeCullingOptions off;
  off.enabled = false;
  EXPECT_TRUE(CullRedundantKeyframes(5, again.graph, again.points, off).empty());
}

TEST(KeyframeCullingTest, OptionsAreValidated) {
  KeyframeCullingOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.redundant_fraction = 0;
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
  options.redundant_fraction = 1.5;
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
  options = {};
  options.min_other_observers = 0;
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
