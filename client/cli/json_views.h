// JSON shapes of query results for --json output.
#pragma once

#include <nlohmann/json.hpp>

#include "common/map_types.h"

namespace semmap::cli {

nlohmann::json ToJson(const MapInfo& map);
nlohmann::json ToJson(const SessionInfo& session);
nlohmann::json ToJson(const TrajectoryPose& pose);
std::string FormatUnixTime(int64_t unix_ns);  // "2026-11-22T01:02:03Z", "" for 0

}  // namespace semmap::cli
