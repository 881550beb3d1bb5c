#include "tests/testing/synth/scene.h"

#include <cmath>
#include <set>

namespace semmap::synth {
namespace {

bool IsUnit(const Eigen::Vector3d& v) { return std::abs(v.norm() - 1.0) < 1e-6; }

Status ValidateSurface(const Surface& s, const Scene& scene, const std::string& what) {
  if (!s.origin.allFinite() || !s.u_axis.allFinite() || !s.v_axis.allFinite() ||
      !std::isfinite(s.width) || !std::isfinite(s.height)) {
    return InvalidArgumentError(what + " has a non-finite value");
  }
  if (!IsUnit(s.u_axis) || !IsUnit(s.v_axis) || std::abs(s.u_axis.dot(s.v_axis)) > 1e-6) {
    return InvalidArgumentError(what + ": u_axis and v_axis must be perpendicular unit vectors");
  }
  if (s.width <= 0 || s.height <= 0) {
    return InvalidArgumentError(what + " needs a positive width and height");
  }
  if (s.texture < 0 || s.texture >= static_cast<int>(scene.textures.size())) {
    return InvalidArgumentError(what + " refers to texture " + std::to_string(s.texture) + " of " +
                                std::to_string(scene.textures.size()));
  }
  return OkStatus();
}

bool IsLabelChar(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-';
}

}  // namespace

Surface MakeSurface(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                    const Eigen::Vector3d& up, double width, double height, int texture) {
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d up_perp = (up - up.dot(n) * n).normalized();
  Surface s;
  s.u_axis = up_perp.cross(n);  // the viewer's right, looking along -n
  s.v_axis = -up_perp;
  s.width = width;
  s.height = height;
  s.texture = texture;
  s.origin = centre - 0.5 * width * s.u_axis - 0.5 * height * s.v_axis;
  return s;
}

Surface BoxFaceSurface(const Box& box, BoxFace face) {
  const Eigen::Matrix3d R = box.T_world_box.linear();
  const Eigen::Vector3d c = box.T_world_box.translation();
  const Eigen::Vector3d half = 0.5 * box.size;
  const int axis = static_cast<int>(face) / 2;
  const double sign = static_cast<int>(face) % 2 == 0 ? 1.0 : -1.0;
  const Eigen::Vector3d normal = sign * R.col(axis);
  const Eigen::Vector3d up = axis == 2 ? R.col(0) : R.col(2);
  const int up_axis = axis == 2 ? 0 : 2;
  const int side_axis = 3 - axis - up_axis;
  return MakeSurface(c + normal * half[axis], normal, up, box.size[side_axis], box.size[up_axis],
                     box.face_textures[static_cast<size_t>(face)]);
}

Eigen::AlignedBox3d WorldBounds(const Box& box) {
  Eigen::AlignedBox3d bounds;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner((i & 1 ? 0.5 : -0.5) * box.size.x(),
                                 (i & 2 ? 0.5 : -0.5) * box.size.y(),
                                 (i & 4 ? 0.5 : -0.5) * box.size.z());
    bounds.extend(box.T_world_box * corner);
  }
  return bounds;
}

std::vector<Surface> Scene::AllSurfaces() const {
  std::vector<Surface> all = surfaces;
  for (const Box& box : boxes) {
    for (int f = 0; f < 6; ++f) all.push_back(BoxFaceSurface(box, static_cast<BoxFace>(f)));
  }
  return all;
}

Status ValidateScene(const Scene& scene) {
  if (scene.room.isEmpty() || !scene.room.min().allFinite() || !scene.room.max().allFinite() ||
      (scene.room.sizes().array() <= 0).any()) {
    return InvalidArgumentError("scene room must be a non-empty finite box");
  }
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const cv::Mat& t = scene.textures[i];
    if (t.type() != CV_8UC3 || t.cols < 1 || t.rows < 1) {
      return InvalidArgumentError("texture " + std::to_string(i) +
                                  " is not a non-empty BGR8 image");
    }
  }
  for (size_t i = 0; i < scene.surfaces.size(); ++i) {
    SEMMAP_RETURN_IF_ERROR(
        ValidateSurface(scene.surfaces[i], scene, "surface " + std::to_string(i)));
  }
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    const Box& box = scene.boxes[i];
    const std::string what = "box " + std::to_string(i);
    if (!box.T_world_box.matrix().allFinite() || !box.size.allFinite() ||
        (box.size.array() <= 0).any()) {
      return InvalidArgumentError(what + " needs a finite pose and positive size");
    }
    const Eigen::Matrix3d R = box.T_world_box.linear();
    if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || R.determinant() < 0) {
      return InvalidArgumentError(what + " has a rotation that is not a proper rotation");
    }
    for (int f = 0; f < 6; ++f) {
      SEMMAP_RETURN_IF_ERROR(ValidateSurface(BoxFaceSurface(box, static_cast<BoxFace>(f)), scene,
                                             what + " face " + std::to_string(f)));
    }
  }
  std::set<std::string> labels;
  for (const NamedObject& object : scene.objects) {
    if (object.label.empty()) return InvalidArgumentError("an object has an empty label");
    for (char c : object.label) {
      if (!IsLabelChar(c)) {
        return InvalidArgumentError("object label '" + object.label +
                                    "' may only use letters, digits, '_' and '-'");
      }
    }
    if (!labels.insert(object.label).second) {
      return InvalidArgumentError("object label '" + object.label + "' appears twice");
    }
    if (!object.centre.allFinite() || !object.size.allFinite() || (object.size.array() < 0).any()) {
      return InvalidArgumentError("object '" + object.label + "' needs a finite centre and size");
    }
    SEMMAP_RETURN_IF_ERROR(
        ValidateSurface(object.front, scene, "front of object '" + object.label + "'"));
  }
  return OkStatus();
}

}  // namespace semmap::synth
