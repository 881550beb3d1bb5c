// What the back end's Ceres solvers (pose graph, bundle adjustment) share: the input pose check
// and the choice of sparse linear algebra. Private to core/slam (Ceres stays out of its
// public headers).
#pragma once

#include <ceres/types.h>

#include <Eigen/Geometry>

#include "common/status.h"

namespace semmap::slam_internal {

// INVALID_ARGUMENT for a non-finite pose or a rotation that is not orthonormal.
Status ValidateRigidPose(const Eigen::Isometry3d& T);

// The first sparse library this Ceres build has; *available false (and NO_SPARSE) when none.
ceres::SparseLinearAlgebraLibraryType ChooseSparseLibrary(bool* available);

// Rigid pose from a translation and an Eigen-order (x, y, z, w) quaternion (normalised).
Eigen::Isometry3d PoseFromParameters(const double* t, const double* q);

}  // namespace semmap::slam_internal
