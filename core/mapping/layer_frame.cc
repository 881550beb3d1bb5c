#include "core/mapping/layer_frame.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "common/pose.h"

namespace semmap {
namespace {

constexpr double kOriginStepM = 1000.0;
constexpr char kOriginMagic[] = "semmap-layer-origin-v1";

}  // namespace

Eigen::Vector3d LayerOriginFor(const Eigen::Vector3d& p_map) {
  if (!p_map.allFinite()) return Eigen::Vector3d::Zero();
  return (p_map / kOriginStepM).array().round().matrix() * kOriginStepM;
}

Eigen::Isometry3d LayerFromMap(const Eigen::Vector3d& origin) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = -origin;
  return T;
}

double LayerReachM(const OccupancyMapOptions& options) {
  // OctoMap keys cover +-2^15 voxels; a ray from the keyframe reaches max_range further.
  return options.resolution_m * 32768.0 * 0.99 - options.max_range_m;
}

bool WithinLayerReach(const Eigen::Isometry3d& T_layer_keyframe,
                      const OccupancyMapOptions& options) {
  const Eigen::Vector3d t = T_layer_keyframe.translation();
  return t.allFinite() && t.cwiseAbs().maxCoeff() <= LayerReachM(options);
}

std::string EncodeLayerOrigin(const Eigen::Vector3d& origin) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "%s %.17g %.17g %.17g\n", kOriginMagic, origin.x(), origin.y(),
                origin.z());
  return buf;
}

StatusOr<Eigen::Vector3d> DecodeLayerOrigin(std::string_view bytes) {
  // Short and ours: copy to a terminated string for sscanf.
  if (bytes.size() > 200) return DataLossError("stored layer origin is too long");
  const std::string text(bytes);
  char magic[32] = {};
  double x = 0, y = 0, z = 0;
  int consumed = 0;
  if (std::sscanf(text.c_str(), "%31s %lf %lf %lf\n%n", magic, &x, &y, &z, &consumed) != 4 ||
      std::string(magic) != kOriginMagic || static_cast<size_t>(consumed) != text.size()) {
    return DataLossError("stored layer origin is not a semmap layer origin");
  }
  const Eigen::Vector3d origin(x, y, z);
  if (!origin.allFinite() || origin.cwiseAbs().maxCoeff() > kMaxPositionM) {
    return DataLossError("stored layer origin is not a finite position within 1e7 m");
  }
  return origin;
}

}  // namespace semmap
