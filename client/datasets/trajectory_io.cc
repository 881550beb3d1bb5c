#include "client/datasets/trajectory_io.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string_view>

#include "client/datasets/text_parse.h"
#include "common/pose.h"
#include "common/time_util.h"
#include "common/tum_format.h"

namespace semmap {
namespace {

using datasets_internal::LineError;
using datasets_internal::ParseDouble;
using datasets_internal::TextLine;

// Non-comment lines of a file split into fields, with their line numbers.
struct FieldLine {
  int number;
  std::vector<std::string_view> fields;
};

std::vector<FieldLine> DataLines(std::string_view content) {
  std::vector<FieldLine> out;
  for (const TextLine& line : datasets_internal::SplitLines(content)) {
    std::vector<std::string_view> fields =
        datasets_internal::SplitFields(datasets_internal::StripComment(line.text));
    if (!fields.empty()) out.push_back({line.number, std::move(fields)});
  }
  return out;
}

bool ParseDoubles(const std::vector<std::string_view>& fields, size_t first, double* values) {
  for (size_t i = first; i < fields.size(); ++i) {
    if (!ParseDouble(fields[i], &values[i - first]) || !std::isfinite(values[i - first])) {
      return false;
    }
  }
  return true;
}

// fclose on scope exit; Close() reports whether buffered data reached the file.
class OutputFile {
 public:
  explicit OutputFile(const std::string& path)
      : path_(path), file_(std::fopen(path.c_str(), "w")) {}
  ~OutputFile() {
    if (file_ != nullptr) std::fclose(file_);
  }
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  std::FILE* get() const { return file_; }
  Status OpenStatus() const {
    return file_ != nullptr ? OkStatus()
                            : UnavailableError(path_ + ": cannot create: " + std::strerror(errno));
  }
  Status Close() {
    const bool write_error = std::ferror(file_) != 0;
    const int rc = std::fclose(file_);
    file_ = nullptr;
    if (write_error || rc != 0) return UnavailableError(path_ + ": write failed");
    return OkStatus();
  }

 private:
  std::string path_;
  std::FILE* file_;
};

Status CheckFinite(const std::vector<StampedPose>& poses, const std::string& path) {
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!poses[i].T_world_camera.matrix().allFinite()) {
      return InvalidArgumentError(path + ": pose " + std::to_string(i) + " has a non-finite value");
    }
  }
  return OkStatus();
}

}  // namespace

StatusOr<std::vector<StampedPose>> ReadTumTrajectory(const std::string& path) {
  SEMMAP_ASSIGN_OR_RETURN(const std::string content, datasets_internal::ReadWholeFile(path));
  return ParseTumTrajectory(content, path);
}

StatusOr<std::vector<StampedPose>> ParseTumTrajectory(std::string_view content,
                                                      const std::string& path) {
  std::vector<StampedPose> poses;
  for (const FieldLine& line : DataLines(content)) {
    if (line.fields.size() != 8) {
      return LineError(path, line.number,
                       "expected 8 fields 'timestamp tx ty tz qx qy qz qw', got " +
                           std::to_string(line.fields.size()));
    }
    StampedPose pose;
    if (!datasets_internal::ParseStamp(line.fields[0], &pose.stamp_ns)) {
      return LineError(path, line.number, "bad timestamp '" + std::string(line.fields[0]) + "'");
    }
    double v[7];
    if (!ParseDoubles(line.fields, 1, v)) {
      return LineError(path, line.number, "pose values must be finite numbers");
    }
    PoseTq tq;
    tq.t = Eigen::Vector3d(v[0], v[1], v[2]);
    tq.q = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);  // file order is qx qy qz qw
    if (Status valid = ValidatePoseTq(tq); !valid.ok()) {
      return LineError(path, line.number, valid.message());
    }
    pose.T_world_camera = ToIsometry(tq);
    poses.push_back(pose);
  }
  return poses;
}

Status WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  SEMMAP_RETURN_IF_ERROR(CheckFinite(poses, path));
  OutputFile out(path);
  SEMMAP_RETURN_IF_ERROR(out.OpenStatus());
  const std::string content = FormatTumTrajectory(poses);
  std::fwrite(content.data(), 1, content.size(), out.get());
  return out.Close();
}

std::string FormatTumTrajectory(const std::vector<StampedPose>& poses) {
  std::string out = "# timestamp tx ty tz qx qy qz qw (T_world_camera)\n";
  for (const StampedPose& pose : poses)
    out += FormatTumPoseLine(pose.stamp_ns, pose.T_world_camera);
  return out;
}

StatusOr<std::vector<StampedPose>> ReadKittiPoses(const std::string& path,
                                                  const std::vector<int64_t>& stamps_ns) {
  SEMMAP_ASSIGN_OR_RETURN(const std::string content, datasets_internal::ReadWholeFile(path));
  return ParseKittiPoses(content, path, stamps_ns);
}

StatusOr<std::vector<StampedPose>> ParseKittiPoses(std::string_view content,
                                                   const std::string& path,
                                                   const std::vector<int64_t>& stamps_ns) {
  std::vector<StampedPose> poses;
  for (const FieldLine& line : DataLines(content)) {
    if (line.fields.size() != 12) {
      return LineError(
          path, line.number,
          "expected 12 numbers (row-major 3x4 matrix), got " + std::to_string(line.fields.size()));
    }
    double v[12];
    if (!ParseDoubles(line.fields, 0, v)) {
      return LineError(path, line.number, "pose values must be finite numbers");
    }
    Eigen::Matrix3d R;
    R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    // KITTI prints 7 significant digits, so rotations are orthonormal to ~1e-6 only.
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-3 ||
        R.determinant() < 0) {
      return LineError(path, line.number, "the 3x3 part is not a rotation");
    }
    StampedPose pose;
    pose.stamp_ns = static_cast<int64_t>(poses.size());
    pose.T_world_camera.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
    pose.T_world_camera.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
    poses.push_back(pose);
  }
  if (!stamps_ns.empty()) {
    if (stamps_ns.size() != poses.size()) {
      return InvalidArgumentError(path + ": has " + std::to_string(poses.size()) + " poses but " +
                                  std::to_string(stamps_ns.size()) + " timestamps were given");
    }
    for (size_t i = 0; i < poses.size(); ++i) poses[i].stamp_ns = stamps_ns[i];
  }
  return poses;
}

Status WriteKittiPoses(const std::string& path, const std::vector<StampedPose>& poses) {
  SEMMAP_RETURN_IF_ERROR(CheckFinite(poses, path));
  OutputFile out(path);
  SEMMAP_RETURN_IF_ERROR(out.OpenStatus());
  const std::string content = FormatKittiPoses(poses);
  std::fwrite(content.data(), 1, content.size(), out.get());
  return out.Close();
}

std::string FormatKittiPoses(const std::vector<StampedPose>& poses) {
  std::string out;
  char number[32];  // "%.9e" of a finite double: at most 16 characters plus the separator
  for (const StampedPose& pose : poses) {
    const Eigen::Matrix<double, 3, 4> M = pose.T_world_camera.matrix().topRows<3>();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        std::snprintf(number, sizeof(number), "%.9e%c", M(r, c), (r == 2 && c == 3) ? '\n' : ' ');
        out += number;
      }
    }
  }
  return out;
}

}  // namespace semmap
