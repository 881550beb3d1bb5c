#include "core/slam/bundle_adjustment.h"

#include <ceres/ceres.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <unordered_map>

#include "core/slam/internal/ceres_support.h"
#include "core/slam/internal/observation_cost.h"
#include "core/slam/internal/relative_pose_error.h"

namespace semmap {
namespace {

struct PoseState {
  double t[3];
  double q[4];  // x, y, z, w
};

bool UsesDepth(const BundleAdjustmentObservation& o, const BundleAdjustmentOptions& options) {
  return options.use_depth && o.inverse_depth > 0;
}

Status ValidateObservation(const BundleAdjustmentObservation& o) {
  if (!o.pixel.allFinite()) return InvalidArgumentError("pixel is not finite");
  if (!std::isfinite(o.pixel_sigma) || o.pixel_sigma <= 0) {
    return InvalidArgumentError("pixel_sigma must be positive");
  }
  if (!std::isfinite(o.inverse_depth) || o.inverse_depth < 0) {
    return InvalidArgumentError("inverse_depth must be >= 0 (0: no depth)");
  }
  return OkStatus();
}

std::string Named(const char* what, int64_t id) {
  return std::string(what) + " " + std::to_string(id);
}

}  // namespace

Status BundleAdjustmentOptions::Validate() const {
  if (!std::isfinite(inverse_depth_sigma) || inverse_depth_sigma <= 0) {
    return InvalidArgumentError("bundle adjustment inverse_depth_sigma must be positive");
  }
  if (robust_iterations < 0 || refine_iterations < 0) {
    return InvalidArgumentError("bundle adjustment iterations must be >= 0");
  }
  if (!std::isfinite(chi2_2dof) || chi2_2dof <= 0 || !std::isfinite(chi2_3dof) || chi2_3dof <= 0) {
    return InvalidArgumentError("bundle adjustment chi-square gates must be positive");
  }
  if (!std::isfinite(min_depth_m) || min_depth_m <= 0) {
    return InvalidArgumentError("bundle adjustment min_depth_m must be positive");
  }
  if (!std::isfinite(max_solve_seconds) || max_solve_seconds < 0) {
    return InvalidArgumentError("bundle adjustment max_solve_seconds must be >= 0");
  }
  if (num_threads < 1) return InvalidArgumentError("bundle adjustment num_threads must be >= 1");
  if (dense_schur_max_keyframes < 0) {
    return InvalidArgumentError("bundle adjustment dense_schur_max_keyframes must be >= 0");
  }
  if (!std::isfinite(pose_constraint_loss_scale) || pose_constraint_loss_scale <= 0) {
    return InvalidArgumentError("bundle adjustment pose_constraint_loss_scale must be positive");
  }
  return OkStatus();
}

ObservationError EvaluateObservation(const BundleAdjustmentObservation& observation,
                                     const Eigen::Isometry3d& T_world_camera,
                                     const CameraCalibration& camera,
                                     const Eigen::Vector3d& position_world,
                                     const BundleAdjustmentOptions& options) {
  ObservationError error;
  const Eigen::Vector3d p = T_world_camera.inverse() * position_world;
  error.in_front = p.z() >= options.min_depth_m;
  error.with_depth = UsesDepth(observation, options);
  if (p.z() <= 1e-6) {
    error.chi2 = std::numeric_limits<double>::infinity();
    return error;
  }
  const double du =
      (camera.fx * p.x() / p.z() + camera.cx - observation.pixel.x()) / observation.pixel_sigma;
  const double dv =
      (camera.fy * p.y() / p.z() + camera.cy - observation.pixel.y()) / observation.pixel_sigma;
  error.chi2 = du * du + dv * dv;
  if (error.with_depth) {
    const double dz = (1 / p.z() - observation.inverse_depth) / options.inverse_depth_sigma;
    error.chi2 += dz * dz;
  }
  return error;
}

StatusOr<BundleAdjustmentResult> BundleAdjust(
    const std::vector<BundleAdjustmentKeyframe>& keyframes,
    const std::vector<BundleAdjustmentPoint>& points,
    const std::vector<BundleAdjustmentObservation>& observations,
    const BundleAdjustmentOptions& options, const std::vector<PoseGraphEdge>& pose_constraints) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());

  // Parameter storage, never resized once blocks point into it.
  std::vector<PoseState> poses(keyframes.size());
  std::vector<Eigen::Vector3d> positions(points.size());
  std::unordered_map<int64_t, size_t> keyframe_index, point_index;
  bool any_fixed = false;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    const BundleAdjustmentKeyframe& k = keyframes[i];
    if (!keyframe_index.emplace(k.id, i).second) {
      return InvalidArgumentError("bundle adjustment has duplicate keyframe id " +
                                  std::to_string(k.id));
    }
    SEMMAP_RETURN_IF_ERROR(slam_internal::ValidateRigidPose(k.T_world_camera)
                               .WithContext("bundle adjustment " + Named("keyframe", k.id)));
    SEMMAP_RETURN_IF_ERROR(
        ValidateCalibration(k.camera).WithContext("bundle adjustment " + Named("keyframe", k.id)));
    Eigen::Map<Eigen::Vector3d>(poses[i].t) = k.T_world_camera.translation();
    Eigen::Map<Eigen::Quaterniond>(poses[i].q) =
        Eigen::Quaterniond(k.T_world_camera.linear()).normalized();
    any_fixed = any_fixed || k.fixed;
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (!point_index.emplace(points[i].id, i).second) {
      return InvalidArgumentError("bundle adjustment has duplicate point id " +
                                  std::to_string(points[i].id));
    }
    if (!points[i].position_world.allFinite()) {
      return InvalidArgumentError("bundle adjustment " + Named("point", points[i].id) +
                                  " is not finite");
    }
    positions[i] = points[i].position_world;
  }
  std::vector<std::pair<size_t, size_t>> observed(observations.size());  // (keyframe, point)
  for (size_t i = 0; i < observations.size(); ++i) {
    const BundleAdjustmentObservation& o = observations[i];
    const auto k = keyframe_index.find(o.keyframe_id);
    const auto p = point_index.find(o.point_id);
    const std::string name = "bundle adjustment observation " + std::to_string(i);
    if (k == keyframe_index.end()) {
      return InvalidArgumentError(name + " names unknown " + Named("keyframe", o.keyframe_id));
    }
    if (p == point_index.end()) {
      return InvalidArgumentError(name + " names unknown " + Named("point", o.point_id));
    }
    SEMMAP_RETURN_IF_ERROR(ValidateObservation(o).WithContext(name));
    observed[i] = {k->second, p->second};
  }
  std::vector<std::pair<size_t, size_t>> constrained(pose_constraints.size());  // (from, to)
  std::vector<slam_internal::Matrix6d> constraint_sqrt_information(pose_constraints.size());
  for (size_t i = 0; i < pose_constraints.size(); ++i) {
    const PoseGraphEdge& e = pose_constraints[i];
    const std::string name = "bundle adjustment pose constraint " + std::to_string(i);
    const auto from = keyframe_index.find(e.from), to = keyframe_index.find(e.to);
    if (from == keyframe_index.end() || to == keyframe_index.end()) {
      return InvalidArgumentError(name + " names unknown " +
                                  Named("keyframe", from == keyframe_index.end() ? e.from : e.to));
    }
    if (e.from == e.to) return InvalidArgumentError(name + " connects a keyframe to itself");
    SEMMAP_RETURN_IF_ERROR(slam_internal::ValidateRigidPose(e.T_from_to).WithContext(name));
    SEMMAP_RETURN_IF_ERROR(slam_internal::ValidateInformation(e.information).WithContext(name));
    constrained[i] = {from->second, to->second};
    constraint_sqrt_information[i] = slam_internal::SqrtInformation(e.information);
  }
  const auto keyframe_fixed = [&](size_t k) {
    return keyframes[k].fixed || (!any_fixed && k == 0);
  };

  BundleAdjustmentResult result;
  result.outlier.assign(observations.size(), false);
  // Outlier classification at the current state: above the gate or not in front.
  const auto classify = [&] {
    result.num_outliers = 0;
    for (size_t i = 0; i < observations.size(); ++i) {
      const auto [k, p] = observed[i];
      const ObservationError e = EvaluateObservation(
          observations[i], slam_internal::PoseFromParameters(poses[k].t, poses[k].q),
          keyframes[k].camera, positions[p], options);
      const double gate = e.with_depth ? options.chi2_3dof : options.chi2_2dof;
      result.outlier[i] = !e.in_front || !(e.chi2 <= gate);
      result.num_outliers += result.outlier[i] ? 1 : 0;
    }
  };
  // Only points in front of every camera that observes them start in the solve (a residual
  // that cannot be evaluated at the start makes Ceres fail).
  for (size_t i = 0; i < observations.size(); ++i) {
    const auto [k, p] = observed[i];
    const ObservationError e = EvaluateObservation(observations[i], keyframes[k].T_world_camera,
                                                   keyframes[k].camera, positions[p], options);
    result.outlier[i] = !e.in_front;
    result.num_outliers += result.outlier[i] ? 1 : 0;
  }

  bool sparse = false;
  const ceres::SparseLinearAlgebraLibraryType sparse_library =
      slam_internal::ChooseSparseLibrary(&sparse);
  // One solve over the current inliers; `robust`: with the Huber loss at the gates.
  const auto solve = [&](int iterations, bool robust, ceres::Solver::Summary* summary) {
    // A free point enters only when its inlier observations determine it.
    std::vector<int> depth_observations(points.size(), 0), all_observations(points.size(), 0);
    for (size_t i = 0; i < observations.size(); ++i) {
      if (result.outlier[i]) continue;
      ++all_observations[observed[i].second];
      depth_observations[observed[i].second] += UsesDepth(observations[i], options) ? 1 : 0;
    }
    const auto determined = [&](size_t p) {
      return points[p].fixed || depth_observations[p] >= 1 || all_observations[p] >= 2;
    };
    ceres::HuberLoss loss_2dof(std::sqrt(options.chi2_2dof));
    ceres::HuberLoss loss_3dof(std::sqrt(options.chi2_3dof));
    ceres::HuberLoss constraint_loss(options.pose_constraint_loss_scale);
    ceres::EigenQuaternionManifold quaternion_manifold;
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    std::vector<bool> pose_added(keyframes.size(), false), point_added(points.size(), false);
    const auto add_pose = [&](size_t k) {
      if (pose_added[k]) return;
      pose_added[k] = true;
      problem.AddParameterBlock(poses[k].t, 3);
      problem.AddParameterBlock(poses[k].q, 4, &quaternion_manifold);
      if (keyframe_fixed(k)) {
        problem.SetParameterBlockConstant(poses[k].t);
        problem.SetParameterBlockConstant(poses[k].q);
      }
      ordering->AddElementToGroup(poses[k].t, 1);
      ordering->AddElementToGroup(poses[k].q, 1);
    };
    result.num_points_optimised = 0;
    for (size_t i = 0; i < observations.size(); ++i) {
      const auto [k, p] = observed[i];
      if (result.outlier[i] || !determined(p)) continue;
      const BundleAdjustmentObservation& o = observations[i];
      ceres::CostFunction* cost = nullptr;
      ceres::LossFunction* loss = nullptr;
      const CameraCalibration& c = keyframes[k].camera;
      slam_internal::ObservationModel model;
      model.fx = c.fx;
      model.fy = c.fy;
      model.cx = c.cx;
      model.cy = c.cy;
      model.u = o.pixel.x();
      model.v = o.pixel.y();
      model.inverse_pixel_sigma = 1 / o.pixel_sigma;
      model.inverse_depth = o.inverse_depth;
      model.inverse_inverse_depth_sigma = 1 / options.inverse_depth_sigma;
      if (UsesDepth(o, options)) {
        cost = new slam_internal::ObservationCost<3>(model);
        loss = robust ? &loss_3dof : nullptr;
      } else {
        cost = new slam_internal::ObservationCost<2>(model);
        loss = robust ? &loss_2dof : nullptr;
      }
      add_pose(k);
      problem.AddResidualBlock(cost, loss, poses[k].t, poses[k].q, positions[p].data());
      if (!point_added[p]) {
        point_added[p] = true;
        if (points[p].fixed) {
          problem.SetParameterBlockConstant(positions[p].data());
        } else {
          ++result.num_points_optimised;
        }
        ordering->AddElementToGroup(positions[p].data(), 0);
      }
    }
    for (size_t i = 0; i < pose_constraints.size(); ++i) {
      const auto [from, to] = constrained[i];
      if (keyframe_fixed(from) && keyframe_fixed(to)) continue;  // nothing to pull on
      add_pose(from);
      add_pose(to);
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<slam_internal::RelativePoseError, 6, 3, 4, 3, 4>(
              new slam_internal::RelativePoseError(pose_constraints[i].T_from_to,
                                                   constraint_sqrt_information[i])),
          &constraint_loss, poses[from].t, poses[from].q, poses[to].t, poses[to].q);
    }
    if (problem.NumResidualBlocks() == 0 || iterations == 0) return true;
    ceres::Solver::Options solver_options;
    solver_options.minimizer_type = ceres::TRUST_REGION;
    solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    solver_options.sparse_linear_algebra_library_type = sparse_library;
    const bool small = static_cast<int>(keyframes.size()) <= options.dense_schur_max_keyframes;
    solver_options.linear_solver_type = sparse && !small ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR;
    solver_options.linear_solver_ordering = ordering;
    solver_options.max_num_iterations = iterations;
    if (options.max_solve_seconds > 0) {
      solver_options.max_solver_time_in_seconds = options.max_solve_seconds;
    }
    solver_options.num_threads = options.num_threads;
    solver_options.logging_type = ceres::SILENT;
    solver_options.minimizer_progress_to_stdout = false;
    ceres::Solve(solver_options, &problem, summary);
    result.iterations += summary->num_successful_steps + summary->num_unsuccessful_steps;
    result.solve_ms += summary->total_time_in_seconds * 1000;
    if (options.max_solve_seconds > 0 &&
        summary->total_time_in_seconds >= 0.95 * options.max_solve_seconds &&
        summary->termination_type == ceres::NO_CONVERGENCE) {
      result.hit_time_limit = true;
    }
    result.report = summary->BriefReport();
    return summary->IsSolutionUsable();
  };

  ceres::Solver::Summary robust_summary, refine_summary;
  if (!solve(options.robust_iterations, /*robust=*/true, &robust_summary)) {
    return FailedPreconditionError("bundle adjustment (robust) failed: " + robust_summary.message);
  }
  result.initial_cost = robust_summary.initial_cost;
  classify();
  if (options.refine_iterations > 0) {
    if (!solve(options.refine_iterations, /*robust=*/false, &refine_summary)) {
      return FailedPreconditionError("bundle adjustment failed: " + refine_summary.message);
    }
    classify();
  }
  result.final_cost =
      options.refine_iterations > 0 ? refine_summary.final_cost : robust_summary.final_cost;

  result.T_world_keyframe.reserve(keyframes.size());
  for (size_t i = 0; i < keyframes.size(); ++i) {
    const Eigen::Isometry3d T = slam_internal::PoseFromParameters(poses[i].t, poses[i].q);
    if (!T.matrix().allFinite()) {
      return FailedPreconditionError("bundle adjustment produced a non-finite pose for " +
                                     Named("keyframe", keyframes[i].id));
    }
    result.T_world_keyframe.emplace_back(keyframes[i].id, T);
  }
  result.position_world.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    if (!positions[i].allFinite()) {
      return FailedPreconditionError("bundle adjustment produced a non-finite position for " +
                                     Named("point", points[i].id));
    }
    result.position_world.emplace_back(points[i].id, positions[i]);
  }
  return result;
}

}  // namespace semmap
