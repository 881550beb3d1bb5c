#include "core/query/map_export.h"

#include <nlohmann/json.hpp>
#include <string>

#include "common/pose.h"
#include "common/sha256.h"
#include "common/time_util.h"
#include "common/tum_format.h"
#include "core/query/map_layer_export.h"

namespace semmap {
namespace {

nlohmann::json PoseJson(const Eigen::Isometry3d& T) {
  const PoseTq tq = ToPoseTq(T);
  return {{"t", {tq.t.x(), tq.t.y(), tq.t.z()}}, {"q", {tq.q.x(), tq.q.y(), tq.q.z(), tq.q.w()}}};
}

StatusOr<std::string> ExportTum(MapStore& store, const ExportRequest& request) {
  std::string session_name = request.session;
  if (session_name.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(std::vector<SessionInfo> sessions, store.ListSessions(request.map));
    if (sessions.size() != 1) {
      return InvalidArgumentError("map '" + request.map + "' has " +
                                  std::to_string(sessions.size()) +
                                  " sessions; name one for a tum export");
    }
    session_name = sessions.front().name;
  }
  SEMMAP_ASSIGN_OR_RETURN(SessionInfo session, store.GetSession(request.map, session_name));
  SEMMAP_ASSIGN_OR_RETURN(std::vector<TrajectoryPose> poses,
                          store.GetTrajectory(session.id, /*keyframes_only=*/false));
  std::string out = "# semmap trajectory of map '" + request.map + "' session '" + session.name +
                    "' (T_world_camera)\n# timestamp tx ty tz qx qy qz qw\n";
  for (const TrajectoryPose& p : poses) out += FormatTumPoseLine(p.stamp_ns, p.T_world_camera);
  return out;
}

StatusOr<std::string> ExportJson(MapStore& store, const ExportRequest& request) {
  SEMMAP_ASSIGN_OR_RETURN(MapInfo map, store.GetMap(request.map));
  SEMMAP_ASSIGN_OR_RETURN(std::vector<SessionInfo> sessions, store.ListSessions(request.map));
  nlohmann::json doc;
  doc["map"] = map.name;
  doc["sessions"] = nlohmann::json::array();
  bool matched = request.session.empty();
  for (const SessionInfo& s : sessions) {
    if (!request.session.empty() && s.name != request.session) continue;
    matched = true;
    SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> kfs,
                            store.ListKeyframes(s.id, /*with_images=*/false));
    nlohmann::json keyframes = nlohmann::json::array();
    for (const KeyframeRecord& kf : kfs) {
      keyframes.push_back({{"id", kf.id},
                           {"seq", kf.seq},
                           {"stamp", FormatStampSeconds(kf.stamp_ns)},
                           {"T_world_camera", PoseJson(kf.T_world_camera)}});
    }
    doc["sessions"].push_back({{"name", s.name},
                               {"mode", SessionModeName(s.mode)},
                               {"frames", s.frame_count},
                               {"keyframes", keyframes}});
  }
  if (!matched) {
    return NotFoundError("map '" + request.map + "' has no session '" + request.session + "'");
  }
  SEMMAP_ASSIGN_OR_RETURN(std::vector<LinkRecord> links, store.ListLinks(map.id));
  doc["links"] = nlohmann::json::array();
  for (const LinkRecord& l : links) {
    doc["links"].push_back({{"from", l.from_keyframe_id},
                            {"to", l.to_keyframe_id},
                            {"kind", l.kind == LinkKind::kLoop ? "loop" : "odometry"},
                            {"T_from_to", PoseJson(l.T_from_to)}});
  }
  return doc.dump(2) + "\n";
}

}  // namespace

StatusOr<ExportResult> BuildExport(MapStore& store, const ExportRequest& request,
                                   const MapLayerOptions& layers, const CancelCheck& cancel) {
  if (request.map.empty()) return InvalidArgumentError("export needs a map name");
  if (IsLayerExportFormat(request.format)) {
    SEMMAP_ASSIGN_OR_RETURN(ExportResult result, BuildLayerExport(store, request, layers, cancel));
    result.sha256_hex = ToHex(Sha256(result.bytes));
    return result;
  }
  ExportResult result;
  result.format = request.format;
  if (request.format == "tum") {
    result.media_type = "text/plain";
    SEMMAP_ASSIGN_OR_RETURN(result.bytes, ExportTum(store, request));
  } else if (request.format == "json") {
    result.media_type = "application/json";
    SEMMAP_ASSIGN_OR_RETURN(result.bytes, ExportJson(store, request));
  } else {
    return InvalidArgumentError("unknown export format '" + request.format +
                                "' (supported: tum, json, ot, bt, ply, pcd, png)");
  }
  result.sha256_hex = ToHex(Sha256(result.bytes));
  return result;
}

}  // namespace semmap
