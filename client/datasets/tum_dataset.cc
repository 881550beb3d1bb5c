#include "client/datasets/tum_dataset.h"

#include <algorithm>
#include <filesystem>
#include <system_error>
#include <vector>

#include "client/datasets/camera_yaml.h"
#include "client/datasets/stamp_association.h"
#include "client/datasets/text_parse.h"

namespace semmap {
namespace {

namespace fs = std::filesystem;
using datasets_internal::LineError;

struct ListedImage {
  int64_t stamp_ns;
  std::string path;  // resolved against the dataset dir
  int line;
};

// Reads rgb.txt / depth.txt (ParseTumImageList), resolves the paths against the dataset dir
// and checks that the files exist. Sorted by stamp.
StatusOr<std::vector<ListedImage>> ReadImageList(const std::string& dir, const std::string& name) {
  const std::string list_path = (fs::path(dir) / name).string();
  SEMMAP_ASSIGN_OR_RETURN(const std::string content, datasets_internal::ReadWholeFile(list_path));
  SEMMAP_ASSIGN_OR_RETURN(const std::vector<TumListEntry> entries,
                          ParseTumImageList(content, list_path));
  std::vector<ListedImage> images;
  images.reserve(entries.size());
  for (const TumListEntry& entry : entries) {
    ListedImage image{entry.stamp_ns, (fs::path(dir) / entry.path).string(), entry.line};
    std::error_code ec;
    if (!fs::is_regular_file(image.path, ec)) {
      return NotFoundError(list_path + ":" + std::to_string(entry.line) + ": listed image " +
                           image.path + " does not exist");
    }
    images.push_back(std::move(image));
  }
  std::stable_sort(images.begin(), images.end(), [](const ListedImage& a, const ListedImage& b) {
    return a.stamp_ns < b.stamp_ns;
  });
  return images;
}

std::vector<int64_t> Stamps(const std::vector<ListedImage>& images) {
  std::vector<int64_t> stamps;
  stamps.reserve(images.size());
  for (const ListedImage& image : images) stamps.push_back(image.stamp_ns);
  return stamps;
}

}  // namespace

StatusOr<std::vector<TumListEntry>> ParseTumImageList(std::string_view content,
                                                      const std::string& path) {
  std::vector<TumListEntry> entries;
  for (const datasets_internal::TextLine& line : datasets_internal::SplitLines(content)) {
    if (line.text.empty() || line.text.front() == '#') continue;
    const size_t split = line.text.find_first_of(" \t,");
    const std::string_view file = split == std::string_view::npos
                                      ? std::string_view()
                                      : datasets_internal::Trim(line.text.substr(split + 1));
    if (file.empty()) return LineError(path, line.number, "expected 'timestamp path'");
    TumListEntry entry{0, std::string(file), line.number};
    if (!datasets_internal::ParseStamp(line.text.substr(0, split), &entry.stamp_ns)) {
      return LineError(path, line.number,
                       "bad timestamp '" + std::string(line.text.substr(0, split)) + "'");
    }
    entries.push_back(std::move(entry));
  }
  return entries;
}

StatusOr<Dataset> OpenTumDataset(const std::string& dir) {
  Dataset dataset;
  dataset.kind = "tum";
  dataset.dir = dir;

  const std::string yaml_path = (fs::path(dir) / "camera.yaml").string();
  std::error_code ec;
  if (!fs::exists(yaml_path, ec)) {
    return NotFoundError(dir +
                         ": TUM RGB-D dataset has no camera.yaml (needs width, height, fx, fy, "
                         "cx, cy, and depth_scale for depth)");
  }
  SEMMAP_ASSIGN_OR_RETURN(const CameraYaml yaml, ReadCameraYaml(yaml_path));
  dataset.camera = yaml.camera;

  SEMMAP_ASSIGN_OR_RETURN(const std::vector<ListedImage> colour, ReadImageList(dir, "rgb.txt"));
  if (colour.empty()) return InvalidArgumentError(dir + "/rgb.txt: lists no images");
  for (size_t i = 1; i < colour.size(); ++i) {
    // Frames are identified by time downstream; two images at one stamp are ambiguous.
    if (colour[i].stamp_ns == colour[i - 1].stamp_ns) {
      return LineError(dir + "/rgb.txt", colour[i].line,
                       "repeats the timestamp of line " + std::to_string(colour[i - 1].line));
    }
  }

  std::vector<ListedImage> depth;
  if (fs::exists(fs::path(dir) / "depth.txt", ec)) {
    if (yaml.depth_scale <= 0) {
      return InvalidArgumentError(yaml_path +
                                  ": depth_scale must be positive when depth.txt is present");
    }
    SEMMAP_ASSIGN_OR_RETURN(depth, ReadImageList(dir, "depth.txt"));
    dataset.depth_scale = yaml.depth_scale;
  }

  const std::vector<std::optional<size_t>> partner =
      AssociateStamps(Stamps(colour), Stamps(depth), kTumMaxAssociationNs);
  dataset.frames.reserve(colour.size());
  for (size_t i = 0; i < colour.size(); ++i) {
    DatasetFrame frame;
    frame.seq = static_cast<int64_t>(i);
    frame.stamp_ns = colour[i].stamp_ns;
    frame.colour_path = colour[i].path;
    if (partner[i]) frame.depth_path = depth[*partner[i]].path;
    dataset.frames.push_back(std::move(frame));
  }

  const std::string gt_path = (fs::path(dir) / "groundtruth.txt").string();
  if (fs::exists(gt_path, ec)) {
    SEMMAP_ASSIGN_OR_RETURN(dataset.ground_truth, ReadTumTrajectory(gt_path));
    std::stable_sort(
        dataset.ground_truth.begin(), dataset.ground_truth.end(),
        [](const StampedPose& a, const StampedPose& b) { return a.stamp_ns < b.stamp_ns; });
  }
  return dataset;
}

}  // namespace semmap
