// One function per semmap subcommand; argv starts after the subcommand name.
#pragma once

#include "client/cli/cli_context.h"

namespace semmap::cli {

int RunHealth(CliContext context, int argc, const char* const* argv);
int RunIngest(CliContext context, int argc, const char* const* argv);
int RunMaps(CliContext context, int argc, const char* const* argv);
int RunSessions(CliContext context, int argc, const char* const* argv);
int RunSessionsRemove(CliContext context, int argc, const char* const* argv);
int RunMapsRemove(CliContext context, int argc, const char* const* argv);
int RunTrajectory(CliContext context, int argc, const char* const* argv);
int RunExport(CliContext context, int argc, const char* const* argv);
int RunEval(CliContext context, int argc, const char* const* argv);
int RunObjects(CliContext context, int argc, const char* const* argv);
int RunWhere(CliContext context, int argc, const char* const* argv);
int RunNear(CliContext context, int argc, const char* const* argv);

}  // namespace semmap::cli
