#include "tests/testing/synth/sequence_writer.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <system_error>

#include "common/time_util.h"
#include "tests/testing/synth/dataset_files.h"
#include "tests/testing/synth/object_template.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_frame.h"

namespace semmap::synth {
namespace {

namespace fs = std::filesystem;

Status WritePng(const std::string& path, const cv::Mat& image) {
  try {
    if (cv::imwrite(path, image)) return OkStatus();
  } catch (const cv::Exception& e) {
    return UnavailableError("cannot write " + path + ": " + e.what());
  }
  return UnavailableError("cannot write " + path);
}

Status PrepareDirectory(const std::string& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) return FailedPreconditionError(dir + " is not a directory");
    if (!fs::is_empty(dir, ec)) {
      return FailedPreconditionError(dir + " is not empty (refusing to mix two sequences)");
    }
  }
  for (const char* sub : {"rgb", "depth", "objects"}) {
    fs::create_directories(fs::path(dir) / sub, ec);
    if (ec)
      return UnavailableError("cannot create " + (fs::path(dir) / sub).string() + ": " +
                              ec.message());
  }
  return OkStatus();
}

Status WriteTemplates(const std::string& dir, const Renderer& renderer, const Scene& scene) {
  for (const NamedObject& object : scene.objects) {
    SEMMAP_ASSIGN_OR_RETURN(const cv::Mat image, RenderObjectTemplate(renderer, object));
    SEMMAP_RETURN_IF_ERROR(
        WritePng((fs::path(dir) / "objects" / (object.label + ".png")).string(), image));
  }
  return OkStatus();
}

}  // namespace

CameraCalibration DefaultSyntheticCamera(int width, int height) {
  CameraCalibration camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = 525.0 * width / 640.0;
  camera.cx = 0.5 * width - 0.5;
  camera.cy = 0.5 * height - 0.5;
  return camera;
}

Status WriteTumSequence(const std::string& dir, const Scene& scene,
                        const std::vector<StampedPose>& trajectory,
                        const SequenceOptions& options) {
  if (trajectory.empty()) return InvalidArgumentError("the trajectory has no poses");
  for (size_t i = 1; i < trajectory.size(); ++i) {
    // Files name frames by microsecond stamps: those must differ too.
    if (FormatStampSeconds(trajectory[i].stamp_ns) ==
            FormatStampSeconds(trajectory[i - 1].stamp_ns) ||
        trajectory[i].stamp_ns <= trajectory[i - 1].stamp_ns) {
      return InvalidArgumentError(
          "trajectory stamps must increase strictly, by at least a microsecond (pose " +
          std::to_string(i) + ")");
    }
  }
  SEMMAP_RETURN_IF_ERROR(ValidateNoiseOptions(options.noise));
  SEMMAP_ASSIGN_OR_RETURN(const Renderer renderer, Renderer::Create(scene, options.camera));
  SEMMAP_RETURN_IF_ERROR(PrepareDirectory(dir));
  const fs::path root(dir);

  SEMMAP_RETURN_IF_ERROR(WriteTextFile((root / "camera.yaml").string(),
                                       FormatCameraYaml(options.camera, kDepthScale)));
  SEMMAP_RETURN_IF_ERROR(
      WriteTextFile((root / "objects.txt").string(), FormatObjectsFile(scene.objects)));
  if (options.write_object_templates) SEMMAP_RETURN_IF_ERROR(WriteTemplates(dir, renderer, scene));
  SEMMAP_RETURN_IF_ERROR(WriteTumTrajectory((root / "groundtruth.txt").string(), trajectory));

  std::string rgb_list = "# color images\n# synthetic scene (semmap-synth)\n# timestamp filename\n";
  std::string depth_list = "# depth maps\n# synthetic scene (semmap-synth)\n# timestamp filename\n";
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const RenderedFrame frame =
        RenderSequenceFrame(renderer, trajectory, i, options.noise, options.noise_seed);
    const std::string stamp = FormatStampSeconds(trajectory[i].stamp_ns);
    const std::string rgb = "rgb/" + stamp + ".png", depth = "depth/" + stamp + ".png";
    SEMMAP_RETURN_IF_ERROR(WritePng((root / rgb).string(), frame.bgr));
    SEMMAP_RETURN_IF_ERROR(WritePng((root / depth).string(), frame.depth));
    rgb_list.append(stamp).append(" ").append(rgb).append("\n");
    depth_list.append(stamp).append(" ").append(depth).append("\n");
    if (options.progress) options.progress(i + 1, trajectory.size());
  }
  SEMMAP_RETURN_IF_ERROR(WriteTextFile((root / "depth.txt").string(), depth_list));
  return WriteTextFile((root / "rgb.txt").string(), rgb_list);
}

}  // namespace semmap::synth
