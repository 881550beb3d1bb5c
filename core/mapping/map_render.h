// Map pictures: one semantic map rendered to a PNG a person would rather look at than read
// (`semmap export --format png`). The coloured cloud seen from above (or obliquely), the camera
// trajectories in red, keyframes, loop-closure edges, object boxes with labels, a metre grid,
// a scale bar, a legend and the title. A pure function of its input: no I/O, no server types.
//
// View conventions (all orthographic; MapViewProjection holds the result for one render):
//  * up: options.up, else EstimateUpDirection() of all trajectory poses and keyframes. The
//    SLAM world is in camera convention (x right, y down, z forward of the first keyframe),
//    so with no cameras at all up is -y.
//  * Ground axes: forward = the first camera's optical axis (+z) projected onto the ground
//    plane (the plane normal to up); if that camera looks (nearly) straight up or down, its
//    -y axis, then world +z, then world +x. right = forward x up. For level cameras facing +z
//    in a camera-convention world: up = -y, forward = +z, right = +x. "First camera": the
//    first pose of the first non-empty trajectory, else the first keyframe.
//  * Top-down: looking along -up; image x = right, image up = forward (the first camera's
//    heading points up in the picture). Not mirrored: (right, -forward, -up) is right-handed.
//  * Oblique: looking down at options.oblique_tilt_deg from vertical, towards forward (from
//    behind the first camera): view direction d = -cos(t) up + sin(t) forward; image x = right,
//    image up = cos(t) forward + sin(t) up.
//  * Depth = position . toward_viewer (= -d; the height above the origin in top-down). Nearer
//    points cover farther ones: a z-buffer over square splats, which gives the same picture as
//    the painter's algorithm with points sorted by height, without the sort.
//  * Points higher than clip_above_camera_m above the mean camera height are not drawn, so a
//    ceiling does not hide the room (only when there are cameras).
//  * Pixels: OpenCV's convention, x right, y down, integer coordinates at pixel centres.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/status.h"
#include "core/mapping/cloud_point.h"

namespace semmap {

// One cloud point: world frame, RGB order (the cloud layer's own points).
using RenderPoint = CloudPoint;

// An axis-aligned (world frame) object box.
struct RenderObject {
  std::string label;  // drawn in a box above the outline; empty: no label
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();  // full box size per axis, m, >= 0
  std::array<uint8_t, 3> rgb = {255, 128, 0};
};

struct MapRenderInput {
  std::vector<RenderPoint> cloud;
  std::vector<std::vector<Eigen::Isometry3d>> trajectories;  // per session, T_world_camera
  std::vector<Eigen::Isometry3d> keyframes;                  // T_world_camera
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> loop_edges;  // keyframe positions
  std::vector<RenderObject> objects;
  std::string title;  // e.g. the map name; non-printable bytes are drawn as '?'
};

enum class RenderView { kTopDown, kOblique };

struct MapRenderOptions {
  // The image's long side; the short side follows the map's aspect, between half the long
  // side and the long side (room for the legend on long thin maps).
  int long_side_px = 1600;
  RenderView view = RenderView::kTopDown;
  std::optional<Eigen::Vector3d> up;  // world "up" (any length > 0); default: estimated
  double oblique_tilt_deg = 35;       // kOblique only: angle between the view ray and -up
  // Points above mean camera height + this are not drawn (ceilings); +infinity: keep all.
  double clip_above_camera_m = 0.5;

  // long_side_px in [200, 8000]; up finite and non-zero; tilt in [5, 80] degrees;
  // clip_above_camera_m not NaN.
  Status Validate() const;
};

// Up direction for camera-convention worlds (x right, y down, z forward): the normalised mean
// of the cameras' -y axes (a hand-held or robot camera is held roughly level). Cameras are
// seldom rolled but often all pitched down a little, which tilts that mean; so when the
// cameras' headings spread (x axes spanning the horizontal, ~8 degrees or more of yaw) the
// normal of their x axes is used instead, on the mean's side and when within 40 degrees of
// it. -y of the world when there are no cameras, or their -y axes cancel out.
Eigen::Vector3d EstimateUpDirection(const std::vector<Eigen::Isometry3d>& T_world_camera);

// Where a render puts things: exposed so tests (and callers adding annotations) can find the
// pixel of a world point.
struct MapViewProjection {
  Eigen::Vector3d up = -Eigen::Vector3d::UnitY();  // unit, world frame
  Eigen::Vector3d forward = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d right = Eigen::Vector3d::UnitX();
  Eigen::Vector3d image_up = Eigen::Vector3d::UnitZ();  // world direction drawn upwards
  Eigen::Vector3d toward_viewer = -Eigen::Vector3d::UnitY();
  double pixels_per_metre = 1;
  // View coordinates (p . right, p . image_up) at the map area's top-left pixel corner.
  double left_m = 0;
  double top_m = 0;
  int image_width = 0;
  int image_height = 0;
  // The map area (the rest holds the title band and the grid labels).
  int area_x = 0;
  int area_y = 0;
  int area_width = 0;
  int area_height = 0;
  double clip_height = std::numeric_limits<double>::infinity();  // along up
  double floor_height = 0;  // along up: the ground grid's plane (matters in oblique view)
  double grid_step_m = 1;

  // Pixel coordinates of a world point (may lie outside the image).
  Eigen::Vector2d ToPixel(const Eigen::Vector3d& p_world) const;
  double Depth(const Eigen::Vector3d& p_world) const { return p_world.dot(toward_viewer); }
};

// The view RenderMapPng uses for this input: basis, fit, image layout. The fit covers the
// cloud's 1st-99th percentile box (in view coordinates, after the height clip) together with
// all poses, loop edges and object boxes, plus a margin; at least 2 m each way.
// INVALID_ARGUMENT for bad options, non-finite input or coordinates beyond 1e6 m, rotation
// entries beyond 2 (not a rotation), or a negative object extent.
StatusOr<MapViewProjection> ComputeMapViewProjection(const MapRenderInput& input,
                                                     const MapRenderOptions& options);

// PNG bytes (8-bit BGR). Errors as ComputeMapViewProjection; INTERNAL if encoding fails. An
// empty map (no points, no poses) still renders a labelled empty picture.
StatusOr<std::string> RenderMapPng(const MapRenderInput& input, const MapRenderOptions& options);

}  // namespace semmap
