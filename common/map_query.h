// The query interface clients use, implemented in-process over the store (server, tests) and
// remotely over gRPC (client library): one interface, two transports.
#pragma once

#include <string>
#include <vector>

#include "common/map_types.h"
#include "common/status.h"

namespace semmap {

struct ExportRequest {
  std::string map;
  std::string format;   // "tum" | "json"
  std::string session;  // optional filter
};

struct ExportResult {
  std::string format;
  std::string media_type;
  std::string bytes;
  std::string sha256_hex;
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
  virtual StatusOr<ExportResult> ExportMap(const ExportRequest& request) = 0;
};

}  // namespace semmap
