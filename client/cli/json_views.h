// JSON shapes of query results for --json output.
#pragma once

#include <nlohmann/json.hpp>

#include "common/map_types.h"
#include "common/object_types.h"

namespace semmap::cli {

nlohmann::json ToJson(const MapInfo& map);
nlohmann::json ToJson(const SessionInfo& session);
nlohmann::json ToJson(const TrajectoryPose& pose);
nlohmann::json ToJson(const ObjectType& type);  // label, map, colour, photos
// label, map, position {x,y,z}, extent {x,y,z}, confidence, observations, sessions, first_seen,
// last_seen, and with_distance the distance from a near query's point.
nlohmann::json ToJson(const ObjectInstance& instance, bool with_distance = false);
std::string FormatUnixTime(int64_t unix_ns);  // "2026-11-22T01:02:03Z", "" for 0

}  // namespace semmap::cli
