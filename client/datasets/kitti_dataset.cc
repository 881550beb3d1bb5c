#include "client/datasets/kitti_dataset.h"

#include <cstdio>
#include <filesystem>
#include <system_error>
#include <vector>

#include "client/datasets/image_file.h"
#include "client/datasets/text_parse.h"

namespace semmap {
namespace {

namespace fs = std::filesystem;
using datasets_internal::LineError;

std::string ImagePath(const std::string& dir, size_t index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu.png", index);
  return (fs::path(dir) / "image_0" / name).string();
}

StatusOr<std::vector<int64_t>> ReadKittiTimes(const std::string& path) {
  SEMMAP_ASSIGN_OR_RETURN(const std::string content, datasets_internal::ReadWholeFile(path));
  return ParseKittiTimes(content, path);
}

}  // namespace

StatusOr<std::vector<int64_t>> ParseKittiTimes(std::string_view content, const std::string& path) {
  std::vector<int64_t> stamps;
  for (const datasets_internal::TextLine& line : datasets_internal::SplitLines(content)) {
    const std::string_view text =
        datasets_internal::Trim(datasets_internal::StripComment(line.text));
    if (text.empty()) continue;
    int64_t stamp = 0;
    if (!datasets_internal::ParseStamp(text, &stamp)) {
      return LineError(path, line.number, "bad time '" + std::string(text) + "'");
    }
    if (!stamps.empty() && stamp <= stamps.back()) {
      return LineError(path, line.number, "times must increase");
    }
    stamps.push_back(stamp);
  }
  return stamps;
}

StatusOr<CameraCalibration> ReadKittiCalibP0(const std::string& path) {
  SEMMAP_ASSIGN_OR_RETURN(const std::string content, datasets_internal::ReadWholeFile(path));
  return ParseKittiCalibP0(content, path);
}

StatusOr<CameraCalibration> ParseKittiCalibP0(std::string_view content, const std::string& path) {
  for (const datasets_internal::TextLine& line : datasets_internal::SplitLines(content)) {
    if (!line.text.starts_with("P0:")) continue;
    const std::vector<std::string_view> fields =
        datasets_internal::SplitFields(line.text.substr(3));
    double p[12];
    if (fields.size() != 12) {
      return LineError(path, line.number,
                       "P0 needs 12 numbers (3x4 matrix), got " + std::to_string(fields.size()));
    }
    for (size_t i = 0; i < 12; ++i) {
      if (!datasets_internal::ParseDouble(fields[i], &p[i])) {
        return LineError(path, line.number,
                         "P0 value '" + std::string(fields[i]) + "' is not a number");
      }
    }
    CameraCalibration camera;
    camera.fx = p[0];
    camera.cx = p[2];
    camera.fy = p[5];
    camera.cy = p[6];
    return camera;
  }
  return InvalidArgumentError(path + ": has no 'P0:' row");
}

StatusOr<Dataset> OpenKittiDataset(const std::string& dir) {
  Dataset dataset;
  dataset.kind = "kitti";
  dataset.dir = dir;
  dataset.colour_is_grey = true;

  SEMMAP_ASSIGN_OR_RETURN(dataset.camera, ReadKittiCalibP0((fs::path(dir) / "calib.txt").string()));
  SEMMAP_ASSIGN_OR_RETURN(const std::vector<int64_t> stamps,
                          ReadKittiTimes((fs::path(dir) / "times.txt").string()));
  if (stamps.empty()) return InvalidArgumentError(dir + "/times.txt: lists no frames");

  std::error_code ec;
  for (size_t i = 0; i < stamps.size(); ++i) {
    DatasetFrame frame;
    frame.seq = static_cast<int64_t>(i);
    frame.stamp_ns = stamps[i];
    frame.colour_path = ImagePath(dir, i);
    if (!fs::is_regular_file(frame.colour_path, ec)) {
      return NotFoundError(frame.colour_path + " does not exist (times.txt lists " +
                           std::to_string(stamps.size()) + " frames)");
    }
    dataset.frames.push_back(std::move(frame));
  }

  SEMMAP_ASSIGN_OR_RETURN(const auto size, PngFileSize(dataset.frames.front().colour_path));
  dataset.camera.width = size.first;
  dataset.camera.height = size.second;
  if (Status valid = ValidateCalibration(dataset.camera); !valid.ok()) {
    return valid.WithContext(dir + "/calib.txt");
  }

  const std::string poses_path = (fs::path(dir) / "poses.txt").string();
  if (fs::exists(poses_path, ec)) {
    SEMMAP_ASSIGN_OR_RETURN(dataset.ground_truth, ReadKittiPoses(poses_path, stamps));
  }
  return dataset;
}

}  // namespace semmap
