// SE(3) pose-graph optimisation (Ceres, Levenberg-Marquardt on a sparse Cholesky): nodes are
// keyframe poses, edges relative-pose measurements from odometry and loop closure.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/status.h"

namespace semmap {

struct PoseGraphNode {
  int64_t id = 0;
  Eigen::Isometry3d T_world_node = Eigen::Isometry3d::Identity();
  bool fixed = false;  // held constant (at least one node must be fixed, else the first node is)
};

enum class PoseGraphEdgeKind { kOdometry, kLoop };

struct PoseGraphEdge {
  int64_t from = 0, to = 0;                                     // node ids, distinct
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();  // measured
  // Information of the error xi in T_from_to * exp(xi), xi = (translation, rotation) in the
  // `to` frame — the same convention as MotionEstimate::information in motion_estimator.h.
  // Symmetric positive semi-definite; a zero block leaves those directions unconstrained.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
  PoseGraphEdgeKind kind = PoseGraphEdgeKind::kOdometry;
};

struct PoseGraphOptions {
  int max_iterations = 100;  // 0 only evaluates the initial cost
  // Huber loss on loop edges; residual norms (whitened, i.e. in sigmas) above this scale pull
  // with a constant force instead of a growing one. See pose_graph.cc for why Huber.
  double loop_loss_scale = 1.0;
  bool robust_odometry = false;  // the same loss on odometry edges too
  int num_threads = 1;
  double function_tolerance = 1e-8;  // Ceres' relative cost-change convergence test
  Status Validate() const;           // INVALID_ARGUMENT naming the field
};

struct PoseGraphResult {
  std::vector<std::pair<int64_t, Eigen::Isometry3d>> T_world_node;  // every node, input order
  double initial_cost = 0, final_cost = 0;  // Ceres cost: sum of 0.5 * rho(|r|^2), robust
  int iterations = 0;                       // LM steps taken, successful or not
  double solve_ms = 0;
  bool converged = false;  // Ceres reported CONVERGENCE (not the iteration limit)
  std::string report;      // Ceres BriefReport
};

// INVALID_ARGUMENT: bad options, duplicate node ids, an edge naming an unknown node or the same
// node twice, non-finite poses or information, rotations that are not orthonormal, information
// not symmetric positive semi-definite; FAILED_PRECONDITION when Ceres fails to produce a usable
// solution. No nodes: OK with an empty result.
StatusOr<PoseGraphResult> OptimizePoseGraph(const std::vector<PoseGraphNode>& nodes,
                                            const std::vector<PoseGraphEdge>& edges,
                                            const PoseGraphOptions& options);

// Whitened residual r of `edge` at the given node poses, the quantity the optimiser minimises
// (cost 0.5 * |r|^2 before any robust loss; |r|^2 is chi-square with rank(information) degrees
// of freedom for a correct edge). r = L * (t_err, 2 * vec(q_err)), L^T L = information, for
// T_err = T_from_to^-1 * T_world_from^-1 * T_world_to. Assumes a valid edge (see above).
Eigen::Matrix<double, 6, 1> PoseGraphEdgeResidual(const PoseGraphEdge& edge,
                                                  const Eigen::Isometry3d& T_world_from,
                                                  const Eigen::Isometry3d& T_world_to);

}  // namespace semmap
