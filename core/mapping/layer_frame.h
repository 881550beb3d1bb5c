// The frame a map's 3D layers are built in, and how far they reach.
//
// OctoMap addresses +-2^15 voxels around its origin (+-1638 m at 5 cm) and the cloud stores
// float coordinates (half-metre steps at UTM northings), so layers built in the map frame itself
// fail or lose precision for maps whose keyframes lie far from that frame's origin (KNOWN_POSES
// from GPS / UTM, long odometry). Each map's layers are therefore built in the map frame shifted
// by a per-map origin:
//
//   p_map = p_layer + origin          (T_layer_map = translation(-origin))
//
// The origin is the map's first keyframe position rounded to whole kilometres, so a map whose
// first keyframe lies within 500 m of its frame's origin (every SLAM map: it starts at the first
// camera) has origin 0 and layer frame == map frame. It is persisted with the layers (map blob
// "layers.origin") and reported with every 3D export.
//
// A keyframe farther from the origin than the occupancy tree reaches (its rays must stay inside
// the tree) is left out of both layers, counted and logged; it is still stored, with its pose,
// and still part of the trajectory, the SLAM graph and object recognition.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <string_view>

#include "common/status.h"
#include "core/mapping/occupancy_map.h"

namespace semmap {

inline constexpr char kLayerOriginBlobKind[] = "layers.origin";

// The origin for a map whose first keyframe is at `p_map` (rounded to whole kilometres).
Eigen::Vector3d LayerOriginFor(const Eigen::Vector3d& p_map);

// T_layer_map for an origin.
Eigen::Isometry3d LayerFromMap(const Eigen::Vector3d& origin);

// How far from the layer origin a keyframe may be (per axis) for its rays to stay in the tree.
double LayerReachM(const OccupancyMapOptions& options);
// Whether a keyframe at T_layer_keyframe is within LayerReachM.
bool WithinLayerReach(const Eigen::Isometry3d& T_layer_keyframe,
                      const OccupancyMapOptions& options);

// "semmap-layer-origin-v1 X Y Z\n" with round-trip precision.
std::string EncodeLayerOrigin(const Eigen::Vector3d& origin);
// DATA_LOSS for anything EncodeLayerOrigin did not write (or a non-finite or absurd origin).
StatusOr<Eigen::Vector3d> DecodeLayerOrigin(std::string_view bytes);

}  // namespace semmap
