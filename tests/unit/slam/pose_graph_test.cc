#include "core/slam/pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace semmap {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// exp(xi) as in motion_estimator.cc: translation as is, rotation by axis-angle.
Eigen::Isometry3d Exp(const Vector6d& xi) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double angle = xi.tail<3>().norm();
  if (angle > 0) T.linear() = Eigen::AngleAxisd(angle, xi.tail<3>() / angle).toRotationMatrix();
  T.translation() = xi.head<3>();
  return T;
}

Matrix6d DiagonalInformation(double sigma_t, double sigma_r) {
  Vector6d d;
  d << Eigen::Vector3d::Constant(1 / (sigma_t * sigma_t)),
      Eigen::Vector3d::Constant(1 / (sigma_r * sigma_r));
  return d.asDiagonal();
}

// A 40-pose circle (radius 10 m, some height and roll). Odometry edges, and loops added later,
// carry zero-mean noise of kSigmaT / kSigmaR (when `noisy`) and the matching information. The
// nodes start where chaining the odometry with an extra bias of 1 cm forward and 0.6 deg of yaw
// per step puts them: metres of drift that the edges themselves do not share.
struct Ring {
  std::vector<Eigen::Isometry3d> truth;
  std::vector<PoseGraphNode> nodes;
  std::vector<PoseGraphEdge> edges;
  bool noisy;
  std::mt19937 rng;
  std::normal_distribution<double> normal{0.0, 1.0};

  static constexpr double kSigmaT = 0.005, kSigmaR = 0.0025;  // metres, radians

  explicit Ring(bool noisy_edges, uint32_t seed = 7) : noisy(noisy_edges), rng(seed) {
    const int n = 40;
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() << 10 * std::cos(a), 10 * std::sin(a), 0.5 * std::sin(3 * a);
      T.linear() = (Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(0.1 * std::sin(2 * a), Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
      truth.push_back(T);
    }
    const Vector6d drift = (Vector6d() << 0.01, 0, 0, 0, 0, 0.01).finished();
    Eigen::Isometry3d T_world_node = truth[0];
    for (int i = 0; i < n; ++i) {
      nodes.push_back({i, T_world_node, i == 0});
      if (i + 1 == n) break;
      const Eigen::Isometry3d measured = truth[i].inverse() * truth[i + 1] * Noise();
      edges.push_back({i, i + 1, measured, DiagonalInformation(kSigmaT, kSigmaR)});
      T_world_node = T_world_node * measured * Exp(drift);
    }
  }

  Eigen::Isometry3d Noise() {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi(k) = noisy ? (k < 3 ? kSigmaT : kSigmaR) * normal(rng) : 0.0;
    return Exp(xi);
  }
  void AddLoop(int from, int to, const Eigen::Isometry3d& T_from_to) {
    edges.push_back(
        {from, to, T_from_to, DiagonalInformation(kSigmaT, kSigmaR), PoseGraphEdgeKind::kLoop});
  }
  void AddCorrectLoop(int from, int to) {
    AddLoop(from, to, truth[from].inverse() * truth[to] * Noise());
  }

  double MaxPositionError(const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& poses) const {
    double worst = 0;
    for (const auto& [id, T] : poses) {
      worst = std::max(worst, (T.translation() - truth[id].translation()).norm());
    }
    return worst;
  }
  double MaxPositionError() const {
    std::vector<std::pair<int64_t, Eigen::Isometry3d>> poses;
    for (const auto& n : nodes) poses.emplace_back(n.id, n.T_world_node);
    return MaxPositionError(poses);
  }
  double MaxRotationError(const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& poses) const {
    double worst = 0;
    for (const auto& [id, T] : poses) {
      worst =
          std::max(worst, Eigen::AngleAxisd(truth[id].linear().transpose() * T.linear()).angle());
    }
    return worst;
  }
};

using Poses = std::vector<std::pair<int64_t, Eigen::Isometry3d>>;

TEST(PoseGraphTest, ExactLoopsRecoverTheRingFromDrift) {
  Ring ring(/*noisy_edges=*/false);
  ring.AddCorrectLoop(39, 0);
  ring.AddCorrectLoop(30, 10);
  ASSERT_GT(ring.MaxPositionError(), 2.0);  // the initial guess is metres off
  auto result = OptimizePoseGraph(ring.nodes, ring.edges, PoseGraphOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_TRUE(result->converged) << result->report;
  ASSERT_EQ(result->T_world_node.size(), 40u);
  EXPECT_LT(ring.MaxPositionError(result->T_world_node), 1e-6);
  EXPECT_LT(ring.MaxRotationError(result->T_world_node), 1e-6);
  EXPECT_LT(result->final_cost, 1e-9 * result->initial_cost);
}

TEST(PoseGraphTest, LoopClosureRemovesDriftFromANoisyRing) {
  Ring ring(/*noisy_edges=*/true);
  ring.AddCorrectLoop(39, 0);
  ring.AddCorrectLoop(30, 10);
  const double before = ring.MaxPositionError();
  auto result = OptimizePoseGraph(ring.nodes, ring.edges, PoseGraphOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_TRUE(result->converged) << result->report;
  const double after = ring.MaxPositionError(result->T_world_node);
  EXPECT_LT(after, 0.3);
  EXPECT_LT(after, before / 5);
  EXPECT_LT(ring.MaxRotationError(result->T_world_node), 0.03);
  // The optimum explains the noisy edges at least as well as the truth does.
  std::vector<PoseGraphNode> at_truth = ring.nodes;
  for (PoseGraphNode& n : at_truth) n.T_world_node = ring.truth[n.id];
  PoseGraphOptions evaluate_only;
  evaluate_only.max_iterations = 0;
  auto truth_cost = OptimizePoseGraph(at_truth, ring.edges, evaluate_only);
  ASSERT_TRUE(truth_cost.ok());
  EXPECT_LE(result->final_cost, truth_cost->initial_cost);
}

TEST(PoseGraphTest, RobustLossDownWeightsAWrongLoop) {
  Ring ring(/*noisy_edges=*/true);
  ring.AddCorrectLoop(39, 0);
  ring.AddCorrectLoop(30, 10);
  ring.AddCorrectLoop(25, 5);
  // Claims nodes 0 and 20, 20 m apart across the circle, are a metre apart.
  Eigen::Isometry3d wrong = Eigen::Isometry3d::Identity();
  wrong.translation() << 1, 0, 0;
  ring.AddLoop(0, 20, wrong);

  auto robust = OptimizePoseGraph(ring.nodes, ring.edges, PoseGraphOptions{});
  ASSERT_TRUE(robust.ok()) << robust.status().ToString();
  EXPECT_LT(ring.MaxPositionError(robust->T_world_node), 0.3);

  PoseGraphOptions quadratic;  // a scale no residual reaches: plain least squares
  quadratic.loop_loss_scale = 1e9;
  auto plain = OptimizePoseGraph(ring.nodes, ring.edges, quadratic);
  ASSERT_TRUE(plain.ok()) << plain.status().ToString();
  EXPECT_GT(ring.MaxPositionError(plain->T_world_node), 2.0);
}

// With exact edges the answer is the truth moved rigidly so the fixed node stays put.
TEST(PoseGraphTest, FixedNodesDoNotMove) {
  Ring ring(/*noisy_edges=*/false);
  ring.AddCorrectLoop(39, 0);
  ring.nodes[0].fixed = false;
  ring.nodes[17].fixed = true;
  auto result = OptimizePoseGraph(ring.nodes, ring.edges, PoseGraphOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  const Eigen::Isometry3d& T_held = ring.nodes[17].T_world_node;
  EXPECT_TRUE(result->T_world_node[17].second.isApprox(T_held, 1e-14));
  const Eigen::Isometry3d correction = T_held * ring.truth[17].inverse();
  for (const auto& [id, T] : result->T_world_node) {
    EXPECT_LT((T.translation() - (correction * ring.truth[id]).translation()).norm(), 1e-6) << id;
  }

  // No node fixed: the first one holds the gauge, here at its true pose.
  ring.nodes[17].fixed = false;
  result = OptimizePoseGraph(ring.nodes, ring.edges, PoseGraphOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_TRUE(result->T_world_node[0].second.isApprox(ring.nodes[0].T_world_node, 1e-14));
  EXPECT_LT(ring.MaxPositionError(result->T_world_node), 1e-6);
}

// Two measurements of one relative pose, rotated 90 deg about z, disagreeing in translation:
// the answer is their information-weighted mean, weights taken along the `to` frame's axes.
TEST(PoseGraphTest, InformationWeightsEdgesInTheToFrame) {
  Eigen::Isometry3d rot = Eigen::Isometry3d::Identity();
  rot.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Isometry3d start = rot;
  start.translation() << 0.3, -0.2, 0.1;
  const std::vector<PoseGraphNode> nodes = {{5, Eigen::Isometry3d::Identity(), true},
                                            {9, start, false}};
  PoseGraphEdge a{5, 9, rot};  // t = 0, very sure along to-x, which is from-y
  a.information(0, 0) = 1e4;
  PoseGraphEdge b{5, 9, rot};  // t = (1, 1, 0)
  b.T_from_to.translation() << 1, 1, 0;
  auto result = OptimizePoseGraph(nodes, {a, b}, PoseGraphOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  const Eigen::Isometry3d& T = result->T_world_node[1].second;
  EXPECT_EQ(result->T_world_node[1].first, 9);
  EXPECT_NEAR(T.translation().x(), 0.5, 1e-6);  // equal weights along to-y
  EXPECT_NEAR(T.translation().y(), 1.0 / (1e4 + 1), 1e-6);
  EXPECT_NEAR(T.translation().z(), 0.0, 1e-6);
  EXPECT_LT(Eigen::AngleAxisd(T.linear().transpose() * rot.linear()).angle(), 1e-6);
}

// Rank-deficient (PSD) information: one edge knows only translation, the other only rotation.
TEST(PoseGraphTest, SemiDefiniteInformationIsUsable) {
  Eigen::Isometry3d target = Exp((Vector6d() << 1, 2, 3, 0.1, -0.2, 0.3).finished());
  PoseGraphEdge translation_only{0, 1, target}, rotation_only{0, 1, target};
  translation_only.information.bottomRightCorner<3, 3>().setZero();
  rotation_only.information.topLeftCorner<3, 3>().setZero();
  auto result = OptimizePoseGraph(
      {{0, Eigen::Isometry3d::Identity(), true}, {1, Eigen::Isometry3d::Identity(), false}},
      {translation_only, rotation_only}, PoseGraphOptions{});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_TRUE(result->T_world_node[1].second.isApprox(target, 1e-6));
}

// Perturbing the measurement by exp(xi) in the `to` frame costs 0.5 * xi^T I xi, the
// convention of MotionEstimate::information (rotation exact to second order in the angle).
TEST(PoseGraphTest, CostMatchesInformationConvention) {
  const Eigen::Isometry3d T_world_from = Exp((Vector6d() << 1, -2, 0.5, 0.3, 0.2, -1).finished());
  const Eigen::Isometry3d T_from_to =
      Exp((Vector6d() << 0.4, 0.1, -0.3, -0.5, 0.8, 0.2).finished());
  Eigen::Matrix<double, 6, 6> A;
  A << 3, 1, 0, 0, 2, 0, 0, 4, 1, 0, 0, 1, 1, 0, 5, 2, 0, 0, 0, 0, 1, 6, 1, 0, 2, 0, 0, 1, 7, 3, 0,
      1, 0, 0, 2, 8;
  PoseGraphEdge edge{0, 1, T_from_to, A * A.transpose()};  // dense, strongly anisotropic
  for (int axis = 0; axis < 6; ++axis) {
    const Vector6d xi = 0.01 * Vector6d::Unit(axis);
    const Eigen::Isometry3d T_world_to = T_world_from * T_from_to * Exp(xi);
    const double expected = 0.5 * xi.dot(edge.information * xi);
    const double tolerance = (axis < 3 ? 1e-10 : 1e-4) * expected;
    EXPECT_NEAR(0.5 * PoseGraphEdgeResidual(edge, T_world_from, T_world_to).squaredNorm(), expected,
                tolerance)
        << "axis " << axis;
    // The same cost through the solver (no steps taken).
    PoseGraphOptions evaluate_only;
    evaluate_only.max_iterations = 0;
    auto result =
        OptimizePoseGraph({{0, T_world_from, true}, {1, T_world_to, false}}, {edge}, evaluate_only);
    ASSERT_TRUE(result.ok()) << result.status().ToString();
    EXPECT_NEAR(result->initial_cost, expected, tolerance) << "axis " << axis;
    EXPECT_TRUE(result->T_world_node[1].second.isApprox(T_world_to, 1e-12));
  }
}

TEST(PoseGraphTest, RejectsInvalidInput) {
  const std::vector<PoseGraphNode> nodes = {{1, Eigen::Isometry3d::Identity(), true},
                                            {2, Eigen::Isometry3d::Identity(), false}};
  const PoseGraphEdge good{1, 2};
  const PoseGraphOptions options;
  ASSERT_TRUE(OptimizePoseGraph(nodes, {good}, options).ok());
  auto code = [&](const std::vector<PoseGraphNode>& n, const PoseGraphEdge& e) {
    return OptimizePoseGraph(n, {e}, options).status().code();
  };
  const StatusCode invalid = StatusCode::kInvalidArgument;

  auto unknown = OptimizePoseGraph(nodes, {PoseGraphEdge{1, 3}}, options);
  EXPECT_EQ(unknown.status().code(), invalid);
  EXPECT_NE(unknown.status().message().find("unknown node 3"), std::string::npos);
  EXPECT_EQ(
      code({{1, Eigen::Isometry3d::Identity(), true}, {1, Eigen::Isometry3d::Identity(), false}},
           good),
      invalid);                                          // duplicate id
  EXPECT_EQ(code(nodes, PoseGraphEdge{2, 2}), invalid);  // self edge

  std::vector<PoseGraphNode> nan_node = nodes;
  nan_node[1].T_world_node.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(code(nan_node, good), invalid);
  std::vector<PoseGraphNode> scaled = nodes;
  scaled[1].T_world_node.linear() *= 1.1;
  EXPECT_EQ(code(scaled, good), invalid);
  PoseGraphEdge e = good;
  e.T_from_to.linear()(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(code(nodes, e), invalid);
  e = good;
  e.information(2, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(code(nodes, e), invalid);
  e = good;
  e.information(0, 1) = 0.5;  // not symmetric
  EXPECT_EQ(code(nodes, e), invalid);
  e = good;
  e.information(4, 4) = -1;  // indefinite
  EXPECT_EQ(code(nodes, e), invalid);

  auto bad_option = [&](auto mutate, const std::string& field) {
    PoseGraphOptions o;
    mutate(o);
    const Status s = o.Validate();
    EXPECT_EQ(s.code(), invalid) << field;
    EXPECT_NE(s.message().find(field), std::string::npos) << s.message();
    EXPECT_EQ(OptimizePoseGraph(nodes, {good}, o).status().code(), invalid) << field;
  };
  bad_option([](PoseGraphOptions& o) { o.max_iterations = -1; }, "max_iterations");
  bad_option([](PoseGraphOptions& o) { o.loop_loss_scale = 0; }, "loop_loss_scale");
  bad_option([](PoseGraphOptions& o) { o.loop_loss_scale = NAN; }, "loop_loss_scale");
  bad_option([](PoseGraphOptions& o) { o.num_threads = 0; }, "num_threads");
  bad_option([](PoseGraphOptions& o) { o.function_tolerance = -1; }, "function_tolerance");
}

TEST(PoseGraphTest, EmptyGraphIsTrivial) {
  auto result = OptimizePoseGraph({}, {}, PoseGraphOptions{});
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result->T_world_node.empty());
}

}  // namespace
}  // namespace semmap
