// The query interface clients use, implemented in-process over the store (server, tests) and
// remotely over gRPC (client library): one interface, two transports.
#pragma once

#include <string>
#include <vector>

#include "common/cancel_check.h"
#include "common/map_types.h"
#include "common/object_types.h"
#include "common/status.h"

namespace semmap {

struct ExportRequest {
  std::string map;
  // "tum" (one session's trajectory), "json" (map summary), "ot" / "bt" (OctoMap occupancy),
  // "ply" / "pcd" (coloured point cloud), "png" (rendered picture).
  std::string format;
  std::string session;  // optional filter
  bool ascii = false;   // ply / pcd: ASCII instead of binary
  // ot / bt: tree resolution, ply / pcd / png: voxel-grid leaf (metres); 0: the map's own.
  double voxel_m = 0;
  std::string view;  // png: "top" (default) or "oblique"
  int width_px = 0;  // png: long side in pixels; 0: default
};

struct ExportResult {
  std::string format;
  std::string media_type;
  std::string bytes;
  std::string sha256_hex;
  // 3D formats: map coordinates = layer coordinates + layer_origin (zero for maps near their
  // frame's origin; see core/mapping/layer_frame.h).
  Eigen::Vector3d layer_origin = Eigen::Vector3d::Zero();
};

class MapQueryInterface {
 public:
  virtual ~MapQueryInterface() = default;
  virtual StatusOr<std::vector<MapInfo>> ListMaps() = 0;
  // Every map's sessions when map is empty; NOT_FOUND for an unknown map.
  virtual StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& map) = 0;
  virtual StatusOr<std::vector<TrajectoryPose>> GetTrajectory(const std::string& map,
                                                              const std::string& session,
                                                              bool keyframes_only) = 0;
  // A long export (a layer rebuilt from every keyframe) asks `cancel` as it goes and stops with
  // its status (the server passes the call's cancellation and deadline).
  virtual StatusOr<ExportResult> ExportMap(const ExportRequest& request,
                                           const CancelCheck& cancel = {}) = 0;

  // Object types visible in `map` (global ones and the map's), or all when empty; no views.
  virtual StatusOr<std::vector<ObjectType>> ListObjectTypes(const std::string& map) = 0;
  // Instances of `label` (every label when empty) in `map` (every map when empty).
  virtual StatusOr<std::vector<ObjectInstance>> FindObjects(const std::string& label,
                                                            const std::string& map) = 0;
  // Instances within radius_m of `point` in `map` (may be empty when there is one map only),
  // nearest first; only `label` when not empty.
  virtual StatusOr<std::vector<ObjectInstance>> ObjectsNear(const std::string& map,
                                                            const Eigen::Vector3d& point,
                                                            double radius_m,
                                                            const std::string& label) = 0;
};

}  // namespace semmap
