// health, maps, sessions, trajectory, export.
#include <fstream>
#include <iomanip>
#include <iostream>

#include "client/cli/commands.h"
#include "client/cli/json_views.h"
#include "common/tum_format.h"

namespace semmap::cli {
namespace {

// "completed", "error: INVALID_ARGUMENT: ...", "open" (still streaming), ...
std::string SessionEndText(const SessionInfo& s) {
  if (s.end_reason == SessionEndReason::kUnspecified) {
    return s.ended_unix_ns == 0 ? "open" : "ended";
  }
  std::string text(SessionEndReasonName(s.end_reason));
  if (!s.end_message.empty()) text += ": " + s.end_message;
  return text;
}

}  // namespace

int RunHealth(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  if (int rc =
          ParseSubcommand(parser, &context, argc, argv,
                          "usage: semmap health\n  Asks semmapd whether it is serving.\n", 0, 0);
      rc >= 0) {
    return rc;
  }
  MapClient client = MakeClient(context);
  StatusOr<std::string> health = client.Health();
  if (!health.ok()) return ReportError(health.status());
  if (context.json) {
    PrintJson({{"server", context.server}, {"status", *health}});
  } else {
    std::cout << context.server << ": " << *health << std::endl;
  }
  return *health == "SERVING" ? kExitOk : kExitError;
}

int RunMaps(CliContext context, int argc, const char* const* argv) {
  if (argc > 0 && std::string(argv[0]) == "remove")
    return RunMapsRemove(context, argc - 1, argv + 1);
  ArgParser parser;
  if (int rc = ParseSubcommand(parser, &context, argc, argv,
                               "usage: semmap maps\n       semmap maps remove MAP [--yes]\n"
                               "  Lists maps (or removes one).\n",
                               0, 0);
      rc >= 0) {
    return rc;
  }
  MapClient client = MakeClient(context);
  StatusOr<std::vector<MapInfo>> maps = client.ListMaps();
  if (!maps.ok()) return ReportError(maps.status());
  if (context.json) {
    nlohmann::json out = {{"maps", nlohmann::json::array()}};
    for (const MapInfo& m : *maps) out["maps"].push_back(ToJson(m));
    PrintJson(out);
    return kExitOk;
  }
  if (maps->empty()) std::cout << "no maps\n";
  for (const MapInfo& m : *maps) {
    std::cout << std::left << std::setw(24) << m.name << " sessions " << std::setw(4)
              << m.session_count << " keyframes " << std::setw(6) << m.keyframe_count << " created "
              << FormatUnixTime(m.created_unix_ns) << "\n";
  }
  return kExitOk;
}

int RunSessions(CliContext context, int argc, const char* const* argv) {
  if (argc > 0 && std::string(argv[0]) == "remove") {
    return RunSessionsRemove(context, argc - 1, argv + 1);
  }
  ArgParser parser;
  parser.AddFlag("map", "M", "only this map's sessions");
  if (int rc = ParseSubcommand(parser, &context, argc, argv,
                               "usage: semmap sessions [--map M]\n"
                               "       semmap sessions remove --map M SESSION [--yes]\n"
                               "  Lists mapping sessions and how they ended (or removes one).\n",
                               0, 0);
      rc >= 0) {
    return rc;
  }
  MapClient client = MakeClient(context);
  StatusOr<std::vector<SessionInfo>> sessions = client.ListSessions(parser.Get("map"));
  if (!sessions.ok()) return ReportError(sessions.status());
  if (context.json) {
    nlohmann::json out = {{"sessions", nlohmann::json::array()}};
    for (const SessionInfo& s : *sessions) out["sessions"].push_back(ToJson(s));
    PrintJson(out);
    return kExitOk;
  }
  if (sessions->empty()) std::cout << "no sessions\n";
  for (const SessionInfo& s : *sessions) {
    std::cout << std::left << std::setw(16) << s.map_name << " " << std::setw(24) << s.name << " "
              << std::setw(12) << SessionModeName(s.mode) << " frames " << std::setw(6)
              << s.frame_count << " keyframes " << std::setw(5) << s.keyframe_count << " "
              << SessionEndText(s) << "\n";
  }
  return kExitOk;
}

int RunTrajectory(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("map", "M", "map name (required)");
  parser.AddFlag("session", "S", "session name (required)");
  parser.AddFlag("o", "FILE", "write TUM format to FILE instead of stdout");
  parser.AddSwitch("keyframes", "only keyframes");
  if (int rc = ParseSubcommand(parser, &context, argc, argv,
                               "usage: semmap trajectory --map M --session S [-o FILE]\n"
                               "  Prints a session's poses (T_world_camera) in TUM format.\n",
                               0, 0);
      rc >= 0) {
    return rc;
  }
  if (!parser.Has("map") || !parser.Has("session")) {
    return ReportUsage("trajectory needs --map and --session", "see semmap trajectory --help\n");
  }
  MapClient client = MakeClient(context);
  StatusOr<std::vector<TrajectoryPose>> poses =
      client.GetTrajectory(parser.Get("map"), parser.Get("session"), parser.Has("keyframes"));
  if (!poses.ok()) return ReportError(poses.status());
  if (context.json && !parser.Has("o")) {
    nlohmann::json out = {{"map", parser.Get("map")},
                          {"session", parser.Get("session")},
                          {"poses", nlohmann::json::array()}};
    for (const TrajectoryPose& p : *poses) out["poses"].push_back(ToJson(p));
    PrintJson(out);
    return kExitOk;
  }
  std::ofstream file;
  if (parser.Has("o")) {
    file.open(parser.Get("o"));
    if (!file) return ReportError(UnavailableError("cannot write " + parser.Get("o")));
  }
  std::ostream& out = parser.Has("o") ? file : std::cout;
  out << "# timestamp tx ty tz qx qy qz qw\n";
  for (const TrajectoryPose& p : *poses) out << FormatTumPoseLine(p.stamp_ns, p.T_world_camera);
  if (parser.Has("o")) {
    file.close();
    if (!file) return ReportError(UnavailableError("writing " + parser.Get("o") + " failed"));
    if (context.json) {
      PrintJson({{"file", parser.Get("o")}, {"poses", poses->size()}});
    } else {
      std::cerr << "wrote " << poses->size() << " poses to " << parser.Get("o") << "\n";
    }
  }
  return kExitOk;
}

int RunExport(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("map", "M", "map name (required)");
  parser.AddFlag("format", "F",
                 "tum (one session's trajectory), json (map summary), ot / bt (OctoMap), ply / pcd "
                 "(coloured point cloud), png (picture)");
  parser.AddFlag("session", "S", "only this session");
  parser.AddSwitch("ascii", "ply / pcd: ASCII instead of binary");
  parser.AddFlag("voxel", "M", "ot / bt: tree resolution; ply / pcd / png: voxel-grid leaf");
  parser.AddFlag("view", "top|oblique", "png: top-down (default) or oblique view");
  parser.AddFlag("width", "PX", "png: long side in pixels (default 1600)");
  parser.AddFlag("o", "FILE", "output file (required)");
  if (int rc = ParseSubcommand(parser, &context, argc, argv,
                               "usage: semmap export --map M --format F -o FILE [--session S]\n"
                               "       [--ascii] [--voxel M] [--view top|oblique] [--width PX]\n"
                               "  Downloads a map product; its SHA-256 is checked.\n",
                               0, 0);
      rc >= 0) {
    return rc;
  }
  if (!parser.Has("map") || !parser.Has("format") || !parser.Has("o")) {
    return ReportUsage("export needs --map, --format and -o", "see semmap export --help\n");
  }
  ExportRequest request;
  request.map = parser.Get("map");
  request.format = parser.Get("format");
  request.session = parser.Get("session");
  request.ascii = parser.Has("ascii");
  request.view = parser.Get("view");
  StatusOr<double> voxel = parser.GetDouble("voxel", 0);
  if (!voxel.ok()) return ReportUsage(voxel.status().message(), "see semmap export --help\n");
  request.voxel_m = *voxel;
  StatusOr<long long> width = parser.GetInt("width", 0);
  if (!width.ok() || *width < 0 || *width > 100000) {
    return ReportUsage("--width must be a pixel count", "see semmap export --help\n");
  }
  request.width_px = static_cast<int>(*width);
  MapClient client = MakeClient(context);
  StatusOr<ExportResult> result = client.ExportMap(request);
  if (!result.ok()) return ReportError(result.status());
  const std::string path = parser.Get("o");
  std::ofstream file(path, std::ios::binary);
  file.write(result->bytes.data(), static_cast<std::streamsize>(result->bytes.size()));
  file.close();
  if (!file) return ReportError(UnavailableError("writing " + path + " failed"));
  const Eigen::Vector3d& origin = result->layer_origin;
  if (context.json) {
    PrintJson({{"file", path},
               {"format", result->format},
               {"bytes", result->bytes.size()},
               {"sha256", result->sha256_hex},
               {"layer_origin", {origin.x(), origin.y(), origin.z()}}});
  } else {
    std::cout << "wrote " << result->bytes.size() << " bytes (" << result->format << ", sha256 "
              << result->sha256_hex << ") to " << path << "\n";
    if (!origin.isZero()) {
      std::cout << "3D coordinates are in the map's layer frame: map = layer + (" << origin.x()
                << ", " << origin.y() << ", " << origin.z() << ") m\n";
    }
  }
  return kExitOk;
}

}  // namespace semmap::cli
