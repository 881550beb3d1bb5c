#include "tests/unit/recognition/recognition_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>

#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/object_template.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap::recognition_test {
namespace {

template <typename T>
T OrAbort(StatusOr<T> s) {
  if (!s.ok()) std::abort();
  return std::move(s).value();
}

std::optional<Eigen::Vector3d> ToCamera(const Eigen::Isometry3d& T_world_camera,
                                        const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d p = T_world_camera.inverse() * p_world;
  if (p.z() <= 1e-6) return std::nullopt;
  return p;
}

Eigen::Vector2d Pixel(const CameraCalibration& c, const Eigen::Vector3d& p) {
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

}  // namespace

const synth::Scene& Room() {
  static const synth::Scene* const scene =
      new synth::Scene(OrAbort(synth::MakeDefaultRoomScene(1)));
  return *scene;
}

const CameraCalibration& RoomCamera() {
  static const CameraCalibration camera = synth::DefaultSyntheticCamera();
  return camera;
}

const synth::Renderer& RoomRenderer() {
  static const synth::Renderer* const renderer =
      new synth::Renderer(OrAbort(synth::Renderer::Create(Room(), RoomCamera())));
  return *renderer;
}

ObjectRecognitionOptions TestOptions() { return ObjectRecognitionOptions(); }

const std::vector<ObjectModel>& RoomModels() {
  static const std::vector<ObjectModel>* const models = [] {
    auto* out = new std::vector<ObjectModel>;
    const std::vector<synth::NamedObject>& objects = Room().objects;
    for (size_t i = 0; i < objects.size(); ++i) {
      const cv::Mat photo = OrAbort(synth::RenderObjectTemplate(RoomRenderer(), objects[i]));
      out->push_back(OrAbort(
          BuildObjectModel(static_cast<int64_t>(i + 1), objects[i].label, {photo}, TestOptions())));
    }
    return out;
  }();
  return *models;
}

FrameFeatures ExtractFeatures(const synth::RenderedFrame& frame) {
  static const FeatureExtractor* const extractor = new FeatureExtractor(
      OrAbort(FeatureExtractor::Create(FeatureExtractorOptions(), RoomCamera())));
  return OrAbort(extractor->Extract(frame.bgr, frame.depth, synth::kDepthScale));
}

Keyframe MakeKeyframe(const Eigen::Isometry3d& T_world_camera) {
  Keyframe k;
  k.T_world_camera = T_world_camera;
  k.frame = RoomRenderer().Render(T_world_camera);
  k.features = ExtractFeatures(k.frame);
  return k;
}

double VisibleFraction(const synth::NamedObject& object, const Eigen::Isometry3d& T_world_camera,
                       const synth::RenderedFrame& frame) {
  const synth::Surface& face = object.front;
  const Eigen::Vector3d to_camera = (T_world_camera.translation() - face.Centre()).normalized();
  if (to_camera.dot(face.Normal()) < std::cos(75.0 * M_PI / 180.0)) return 0.0;
  const CameraCalibration& c = RoomCamera();
  constexpr int kGrid = 9;
  int seen = 0;
  for (int i = 0; i < kGrid; ++i) {
    for (int j = 0; j < kGrid; ++j) {
      // Cell centres, so the grid stays off the face's edges.
      const Eigen::Vector3d p_world =
          face.PointAt((i + 0.5) / kGrid * face.width, (j + 0.5) / kGrid * face.height);
      const std::optional<Eigen::Vector3d> p = ToCamera(T_world_camera, p_world);
      if (!p) continue;
      const Eigen::Vector2d px = Pixel(c, *p);
      const int u = static_cast<int>(std::lround(px.x()));
      const int v = static_cast<int>(std::lround(px.y()));
      if (u < 0 || v < 0 || u >= c.width || v >= c.height) continue;
      const double z = frame.depth.at<uint16_t>(v, u) / synth::kDepthScale;
      if (std::abs(z - p->z()) < 0.01) ++seen;
    }
  }
  return static_cast<double>(seen) / (kGrid * kGrid);
}

double ProjectedFaceMinSidePx(const synth::NamedObject& object,
                              const Eigen::Isometry3d& T_world_camera) {
  const synth::Surface& f = object.front;
  const Eigen::Vector3d corners[4] = {f.PointAt(0, 0), f.PointAt(f.width, 0),
                                      f.PointAt(f.width, f.height), f.PointAt(0, f.height)};
  Eigen::Vector2d q[4];
  for (int i = 0; i < 4; ++i) {
    const std::optional<Eigen::Vector3d> p = ToCamera(T_world_camera, corners[i]);
    if (!p) return 0.0;
    q[i] = Pixel(RoomCamera(), *p);
  }
  const double width = 0.5 * ((q[1] - q[0]).norm() + (q[2] - q[3]).norm());
  const double height = 0.5 * ((q[3] - q[0]).norm() + (q[2] - q[1]).norm());
  return std::min(width, height);
}

Eigen::Isometry3d FacingPose(const synth::NamedObject& object, double distance, double yaw_offset,
                             double height_offset) {
  const Eigen::Vector3d centre = object.front.Centre();
  const Eigen::Vector3d normal =
      Eigen::AngleAxisd(yaw_offset, Eigen::Vector3d::UnitZ()) * object.front.Normal();
  const Eigen::Vector3d position =
      centre + distance * normal + height_offset * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d d = centre - position;
  return synth::LookingPose(position, std::atan2(d.y(), d.x()),
                            std::atan2(d.z(), std::hypot(d.x(), d.y())));
}

}  // namespace semmap::recognition_test
