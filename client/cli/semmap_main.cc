// semmap: the command-line client of semmapd.
#include <cstring>
#include <iostream>
#include <map>
#include <string>

#include "client/cli/commands.h"

namespace {

constexpr char kUsage[] =
    "usage: semmap [--server HOST:PORT] [--json] COMMAND [args]\n"
    "\n"
    "commands:\n"
    "  health                       is semmapd serving?\n"
    "  ingest DIR [options]         stream a dataset (TUM RGB-D or KITTI layout) into a map\n"
    "  maps                         list maps\n"
    "  maps remove MAP [--yes]      remove a map (asks for confirmation)\n"
    "  sessions [--map M]           list mapping sessions and how they ended\n"
    "  sessions remove --map M S [--yes]          remove a session (asks for confirmation)\n"
    "  trajectory --map M --session S [-o FILE]   a session's poses in TUM format\n"
    "  export --map M --format F -o FILE          download a map product (tum, json, ot, bt,\n"
    "                                             ply, pcd, png)\n"
    "  objects add|list|remove ...  the object database (photos of objects to recognise)\n"
    "  where LABEL [--map M]        where the objects of a label are\n"
    "  near X Y Z RADIUS [--label L] [--map M]    objects within RADIUS metres of a point\n"
    "  eval ate|rpe|kitti GT EST [options]        trajectory error (TUM ATE/RPE, KITTI)\n"
    "\n"
    "`semmap COMMAND --help` describes a command. --json prints one JSON object to stdout.\n"
    "The server address also comes from $SEMMAP_SERVER. Exit status: 0 ok, 1 error, 2 usage.\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace semmap::cli;
  CliContext context;
  if (const char* env = std::getenv("SEMMAP_SERVER"); env != nullptr && *env != '\0') {
    context.server = env;
  }
  // Global options before the command.
  int i = 1;
  for (; i < argc && std::strncmp(argv[i], "--", 2) == 0; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return kExitOk;
    } else if (arg == "--json") {
      context.json = true;
    } else if (arg == "--server" && i + 1 < argc) {
      context.server = argv[++i];
    } else if (arg.rfind("--server=", 0) == 0) {
      context.server = arg.substr(9);
    } else {
      std::cerr << "semmap: unknown option " << arg << "\n\n" << kUsage;
      return kExitUsage;
    }
  }
  if (i >= argc) {
    std::cerr << kUsage;
    return kExitUsage;
  }
  using Command = int (*)(CliContext, int, const char* const*);
  static const std::map<std::string, Command> kCommands = {
      {"health", RunHealth},     {"ingest", RunIngest},         {"maps", RunMaps},
      {"sessions", RunSessions}, {"trajectory", RunTrajectory}, {"export", RunExport},
      {"eval", RunEval},         {"objects", RunObjects},       {"where", RunWhere},
      {"near", RunNear},
  };
  const auto command = kCommands.find(argv[i]);
  if (command == kCommands.end()) {
    std::cerr << "semmap: unknown command '" << argv[i] << "'\n\n" << kUsage;
    return kExitUsage;
  }
  return command->second(context, argc - i - 1, argv + i + 1);
}
