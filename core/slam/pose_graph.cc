#include "core/slam/pose_graph.h"

#include <ceres/ceres.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <unordered_map>

#include "core/slam/internal/ceres_support.h"
#include "core/slam/internal/relative_pose_error.h"

namespace semmap {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

std::string EdgeName(size_t i, const PoseGraphEdge& e) {
  return "pose graph edge " + std::to_string(i) + " (" + std::to_string(e.from) + " -> " +
         std::to_string(e.to) + ")";
}

}  // namespace

Status PoseGraphOptions::Validate() const {
  if (max_iterations < 0) return InvalidArgumentError("pose graph max_iterations must be >= 0");
  if (!std::isfinite(loop_loss_scale) || loop_loss_scale <= 0) {
    return InvalidArgumentError("pose graph loop_loss_scale must be positive");
  }
  if (num_threads < 1) return InvalidArgumentError("pose graph num_threads must be >= 1");
  if (!std::isfinite(function_tolerance) || function_tolerance < 0) {
    return InvalidArgumentError("pose graph function_tolerance must be >= 0");
  }
  return OkStatus();
}

Eigen::Matrix<double, 6, 1> PoseGraphEdgeResidual(const PoseGraphEdge& edge,
                                                  const Eigen::Isometry3d& T_world_from,
                                                  const Eigen::Isometry3d& T_world_to) {
  const Eigen::Vector3d t_wf = T_world_from.translation(), t_wt = T_world_to.translation();
  const Eigen::Quaterniond q_wf = Eigen::Quaterniond(T_world_from.linear()).normalized();
  const Eigen::Quaterniond q_wt = Eigen::Quaterniond(T_world_to.linear()).normalized();
  Vector6d residual;
  slam_internal::RelativePoseError(edge.T_from_to,
                                   slam_internal::SqrtInformation(edge.information))(
      t_wf.data(), q_wf.coeffs().data(), t_wt.data(), q_wt.coeffs().data(), residual.data());
  return residual;
}

StatusOr<PoseGraphResult> OptimizePoseGraph(const std::vector<PoseGraphNode>& nodes,
                                            const std::vector<PoseGraphEdge>& edges,
                                            const PoseGraphOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());

  // Parameter storage: one (t, q) per node, never resized once blocks point into it.
  struct NodeState {
    double t[3];
    double q[4];  // x, y, z, w
  };
  std::vector<NodeState> state(nodes.size());
  std::unordered_map<int64_t, size_t> index;
  bool any_fixed = false;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const PoseGraphNode& n = nodes[i];
    if (!index.emplace(n.id, i).second) {
      return InvalidArgumentError("pose graph has duplicate node id " + std::to_string(n.id));
    }
    SEMMAP_RETURN_IF_ERROR(slam_internal::ValidateRigidPose(n.T_world_node)
                               .WithContext("pose graph node " + std::to_string(n.id)));
    Eigen::Map<Eigen::Vector3d>(state[i].t) = n.T_world_node.translation();
    Eigen::Map<Eigen::Quaterniond>(state[i].q) =
        Eigen::Quaterniond(n.T_world_node.linear()).normalized();
    any_fixed = any_fixed || n.fixed;
  }
  std::vector<std::pair<size_t, size_t>> edge_nodes(edges.size());
  for (size_t i = 0; i < edges.size(); ++i) {
    const PoseGraphEdge& e = edges[i];
    const auto from = index.find(e.from), to = index.find(e.to);
    if (from == index.end() || to == index.end()) {
      return InvalidArgumentError(EdgeName(i, e) + ": unknown node " +
                                  std::to_string(from == index.end() ? e.from : e.to));
    }
    // Ceres aborts on a residual block naming one parameter block twice.
    if (e.from == e.to) return InvalidArgumentError(EdgeName(i, e) + ": connects a node to itself");
    SEMMAP_RETURN_IF_ERROR(
        slam_internal::ValidateRigidPose(e.T_from_to).WithContext(EdgeName(i, e)));
    SEMMAP_RETURN_IF_ERROR(
        slam_internal::ValidateInformation(e.information).WithContext(EdgeName(i, e)));
    edge_nodes[i] = {from->second, to->second};
  }

  PoseGraphResult result;
  if (nodes.empty()) {
    result.converged = true;
    return result;
  }

  // Huber rather than Cauchy: a correct loop first closed after long drift sits hundreds of
  // sigmas from satisfied. Cauchy's cost saturates there, so ignoring the loop is cheaper than
  // bending the odometry (on a 40-pose ring with 4 m of drift, Cauchy at scale 1 kept 3.4 m of
  // it, Huber closed it to 0.2 m). Huber is convex and keeps a constant pull on every loop; an
  // outlier keeps only that bounded pull, worth a loop_loss_scale-sigma residual. Remove
  // outliers fully by gating loops on PoseGraphEdgeResidual afterwards and solving again.
  // Losses and the manifold live on the stack and outlive the problem, which must not own them.
  ceres::HuberLoss loss(options.loop_loss_scale);
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (size_t i = 0; i < nodes.size(); ++i) {
    problem.AddParameterBlock(state[i].t, 3);
    problem.AddParameterBlock(state[i].q, 4, &quaternion_manifold);
    // Without a fixed node the graph is free to drift as a whole (gauge freedom).
    if (nodes[i].fixed || (!any_fixed && i == 0)) {
      problem.SetParameterBlockConstant(state[i].t);
      problem.SetParameterBlockConstant(state[i].q);
    }
  }
  for (size_t i = 0; i < edges.size(); ++i) {
    const PoseGraphEdge& e = edges[i];
    auto* cost = new ceres::AutoDiffCostFunction<slam_internal::RelativePoseError, 6, 3, 4, 3, 4>(
        new slam_internal::RelativePoseError(e.T_from_to,
                                             slam_internal::SqrtInformation(e.information)));
    const bool robust = e.kind == PoseGraphEdgeKind::kLoop || options.robust_odometry;
    NodeState& a = state[edge_nodes[i].first];
    NodeState& b = state[edge_nodes[i].second];
    problem.AddResidualBlock(cost, robust ? &loss : nullptr, a.t, a.q, b.t, b.q);
  }

  ceres::Solver::Options solver_options;
  solver_options.minimizer_type = ceres::TRUST_REGION;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  bool sparse = false;
  solver_options.sparse_linear_algebra_library_type = slam_internal::ChooseSparseLibrary(&sparse);
  // A Ceres built without any sparse library still solves, iteratively.
  solver_options.linear_solver_type = sparse ? ceres::SPARSE_NORMAL_CHOLESKY : ceres::CGNR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.num_threads;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;

  ceres::Solver::Summary summary;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solve(solver_options, &problem, &summary);
  result.solve_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  result.report = summary.BriefReport();
  if (!summary.IsSolutionUsable()) {
    return FailedPreconditionError("pose graph solve failed: " + summary.message);
  }
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.T_world_node.reserve(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    const Eigen::Isometry3d T = slam_internal::PoseFromParameters(state[i].t, state[i].q);
    if (!T.matrix().allFinite()) {
      return FailedPreconditionError("pose graph solve produced a non-finite pose for node " +
                                     std::to_string(nodes[i].id));
    }
    result.T_world_node.emplace_back(nodes[i].id, T);
  }
  return result;
}

}  // namespace semmap
