// sessions remove, maps remove: administrative removals, confirmed at a terminal or by --yes.
#include <unistd.h>

#include <algorithm>
#include <iostream>
#include <string>

#include "client/cli/commands.h"

namespace semmap::cli {
namespace {

constexpr char kSessionsRemoveUsage[] =
    "usage: semmap sessions remove --map M SESSION [--yes]\n"
    "  Removes a session: its frames, keyframes, links and object observations. The map's 3D\n"
    "  layers and object positions are rebuilt from the other sessions. Cannot be undone; asks\n"
    "  for confirmation at a terminal (--yes: do not ask). Refused while a stream ingests into\n"
    "  the map.\n";
constexpr char kMapsRemoveUsage[] =
    "usage: semmap maps remove MAP [--yes]\n"
    "  Removes a map with all its sessions, layers and objects. Cannot be undone; asks for\n"
    "  confirmation at a terminal (--yes: do not ask). Refused while a stream ingests into it.\n";

// kExitOk when the user confirmed (or passed --yes); a non-terminal stdin without --yes is a
// usage error, any answer but yes an error.
int Confirm(const ArgParser& parser, const std::string& question) {
  if (parser.Has("yes")) return kExitOk;
  if (::isatty(STDIN_FILENO) == 0) {
    return ReportUsage("not removing without confirmation: stdin is not a terminal; pass --yes",
                       "");
  }
  std::cerr << question << " This cannot be undone. [y/N] " << std::flush;
  std::string answer;
  if (!std::getline(std::cin, answer) || (answer != "y" && answer != "Y" && answer != "yes")) {
    std::cerr << "semmap: nothing removed\n";
    return kExitError;
  }
  return kExitOk;
}

}  // namespace

int RunSessionsRemove(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("map", "M", "the session's map (required)");
  parser.AddSwitch("yes", "do not ask for confirmation");
  if (int rc = ParseSubcommand(parser, &context, argc, argv, kSessionsRemoveUsage, 1, 1,
                               /*uses_server=*/true, "sessions remove takes one SESSION");
      rc >= 0) {
    return rc;
  }
  if (!parser.Has("map")) return ReportUsage("sessions remove needs --map", kSessionsRemoveUsage);
  const std::string map = parser.Get("map");
  const std::string session = parser.positional()[0];
  MapClient client = MakeClient(context);
  // Say what would go before asking (and fail early for an unknown session).
  StatusOr<std::vector<SessionInfo>> sessions = client.ListSessions(map);
  if (!sessions.ok()) return ReportError(sessions.status());
  const auto found = std::find_if(sessions->begin(), sessions->end(),
                                  [&](const SessionInfo& s) { return s.name == session; });
  if (found == sessions->end()) {
    return ReportError(NotFoundError("map '" + map + "' has no session '" + session + "'"));
  }
  if (int rc = Confirm(parser, "Remove session '" + session + "' of map '" + map + "' (" +
                                   std::to_string(found->frame_count) + " frames, " +
                                   std::to_string(found->keyframe_count) + " keyframes)?");
      rc != kExitOk) {
    return rc;
  }
  StatusOr<RemovedCounts> removed = client.RemoveSession(map, session);
  if (!removed.ok()) return ReportError(removed.status());
  if (context.json) {
    PrintJson({{"map", map},
               {"session", session},
               {"frames", removed->frames},
               {"keyframes", removed->keyframes}});
  } else {
    std::cout << "removed session '" << session << "' of map '" << map << "': " << removed->frames
              << " frames, " << removed->keyframes << " keyframes\n";
  }
  return kExitOk;
}

int RunMapsRemove(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddSwitch("yes", "do not ask for confirmation");
  if (int rc = ParseSubcommand(parser, &context, argc, argv, kMapsRemoveUsage, 1, 1,
                               /*uses_server=*/true, "maps remove takes one MAP");
      rc >= 0) {
    return rc;
  }
  const std::string map = parser.positional()[0];
  MapClient client = MakeClient(context);
  StatusOr<std::vector<SessionInfo>> sessions = client.ListSessions(map);
  if (!sessions.ok()) return ReportError(sessions.status());
  int64_t frames = 0;
  for (const SessionInfo& s : *sessions) frames += s.frame_count;
  if (int rc =
          Confirm(parser, "Remove map '" + map + "' with its " + std::to_string(sessions->size()) +
                              " session(s) and " + std::to_string(frames) + " frames?");
      rc != kExitOk) {
    return rc;
  }
  StatusOr<RemovedCounts> removed = client.RemoveMap(map);
  if (!removed.ok()) return ReportError(removed.status());
  if (context.json) {
    PrintJson({{"map", map},
               {"sessions", removed->sessions},
               {"frames", removed->frames},
               {"keyframes", removed->keyframes}});
  } else {
    std::cout << "removed map '" << map << "': " << removed->sessions << " session(s), "
              << removed->frames << " frames, " << removed->keyframes << " keyframes\n";
  }
  return kExitOk;
}

}  // namespace semmap::cli
