#include "client/datasets/image_folder_dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <system_error>
#include <vector>

#include "client/datasets/camera_yaml.h"

namespace semmap {
namespace {

constexpr double kDefaultFps = 30.0;

bool IsImage(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

}  // namespace

StatusOr<Dataset> OpenImageFolderDataset(const std::string& dir) {
  namespace fs = std::filesystem;
  SEMMAP_ASSIGN_OR_RETURN(const CameraYaml yaml,
                          ReadCameraYaml((fs::path(dir) / "camera.yaml").string()));
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file(ec) && IsImage(it->path())) names.push_back(it->path().filename());
  }
  if (ec) return NotFoundError(dir + ": cannot list the folder: " + ec.message());
  if (names.empty()) {
    return InvalidArgumentError(dir +
                                ": an image folder needs .png or .jpg frames next to its "
                                "camera.yaml");
  }
  std::sort(names.begin(), names.end());
  Dataset dataset;
  dataset.kind = "images";
  dataset.dir = dir;
  dataset.camera = yaml.camera;
  dataset.depth_scale = 0;
  const double fps = yaml.fps > 0 ? yaml.fps : kDefaultFps;
  for (size_t i = 0; i < names.size(); ++i) {
    DatasetFrame frame;
    frame.seq = static_cast<int64_t>(i);
    frame.stamp_ns = std::llround(static_cast<double>(i) * 1e9 / fps);
    frame.colour_path = (fs::path(dir) / names[i]).string();
    dataset.frames.push_back(std::move(frame));
  }
  return dataset;
}

}  // namespace semmap
