#include "client/cli/cli_context.h"

namespace semmap::cli {

void AddCommonFlags(ArgParser& parser, bool uses_server) {
  if (uses_server) {
    parser.AddFlag("server", "HOST:PORT", "semmapd address (default 127.0.0.1:50051)");
  }
  parser.AddSwitch("json", "print one JSON object to stdout");
  parser.AddSwitch("help", "print this help");
}

void ApplyCommonFlags(const ArgParser& parser, CliContext* context) {
  context->server = parser.Get("server", context->server);
  if (parser.Has("json")) context->json = true;
}

int ParseSubcommand(ArgParser& parser, CliContext* context, int argc, const char* const* argv,
                    const std::string& usage, size_t min_positional, size_t max_positional,
                    bool uses_server, const std::string& positional_error) {
  AddCommonFlags(parser, uses_server);
  const std::string full_usage = usage + "\noptions:\n" + parser.Usage();
  Status parsed = parser.Parse(argc, argv, 0);
  if (!parsed.ok()) return ReportUsage(parsed.message(), full_usage);
  if (parser.Has("help")) {
    std::cout << full_usage;
    return kExitOk;
  }
  const size_t n = parser.positional().size();
  if (n < min_positional || n > max_positional) return ReportUsage(positional_error, full_usage);
  ApplyCommonFlags(parser, context);
  return -1;
}

int ReportError(const Status& status) {
  std::cerr << "semmap: " << status.ToString() << std::endl;
  return kExitError;
}

int ReportUsage(const std::string& message, const std::string& usage) {
  std::cerr << "semmap: " << message << "\n\n" << usage;
  return kExitUsage;
}

void PrintJson(const nlohmann::json& value) { std::cout << value.dump() << std::endl; }

MapClient MakeClient(const CliContext& context) {
  ClientOptions options;
  options.server = context.server;
  return MapClient(options);
}

}  // namespace semmap::cli
