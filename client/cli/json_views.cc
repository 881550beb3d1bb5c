#include "client/cli/json_views.h"

#include <ctime>

#include "common/pose.h"
#include "common/time_util.h"

namespace semmap::cli {

std::string FormatUnixTime(int64_t unix_ns) {
  if (unix_ns == 0) return "";
  const std::time_t seconds = static_cast<std::time_t>(unix_ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buf;
}

nlohmann::json ToJson(const MapInfo& map) {
  return {{"name", map.name},
          {"created", FormatUnixTime(map.created_unix_ns)},
          {"sessions", map.session_count},
          {"keyframes", map.keyframe_count}};
}

nlohmann::json ToJson(const SessionInfo& s) {
  nlohmann::json out = {{"map", s.map_name},
                        {"name", s.name},
                        {"mode", SessionModeName(s.mode)},
                        {"frames", s.frame_count},
                        {"keyframes", s.keyframe_count},
                        {"started", FormatUnixTime(s.started_unix_ns)},
                        {"camera",
                         {{"width", s.camera.width},
                          {"height", s.camera.height},
                          {"fx", s.camera.fx},
                          {"fy", s.camera.fy},
                          {"cx", s.camera.cx},
                          {"cy", s.camera.cy}}}};
  out["ended"] = s.ended_unix_ns == 0 ? nlohmann::json(nullptr)
                                      : nlohmann::json(FormatUnixTime(s.ended_unix_ns));
  out["end_reason"] = s.end_reason == SessionEndReason::kUnspecified
                          ? nlohmann::json(nullptr)
                          : nlohmann::json(std::string(SessionEndReasonName(s.end_reason)));
  out["end_message"] = s.end_message;
  return out;
}

nlohmann::json ToJson(const TrajectoryPose& p) {
  const PoseTq tq = ToPoseTq(p.T_world_camera);
  return {{"seq", p.seq},
          {"stamp", FormatStampSeconds(p.stamp_ns)},
          {"t", {tq.t.x(), tq.t.y(), tq.t.z()}},
          {"q", {tq.q.x(), tq.q.y(), tq.q.z(), tq.q.w()}},
          {"keyframe", p.is_keyframe},
          {"lost", p.lost}};
}

nlohmann::json ToJson(const ObjectType& t) {
  return {{"label", t.label},
          {"map", t.map_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(t.map_name)},
          {"colour", {t.rgb[0], t.rgb[1], t.rgb[2]}},
          {"photos", t.views.size()},
          {"created", FormatUnixTime(t.created_unix_ns)}};
}

nlohmann::json ToJson(const ObjectInstance& o, bool with_distance) {
  const auto xyz = [](const Eigen::Vector3d& v) {
    return nlohmann::json{{"x", v.x()}, {"y", v.y()}, {"z", v.z()}};
  };
  nlohmann::json out = {{"label", o.label},
                        {"map", o.map_name},
                        {"position", xyz(o.position)},
                        {"extent", xyz(o.extent)},
                        {"confidence", o.confidence},
                        {"observations", o.observations},
                        {"sessions", o.sessions},
                        {"first_seen", FormatStampSeconds(o.first_seen_ns)},
                        {"last_seen", FormatStampSeconds(o.last_seen_ns)}};
  if (with_distance) out["distance"] = o.distance_m;
  return out;
}

}  // namespace semmap::cli
