#include "tests/testing/synth/default_scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "tests/testing/synth/rng.h"
#include "tests/testing/synth/texture.h"

namespace semmap::synth {
namespace {

using Eigen::Vector3d;

constexpr uint64_t kTextureStream = 0x7465787475726573ULL;  // "textures"

// Adds textures to a scene, each from its own derived seed.
class SceneBuilder {
 public:
  SceneBuilder(Scene* scene, uint64_t seed) : scene_(scene), seed_(seed) {}

  StatusOr<int> Texture(double width, double height, double texel, TextureStyle style,
                        std::string_view caption = {}) {
    const int cols = std::max(8, static_cast<int>(std::lround(width / texel)));
    const int rows = std::max(8, static_cast<int>(std::lround(height / texel)));
    SEMMAP_ASSIGN_OR_RETURN(
        cv::Mat image,
        GenerateTexture(cols, rows, style, DeriveSeed(seed_, kTextureStream, next_++), caption));
    return scene_->AddTexture(std::move(image));
  }

  StatusOr<Surface> AddSurface(const Vector3d& centre, const Vector3d& normal, const Vector3d& up,
                               double width, double height, double texel, TextureStyle style,
                               std::string_view caption = {}) {
    SEMMAP_ASSIGN_OR_RETURN(const int texture, Texture(width, height, texel, style, caption));
    scene_->surfaces.push_back(MakeSurface(centre, normal, up, width, height, texture));
    return scene_->surfaces.back();
  }

  // A box with a texture per face; `caption_face` (if >= 0) gets `caption`.
  StatusOr<Box> AddBox(const Eigen::Isometry3d& T_world_box, const Vector3d& size, double texel,
                       TextureStyle style, int caption_face = -1, std::string_view caption = {}) {
    Box box;
    box.T_world_box = T_world_box;
    box.size = size;
    for (int f = 0; f < 6; ++f) {
      const Surface face = BoxFaceSurface(box, static_cast<BoxFace>(f));
      SEMMAP_ASSIGN_OR_RETURN(box.face_textures[static_cast<size_t>(f)],
                              Texture(face.width, face.height, texel, style,
                                      f == caption_face ? caption : std::string_view()));
    }
    scene_->boxes.push_back(box);
    return box;
  }

 private:
  Scene* scene_;
  uint64_t seed_;
  uint64_t next_ = 0;
};

Eigen::Isometry3d At(const Vector3d& centre, double yaw = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = centre;
  return T;
}

NamedObject ObjectFromBounds(const std::string& label, const Eigen::AlignedBox3d& bounds,
                             const Surface& front) {
  NamedObject object;
  object.label = label;
  object.centre = bounds.center();
  object.size = bounds.sizes();
  object.front = front;
  return object;
}

Status AddRoom(SceneBuilder& b, const Eigen::AlignedBox3d& room) {
  const Vector3d& lo = room.min();
  const Vector3d& hi = room.max();
  const Vector3d mid = room.center(), size = room.sizes();
  const Vector3d z = Vector3d::UnitZ(), y = Vector3d::UnitY();
  const TextureStyle wall = TextureStyle::kWall;
  SEMMAP_RETURN_IF_ERROR(b.AddSurface({lo.x(), mid.y(), mid.z()}, Vector3d::UnitX(), z, size.y(),
                                      size.z(), kRoomTexelM, wall)
                             .status());
  SEMMAP_RETURN_IF_ERROR(b.AddSurface({hi.x(), mid.y(), mid.z()}, -Vector3d::UnitX(), z, size.y(),
                                      size.z(), kRoomTexelM, wall)
                             .status());
  SEMMAP_RETURN_IF_ERROR(b.AddSurface({mid.x(), lo.y(), mid.z()}, Vector3d::UnitY(), z, size.x(),
                                      size.z(), kRoomTexelM, wall)
                             .status());
  SEMMAP_RETURN_IF_ERROR(b.AddSurface({mid.x(), hi.y(), mid.z()}, -Vector3d::UnitY(), z, size.x(),
                                      size.z(), kRoomTexelM, wall)
                             .status());
  SEMMAP_RETURN_IF_ERROR(b.AddSurface({mid.x(), mid.y(), lo.z()}, z, y, size.x(), size.y(),
                                      kRoomTexelM, TextureStyle::kFloor)
                             .status());
  SEMMAP_RETURN_IF_ERROR(b.AddSurface({mid.x(), mid.y(), hi.z()}, -z, y, size.x(), size.y(),
                                      kRoomTexelM, TextureStyle::kCeiling)
                             .status());
  return OkStatus();
}

Status AddFurniture(SceneBuilder& b) {
  const TextureStyle style = TextureStyle::kFurniture;
  // Shelf against the -x wall, cabinet against +y, table against +x, sofa against -y.
  SEMMAP_RETURN_IF_ERROR(
      b.AddBox(At({-2.77, 0.8, 0.9}), {0.44, 1.2, 1.8}, kFurnitureTexelM, style).status());
  SEMMAP_RETURN_IF_ERROR(
      b.AddBox(At({0.9, 2.24, 0.45}), {1.3, 0.5, 0.9}, kFurnitureTexelM, style).status());
  SEMMAP_RETURN_IF_ERROR(
      b.AddBox(At({2.58, -0.7, 0.375}), {0.8, 1.5, 0.75}, kFurnitureTexelM, style).status());
  SEMMAP_RETURN_IF_ERROR(b.AddBox(At({-1.1, -2.0, 0.25}, 4.0 * std::numbers::pi / 180.0),
                                  {1.9, 0.8, 0.5}, kFurnitureTexelM, style)
                             .status());
  return OkStatus();
}

Status AddObjects(SceneBuilder& b, Scene& scene) {
  const TextureStyle style = TextureStyle::kObject;
  // A book standing on the cabinet (top at z = 0.9), cover towards the room (-y).
  {
    SEMMAP_ASSIGN_OR_RETURN(const Box book, b.AddBox(At({0.7, 2.12, 1.04}), {0.21, 0.045, 0.28},
                                                     kObjectTexelM, style, kBoxNegY, "BOOK"));
    scene.objects.push_back(
        ObjectFromBounds("book", WorldBounds(book), BoxFaceSurface(book, kBoxNegY)));
  }
  // An open laptop on the table (top at z = 0.75), screen towards the room (-x): the base lies
  // flat, the lid stands on its back edge leaning back by 15 degrees.
  {
    SEMMAP_ASSIGN_OR_RETURN(
        const Box base, b.AddBox(At({2.5, -0.75, 0.76}), {0.24, 0.34, 0.02}, kObjectTexelM, style));
    const double tilt = 15.0 * std::numbers::pi / 180.0;
    Eigen::Isometry3d T_lid = Eigen::Isometry3d::Identity();
    T_lid.linear() = Eigen::AngleAxisd(tilt, Vector3d::UnitY()).toRotationMatrix();
    const Vector3d hinge(2.62, -0.75, 0.77);
    const double thickness = 0.008, height = 0.24;
    T_lid.translation() =
        hinge + 0.5 * height * T_lid.linear().col(2) - 0.5 * thickness * T_lid.linear().col(0);
    SEMMAP_ASSIGN_OR_RETURN(const Box lid, b.AddBox(T_lid, {thickness, 0.34, height}, kObjectTexelM,
                                                    style, kBoxNegX, "LAPTOP"));
    Eigen::AlignedBox3d bounds = WorldBounds(base);
    bounds.extend(WorldBounds(lid));
    scene.objects.push_back(ObjectFromBounds("laptop", bounds, BoxFaceSurface(lid, kBoxNegX)));
  }
  // A poster 3 mm in front of the -y wall, above the sofa.
  {
    const double w = 0.6, h = 0.8;
    const Vector3d centre(-1.1, scene.room.min().y() + 0.003, 1.55);
    SEMMAP_ASSIGN_OR_RETURN(const Surface poster,
                            b.AddSurface(centre, Vector3d::UnitY(), Vector3d::UnitZ(), w, h,
                                         kObjectTexelM, style, "MUG"));
    NamedObject object;
    object.label = "mug_poster";
    object.centre = centre;
    object.size = Vector3d(w, 0.0, h);
    object.front = poster;
    scene.objects.push_back(object);
  }
  // A cube on the floor beside the shelf, facing +x.
  {
    SEMMAP_ASSIGN_OR_RETURN(const Box teddy, b.AddBox(At({-2.74, -0.5, 0.2}), {0.4, 0.4, 0.4},
                                                      kObjectTexelM, style, kBoxPosX, "TEDDY"));
    scene.objects.push_back(
        ObjectFromBounds("teddy_box", WorldBounds(teddy), BoxFaceSurface(teddy, kBoxPosX)));
  }
  return OkStatus();
}

}  // namespace

StatusOr<Scene> MakeDefaultRoomScene(uint64_t seed) {
  Scene scene;
  scene.room = Eigen::AlignedBox3d(Vector3d(-3.0, -2.5, 0.0), Vector3d(3.0, 2.5, 2.8));
  SceneBuilder builder(&scene, seed);
  SEMMAP_RETURN_IF_ERROR(AddRoom(builder, scene.room));
  SEMMAP_RETURN_IF_ERROR(AddFurniture(builder));
  SEMMAP_RETURN_IF_ERROR(AddObjects(builder, scene));
  SEMMAP_RETURN_IF_ERROR(ValidateScene(scene));
  return scene;
}

}  // namespace semmap::synth
