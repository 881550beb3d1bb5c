// Trajectory files, both formats, on the same input: TUM (`t tx ty tz qx qy qz qw`) and KITTI
// (12 numbers a line). What parses is rigid and finite, and writing it out with the repo's
// writers parses back to the same poses; PoseLookup over the TUM poses answers every stamp
// with a finite rigid pose or nothing.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "client/datasets/pose_lookup.h"
#include "client/datasets/trajectory_io.h"
#include "tests/fuzz/fuzz_util.h"

namespace semmap {
namespace {

bool Rigid(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  return T.matrix().allFinite() &&
         (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         R.determinant() > 0;
}

// Within what the writers' digits keep: 9 decimals (TUM) or 10 significant digits (KITTI).
bool Close(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const double rotation = (a.linear() - b.linear()).cwiseAbs().maxCoeff();
  const Eigen::Vector3d ta = a.translation(), tb = b.translation();
  for (int i = 0; i < 3; ++i) {
    if (std::abs(ta[i] - tb[i]) > 1e-8 * std::max(1.0, std::abs(ta[i]))) return false;
  }
  return rotation < 1e-7;
}

void CheckTum(const std::vector<StampedPose>& poses) {
  for (const StampedPose& p : poses) FUZZ_CHECK(Rigid(p.T_world_camera));
  StatusOr<std::vector<StampedPose>> again =
      ParseTumTrajectory(FormatTumTrajectory(poses), "again.txt");
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(again->size() == poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    FUZZ_CHECK(std::llabs((*again)[i].stamp_ns - poses[i].stamp_ns) <= 500);  // microseconds
    FUZZ_CHECK(Close((*again)[i].T_world_camera, poses[i].T_world_camera));
  }
}

void CheckKitti(const std::vector<StampedPose>& poses) {
  for (const StampedPose& p : poses) FUZZ_CHECK(Rigid(p.T_world_camera));
  StatusOr<std::vector<StampedPose>> again = ParseKittiPoses(FormatKittiPoses(poses), "again.txt");
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(again->size() == poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    FUZZ_CHECK(Close((*again)[i].T_world_camera, poses[i].T_world_camera));
  }
}

// KITTI poses (positions unbounded) written as TUM: one whole line of 8 fields per pose.
void CheckKittiAsTum(const std::vector<StampedPose>& poses) {
  const std::string text = FormatTumTrajectory(poses);
  FUZZ_CHECK(!text.empty() && text.back() == '\n');
  FUZZ_CHECK(static_cast<size_t>(std::count(text.begin(), text.end(), '\n')) == poses.size() + 1);
  FUZZ_CHECK(static_cast<size_t>(std::count(text.begin(), text.end(), ' ')) ==
             7 * poses.size() + 9);  // the header comment has 9 blanks
}

void CheckLookup(const std::vector<StampedPose>& poses, std::string_view input) {
  const PoseLookup lookup(poses);
  FUZZ_CHECK(lookup.size() == poses.size());
  std::vector<int64_t> queries = {0, std::numeric_limits<int64_t>::min(),
                                  std::numeric_limits<int64_t>::max()};
  for (size_t i = 0; i < poses.size() && i < 64; ++i) {
    queries.push_back(poses[i].stamp_ns);
    queries.push_back(poses[i].stamp_ns + 1);
    queries.push_back(poses[i].stamp_ns - 1);
    if (i > 0) queries.push_back(poses[i - 1].stamp_ns / 2 + poses[i].stamp_ns / 2);
  }
  // The input's last 8 bytes as one more stamp.
  if (input.size() >= 8) {
    int64_t raw = 0;
    std::memcpy(&raw, input.data() + input.size() - 8, sizeof(raw));
    queries.push_back(raw);
  }
  for (const int64_t stamp : queries) {
    const std::optional<Eigen::Isometry3d> T = lookup.At(stamp);
    if (T) FUZZ_CHECK(Rigid(*T));
  }
  // An exact stamp gives a pose listed at that stamp.
  for (size_t i = 0; i < lookup.size() && i < 64; ++i) {
    const StampedPose& p = lookup.poses()[i];
    FUZZ_CHECK(lookup.At(p.stamp_ns).has_value());
  }
}

}  // namespace
}  // namespace semmap

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  const std::string_view input = fuzz::AsText(data, size);
  StatusOr<std::vector<StampedPose>> tum = ParseTumTrajectory(input, "traj.txt");
  if (tum.ok()) {
    CheckTum(*tum);
    CheckLookup(*tum, input);
  } else {
    FUZZ_CHECK(tum.status().code() == StatusCode::kInvalidArgument);
    FUZZ_CHECK(fuzz::NamesSource(tum.status().message(), "traj.txt:"));
  }
  StatusOr<std::vector<StampedPose>> kitti = ParseKittiPoses(input, "poses.txt");
  if (kitti.ok()) {
    CheckKitti(*kitti);
    CheckKittiAsTum(*kitti);
  } else {
    FUZZ_CHECK(kitti.status().code() == StatusCode::kInvalidArgument);
    FUZZ_CHECK(fuzz::NamesSource(kitti.status().message(), "poses.txt:"));
  }
  return 0;
}
