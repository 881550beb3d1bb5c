#include "tests/testing/synth/object_template.h"

#include <cmath>

namespace semmap::synth {

StatusOr<cv::Mat> RenderObjectTemplate(const Renderer& renderer, const NamedObject& object,
                                       const TemplateOptions& options) {
  if (!(options.metres_per_pixel > 0) || !(options.margin >= 0 && options.margin < 1) ||
      !(options.distance > 0.02) || !std::isfinite(options.distance)) {
    return InvalidArgumentError(
        "template options need a positive resolution and distance and a "
        "margin in [0, 1)");
  }
  const Surface& face = object.front;
  CameraCalibration camera;
  camera.width =
      static_cast<int>(std::ceil(face.width * (1 + 2 * options.margin) / options.metres_per_pixel));
  camera.height = static_cast<int>(
      std::ceil(face.height * (1 + 2 * options.margin) / options.metres_per_pixel));
  camera.fx = camera.fy = options.distance / options.metres_per_pixel;
  camera.cx = 0.5 * (camera.width - 1);
  camera.cy = 0.5 * (camera.height - 1);
  SEMMAP_ASSIGN_OR_RETURN(const Renderer view, renderer.WithCamera(camera));
  // Camera axes: x along the face's texture columns, y along its rows, z into the face.
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  T_world_camera.linear().col(0) = face.u_axis;
  T_world_camera.linear().col(1) = face.v_axis;
  T_world_camera.linear().col(2) = -face.Normal();
  T_world_camera.translation() = face.Centre() + options.distance * face.Normal();
  return view.Render(T_world_camera).bgr;
}

}  // namespace semmap::synth
