// KeyframeGraph: session order, neighbours, proximity search and per-component gauge fixing.
#include "core/slam/keyframe_graph.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

Eigen::Isometry3d At(double x, double yaw = 0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, 0, 0);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return T;
}

GraphKeyframe Kf(int64_t session, int64_t seq, const Eigen::Isometry3d& T) {
  GraphKeyframe kf;
  kf.session_id = session;
  kf.seq = seq;
  kf.T_world_keyframe = T;
  return kf;
}

GraphEdge Edge(int from, int to, const Eigen::Isometry3d& T, PoseGraphEdgeKind kind) {
  GraphEdge e;
  e.from = from;
  e.to = to;
  e.T_from_to = T;
  e.information = Eigen::Matrix<double, 6, 6>::Identity() * 100;
  e.kind = kind;
  return e;
}

TEST(KeyframeGraphTest, SessionOrderAndNeighbours) {
  KeyframeGraph g;
  EXPECT_EQ(g.Add(Kf(1, 0, At(0))), 0);
  EXPECT_EQ(g.Add(Kf(2, 5, At(9))), 1);
  EXPECT_EQ(g.Add(Kf(1, 10, At(1))), 2);
  EXPECT_EQ(g.Add(Kf(1, 20, At(2))), 3);
  EXPECT_EQ(g.node(3).index_in_session, 2);
  EXPECT_EQ(g.Find(1, 10), 2);
  EXPECT_FALSE(g.Find(1, 11));
  EXPECT_EQ(g.LastOfSession(1), 3);
  EXPECT_EQ(g.LastOfSession(2), 1);
  EXPECT_FALSE(g.LastOfSession(3));
  EXPECT_EQ(g.SessionNeighbours(2, 1), (std::vector<int>{0, 3}));
  EXPECT_EQ(g.SessionNeighbours(0, 2), (std::vector<int>{2, 3}));
  EXPECT_TRUE(g.SessionNeighbours(1, 3).empty());
}

TEST(KeyframeGraphTest, NearFiltersByDistanceAngleAndSkip) {
  KeyframeGraph g;
  g.Add(Kf(1, 0, At(0.0)));
  g.Add(Kf(1, 1, At(0.3)));
  g.Add(Kf(1, 2, At(0.1, 1.5)));  // close but looking 86 degrees away
  g.Add(Kf(1, 3, At(2.0)));       // too far
  g.Add(Kf(1, 4, At(0.2)));
  EXPECT_EQ(g.Near(At(0.05), 0.5, 0.5, nullptr), (std::vector<int>{0, 4, 1}));
  EXPECT_EQ(g.Near(At(0.05), 0.5, 0.5, [](int i) { return i == 4; }), (std::vector<int>{0, 1}));
}

TEST(KeyframeGraphTest, OptimiseFixesTheOldestKeyframeOfEachComponent) {
  KeyframeGraph g;
  // Session 1: a line whose odometry says each step is 1 m, a loop says 3 -> 0 is 2.7 m.
  for (int i = 0; i < 4; ++i) g.Add(Kf(1, i, At(1.0 * i)));
  for (int i = 0; i < 3; ++i) g.AddEdge(Edge(i, i + 1, At(1.0), PoseGraphEdgeKind::kOdometry));
  g.AddEdge(Edge(0, 3, At(2.7), PoseGraphEdgeKind::kLoop));
  // Session 2, never connected: two keyframes far away, consistent with its own odometry.
  g.Add(Kf(2, 0, At(50)));
  g.Add(Kf(2, 1, At(51)));
  g.AddEdge(Edge(4, 5, At(1.0), PoseGraphEdgeKind::kOdometry));
  StatusOr<PoseGraphResult> result = g.Optimise(PoseGraphOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_NEAR(g.node(0).T_world_keyframe.translation().x(), 0.0, 1e-9);  // fixed
  EXPECT_LT(g.node(3).T_world_keyframe.translation().x(), 2.95);         // pulled in by the loop
  EXPECT_GT(g.node(3).T_world_keyframe.translation().x(), 2.7);
  EXPECT_NEAR(g.node(4).T_world_keyframe.translation().x(), 50.0, 1e-9);  // its own gauge
  EXPECT_NEAR(g.node(5).T_world_keyframe.translation().x(), 51.0, 1e-6);
}

}  // namespace
}  // namespace semmap
