// KITTI odometry text files: times.txt, poses.txt (with times.txt's stamps when the counts
// match), calib.txt's P0 row, and the PNG header that gives the image size.
// Input: times.txt '\0' poses.txt '\0' calib.txt '\0' PNG bytes.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "client/datasets/image_file.h"
#include "client/datasets/kitti_dataset.h"
#include "client/datasets/trajectory_io.h"
#include "common/time_util.h"
#include "tests/fuzz/fuzz_util.h"

namespace semmap {
namespace {

void CheckTimes(const std::vector<int64_t>& stamps) {
  std::string text;
  for (size_t i = 0; i < stamps.size(); ++i) {
    if (i > 0) FUZZ_CHECK(stamps[i] > stamps[i - 1]);
    text += FormatStampSeconds(stamps[i]) + "\n";
  }
  // Microsecond rounding may merge stamps closer than 1 us; otherwise the same stamps.
  StatusOr<std::vector<int64_t>> again = ParseKittiTimes(text, "times.txt");
  if (!again.ok()) {
    FUZZ_CHECK(again.status().message().find("times must increase") != std::string::npos);
    return;
  }
  FUZZ_CHECK(again->size() == stamps.size());
  for (size_t i = 0; i < stamps.size(); ++i) {
    FUZZ_CHECK(std::llabs((*again)[i] - stamps[i]) <= 500);
  }
}

bool Close(double a, double b) { return std::abs(a - b) <= 1e-8 * std::max(1.0, std::abs(a)); }

void CheckPoses(const std::vector<StampedPose>& poses, const std::vector<int64_t>& stamps) {
  for (const StampedPose& p : poses) {
    const Eigen::Matrix3d R = p.T_world_camera.linear();
    FUZZ_CHECK(p.T_world_camera.matrix().allFinite());
    FUZZ_CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9);
    FUZZ_CHECK(R.determinant() > 0);
  }
  StatusOr<std::vector<StampedPose>> again =
      ParseKittiPoses(FormatKittiPoses(poses), "poses.txt", stamps);
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(again->size() == poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    FUZZ_CHECK((*again)[i].stamp_ns == poses[i].stamp_ns);
    const Eigen::Matrix4d a = poses[i].T_world_camera.matrix();
    const Eigen::Matrix4d b = (*again)[i].T_world_camera.matrix();
    for (int k = 0; k < 16; ++k) FUZZ_CHECK(Close(a(k), b(k)));
  }
}

}  // namespace
}  // namespace semmap

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  const std::vector<std::string_view> parts = fuzz::SplitParts(fuzz::AsText(data, size), 4);

  StatusOr<std::vector<int64_t>> times = ParseKittiTimes(parts[0], "times.txt");
  if (times.ok()) {
    CheckTimes(*times);
  } else {
    FUZZ_CHECK(fuzz::NamesSource(times.status().message(), "times.txt:"));
  }

  StatusOr<std::vector<StampedPose>> poses = ParseKittiPoses(parts[1], "poses.txt");
  if (poses.ok()) {
    for (size_t i = 0; i < poses->size(); ++i) {
      FUZZ_CHECK((*poses)[i].stamp_ns == static_cast<int64_t>(i));
    }
    CheckPoses(*poses, {});
    if (times.ok() && !times->empty()) {
      StatusOr<std::vector<StampedPose>> stamped = ParseKittiPoses(parts[1], "poses.txt", *times);
      FUZZ_CHECK(stamped.ok() == (times->size() == poses->size()));
      if (stamped.ok()) CheckPoses(*stamped, *times);
    }
  } else {
    FUZZ_CHECK(poses.status().code() == StatusCode::kInvalidArgument);
    FUZZ_CHECK(fuzz::NamesSource(poses.status().message(), "poses.txt:"));
  }

  StatusOr<CameraCalibration> calib = ParseKittiCalibP0(parts[2], "calib.txt");
  if (!calib.ok()) FUZZ_CHECK(fuzz::NamesSource(calib.status().message(), "calib.txt"));

  StatusOr<std::pair<int, int>> png = PngSize(parts[3]);
  if (png.ok()) FUZZ_CHECK(png->first > 0 && png->second > 0);
  return 0;
}
