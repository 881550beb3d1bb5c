#include "client/cli/cli_context.h"

#include <cstdlib>
#include <fstream>

namespace semmap::cli {

void AddCommonFlags(ArgParser& parser, bool uses_server) {
  if (uses_server) {
    parser.AddFlag("server", "HOST:PORT",
                   "semmapd address (default 127.0.0.1:50051), or unix:/PATH for its Unix socket");
    parser.AddFlag("tls-ca", "FILE", "connect with TLS, trusting this PEM CA (default plaintext)");
    parser.AddFlag("tls-cert", "FILE",
                   "mutual TLS: this client's PEM certificate (with --tls-key)");
    parser.AddFlag("tls-key", "FILE", "mutual TLS: the PEM private key of --tls-cert");
    parser.AddFlag("token-file", "FILE",
                   "send the bearer token in FILE (semmapd --auth-tokens; default "
                   "$SEMMAP_TOKEN)");
  }
  parser.AddSwitch("json", "print one JSON object to stdout");
  parser.AddSwitch("help", "print this help");
}

namespace {

// The first line of `path`, surrounding white space removed.
StatusOr<std::string> ReadTokenFile(const std::string& path) {
  std::ifstream in(path);
  std::string token;
  if (!in || !std::getline(in, token)) {
    return InvalidArgumentError("--token-file " + path + ": cannot be read");
  }
  const size_t first = token.find_first_not_of(" \t\r");
  const size_t last = token.find_last_not_of(" \t\r");
  if (first == std::string::npos) return InvalidArgumentError("--token-file " + path + ": empty");
  return token.substr(first, last - first + 1);
}

}  // namespace

Status ApplyCommonFlags(const ArgParser& parser, CliContext* context) {
  context->server = parser.Get("server", context->server);
  if (parser.Has("json")) context->json = true;
  if (parser.Has("tls-ca") || parser.Has("tls-cert") || parser.Has("tls-key")) {
    SEMMAP_ASSIGN_OR_RETURN(context->tls,
                            LoadClientTls(parser.Get("tls-ca", ""), parser.Get("tls-cert", ""),
                                          parser.Get("tls-key", "")));
  }
  if (parser.Has("token-file")) {
    SEMMAP_ASSIGN_OR_RETURN(context->token, ReadTokenFile(parser.Get("token-file", "")));
  } else if (const char* env = std::getenv("SEMMAP_TOKEN"); env != nullptr) {
    context->token = env;
  }
  return OkStatus();
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
  if (Status applied = ApplyCommonFlags(parser, context); !applied.ok()) {
    return ReportUsage(applied.message(), full_usage);
  }
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
  options.tls = context.tls;
  options.token = context.token;
  return MapClient(options);
}

}  // namespace semmap::cli
