// What every semmap subcommand gets: the parsed options shared by all commands and helpers to
// report errors the same way everywhere.
#pragma once

#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "client/lib/map_client.h"
#include "common/arg_parser.h"
#include "common/status.h"

namespace semmap::cli {

constexpr int kExitOk = 0;
constexpr int kExitError = 1;  // the server or the data said no
constexpr int kExitUsage = 2;  // the command line was wrong

struct CliContext {
  std::string server = "127.0.0.1:50051";
  std::optional<ClientTls> tls;  // --tls-ca / --tls-cert / --tls-key
  std::string token;             // --token-file or $SEMMAP_TOKEN
  bool json = false;
};

// Adds --json and --help, and --server for commands that talk to semmapd, so they work
// before or after the subcommand.
void AddCommonFlags(ArgParser& parser, bool uses_server = true);
// INVALID_ARGUMENT for TLS files that cannot be read (naming the flag).
Status ApplyCommonFlags(const ArgParser& parser, CliContext* context);

// Parses a subcommand's argv (after its name) with the parser's own flags plus the common ones,
// prints help or a usage error, and checks the number of positional arguments.
// Returns -1 to go on, otherwise the exit code to return.
int ParseSubcommand(ArgParser& parser, CliContext* context, int argc, const char* const* argv,
                    const std::string& usage, size_t min_positional, size_t max_positional,
                    bool uses_server = true,
                    const std::string& positional_error = "wrong number of arguments");

// Prints "semmap: CODE: message" to stderr and returns kExitError.
int ReportError(const Status& status);
int ReportUsage(const std::string& message, const std::string& usage);
void PrintJson(const nlohmann::json& value);

MapClient MakeClient(const CliContext& context);

}  // namespace semmap::cli
