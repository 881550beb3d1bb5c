// Scene description of the synthetic RGB-D generator: textured planar surfaces (room walls,
// floor, ceiling, posters), oriented textured boxes (furniture and box-shaped objects) and the
// named objects a recognition test looks for. World frame: metres, z up. Everything is
// visible from one side only (surfaces from the side their normal points to, boxes from
// outside), which is what a closed room and solid boxes need.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "common/status.h"

namespace semmap::synth {

// A textured rectangle. Texel (0, 0)'s outer corner sits at `origin`; texture columns run
// along u_axis and rows along v_axis, so the texture reads upright for a viewer on the front
// side, whose normal is v_axis x u_axis.
struct Surface {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d u_axis = Eigen::Vector3d::UnitX();   // unit
  Eigen::Vector3d v_axis = -Eigen::Vector3d::UnitZ();  // unit, perpendicular to u_axis
  double width = 0;                                    // metres along u_axis
  double height = 0;                                   // metres along v_axis
  int texture = -1;                                    // index into Scene::textures

  Eigen::Vector3d Normal() const { return v_axis.cross(u_axis); }
  // The point at (s, t) metres along (u_axis, v_axis) from the origin.
  Eigen::Vector3d PointAt(double s, double t) const { return origin + s * u_axis + t * v_axis; }
  Eigen::Vector3d Centre() const { return PointAt(0.5 * width, 0.5 * height); }
};

// A surface centred at `centre`, facing `normal`, with the texture's top towards `up`
// (projected to be perpendicular to the normal).
Surface MakeSurface(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                    const Eigen::Vector3d& up, double width, double height, int texture);

enum BoxFace { kBoxPosX = 0, kBoxNegX, kBoxPosY, kBoxNegY, kBoxPosZ, kBoxNegZ };

// A solid box seen from outside. Side faces read upright along the box's +z; the top and
// bottom faces have their texture's top towards the box's +x.
struct Box {
  Eigen::Isometry3d T_world_box = Eigen::Isometry3d::Identity();  // centre and orientation
  Eigen::Vector3d size = Eigen::Vector3d::Zero();                 // extents along box x, y, z
  std::array<int, 6> face_textures{-1, -1, -1, -1, -1, -1};       // indexed by BoxFace
};

Surface BoxFaceSurface(const Box& box, BoxFace face);
Eigen::AlignedBox3d WorldBounds(const Box& box);

// An object a user names: its world axis-aligned bounding box and the face its template
// image shows (a copy of one of the object's surfaces or box faces).
struct NamedObject {
  std::string label;  // [A-Za-z0-9_-]+, unique in the scene
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  // extents along world x, y, z
  Surface front;
};

struct Scene {
  Eigen::AlignedBox3d room;       // the inside of the room: trajectories stay in it
  std::vector<cv::Mat> textures;  // BGR8
  std::vector<Surface> surfaces;  // room planes, posters
  std::vector<Box> boxes;         // furniture and box-shaped objects
  std::vector<NamedObject> objects;

  int AddTexture(cv::Mat bgr) {
    textures.push_back(std::move(bgr));
    return static_cast<int>(textures.size()) - 1;
  }
  // The surfaces and every box face: what the renderer draws.
  std::vector<Surface> AllSurfaces() const;
};

// Checks texture indices and types, unit and perpendicular axes, positive sizes, finite
// values, a non-empty room, and object labels (charset, uniqueness).
Status ValidateScene(const Scene& scene);

}  // namespace semmap::synth
