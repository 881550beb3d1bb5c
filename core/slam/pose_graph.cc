#include "core/slam/pose_graph.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <memory>
#include <unordered_map>

#include "core/slam/internal/ceres_support.h"

namespace semmap {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Residual of one edge over the parameter blocks (t_world_from, q_world_from, t_world_to,
// q_world_to); quaternions in Eigen's (x, y, z, w) order, kept unit by EigenQuaternionManifold.
class EdgeError {
 public:
  EdgeError(const Eigen::Isometry3d& T_from_to, const Matrix6d& sqrt_information)
      : t_to_from_(T_from_to.inverse().translation()),
        q_to_from_(Eigen::Quaterniond(T_from_to.linear()).normalized().conjugate()),
        sqrt_information_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* t_wf_ptr, const T* q_wf_ptr, const T* t_wt_ptr, const T* q_wt_ptr,
                  T* residual_ptr) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> t_wf(t_wf_ptr), t_wt(t_wt_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_wf(q_wf_ptr), q_wt(q_wt_ptr);
    // Estimated T_from_to, then T_err = measured^-1 * estimated.
    const Eigen::Quaternion<T> q_fw = q_wf.conjugate();
    const Eigen::Quaternion<T> q_ft = q_fw * q_wt;
    const Vec3 t_ft = q_fw * (t_wt - t_wf);
    const Eigen::Quaternion<T> q_tf_measured = q_to_from_.cast<T>();
    Eigen::Quaternion<T> q_err = q_tf_measured * q_ft;
    // q and -q are the same rotation; take the short way so 2 * vec grows with the angle.
    if (q_err.w() < T(0)) q_err.coeffs() = -q_err.coeffs();
    Eigen::Matrix<T, 6, 1> error;
    error.template head<3>() = q_tf_measured * t_ft + t_to_from_.cast<T>();
    error.template tail<3>() = T(2) * q_err.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
    residual = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  Eigen::Vector3d t_to_from_;
  Eigen::Quaterniond q_to_from_;
  Matrix6d sqrt_information_;
};

// L with L^T L = information, by eigen-decomposition so a PSD (rank-deficient) information
// works where LLT would fail; tiny negative round-off eigenvalues are clamped to zero.
Matrix6d SqrtInformation(const Matrix6d& information) {
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (information + information.transpose()));
  const Vector6d d = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return d.asDiagonal() * eigen.eigenvectors().transpose();
}

Status ValidateInformation(const Matrix6d& information) {
  if (!information.allFinite()) return InvalidArgumentError("information is not finite");
  const double scale = information.cwiseAbs().maxCoeff();
  if ((information - information.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return InvalidArgumentError("information is not symmetric");
  }
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(information, Eigen::EigenvaluesOnly);
  if (eigen.eigenvalues().minCoeff() < -1e-9 * scale) {
    return InvalidArgumentError("information is not positive semi-definite");
  }
  return OkStatus();
}

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
  EdgeError(edge.T_from_to, SqrtInformation(edge.information))(
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
    SEMMAP_RETURN_IF_ERROR(ValidateInformation(e.information).WithContext(EdgeName(i, e)));
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
    auto* cost = new ceres::AutoDiffCostFunction<EdgeError, 6, 3, 4, 3, 4>(
        new EdgeError(e.T_from_to, SqrtInformation(e.information)));
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
