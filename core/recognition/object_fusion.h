// Fuses object observations of one map (moved into the map frame with their keyframes' poses)
// into object instances: the same type within a distance threshold is one physical object,
// farther apart they are separate ones (two mugs on two desks). Re-run from all observations
// whenever poses change (loop closure): the result depends only on the set of observations,
// not on their order, so a rebuild gives the same instances.
//
// Clustering, per (map, type): observations strongest first (most inliers; ties broken by
// every other field, so equal keys are identical observations) each join the cluster whose
// seed (its strongest observation) is nearest within merge_distance_m, or seed a new cluster;
// then every observation moves to the cluster whose median is nearest (within
// merge_distance_m; otherwise it stays), so a weak early seed does not split an object.
// Instance position: per-axis median of the members (an outlier observation moves it by at
// most one rank); extent: per-axis median of the members' extents.
//
// Confidence = 1 - exp(-W / confidence_scale), W = sum over observations of
// min(1, inliers / full_weight_inliers): one strong observation (>= 50 inliers) gives 0.39,
// three 0.78, five 0.92, ten 0.99; a single one at the 12-inlier detection threshold 0.11.
// It grows with the number of observations and their inliers and stays in [0, 1).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/object_types.h"
#include "common/status.h"

namespace semmap {

// An observation in the map frame.
struct WorldObjectObservation {
  int64_t map_id = 0;
  int64_t type_id = 0;
  std::string label;
  int64_t session_id = 0;
  int64_t stamp_ns = 0;
  int matches = 0;
  int inliers = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent_world = Eigen::Vector3d::Zero();  // along the map axes, metres
};

// Moves `o` (keyframe frame) into the map frame with its keyframe's pose. The extent box's
// axes turn with the keyframe; its map-axis extent is the box's bounding box (|R| * extent).
WorldObjectObservation ObservationInWorld(const ObjectObservation& o,
                                          const Eigen::Isometry3d& T_world_keyframe);

struct ObjectFusionOptions {
  double merge_distance_m = 0.5;    // same type within this: one instance
  double full_weight_inliers = 50;  // an observation with this many inliers counts fully
  double confidence_scale = 2.0;    // W at which confidence reaches 1 - 1/e
  int min_observations = 1;         // instances with fewer are dropped

  Status Validate() const;
};

// Confidence of an instance from its observations' inliers (formula above).
double InstanceConfidence(const std::vector<int>& inliers, const ObjectFusionOptions& options);

// Instances (id 0, unsaved; map_name and sessions empty) sorted by map, label, type and
// position. Observations with non-finite positions or extents are skipped. INVALID_ARGUMENT for
// bad options.
StatusOr<std::vector<ObjectInstance>> FuseObservations(
    const std::vector<WorldObjectObservation>& observations, const ObjectFusionOptions& options);

}  // namespace semmap
