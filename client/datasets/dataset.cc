#include "client/datasets/dataset.h"

#include <filesystem>
#include <system_error>

#include "client/datasets/image_folder_dataset.h"
#include "client/datasets/kitti_dataset.h"
#include "client/datasets/tum_dataset.h"

namespace semmap {

StatusOr<Dataset> OpenDataset(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return NotFoundError(dir + ": no such dataset directory");
  if (fs::exists(fs::path(dir) / "rgb.txt", ec)) return OpenTumDataset(dir);
  if (fs::is_directory(fs::path(dir) / "image_0", ec) &&
      fs::exists(fs::path(dir) / "times.txt", ec)) {
    return OpenKittiDataset(dir);
  }
  if (fs::exists(fs::path(dir) / "camera.yaml", ec)) return OpenImageFolderDataset(dir);
  return InvalidArgumentError(dir +
                              ": not a dataset: expected rgb.txt (TUM RGB-D layout), image_0/ "
                              "and times.txt (KITTI odometry layout), or images next to a "
                              "camera.yaml (an image folder)");
}

}  // namespace semmap
