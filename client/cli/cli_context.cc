#include "client/cli/cli_context.h"

namespace semmap::cli {

void AddCommonFlags(ArgParser& parser) {
  parser.AddFlag("server", "HOST:PORT", "semmapd address (default 127.0.0.1:50051)");
  parser.AddSwitch("json", "print one JSON object to stdout");
  parser.AddSwitch("help", "print this help");
}

void ApplyCommonFlags(const ArgParser& parser, CliContext* context) {
  context->server = parser.Get("server", context->server);
  if (parser.Has("json")) context->json = true;
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
