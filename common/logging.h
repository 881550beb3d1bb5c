// One logging library for the whole tree: spdlog (Debian's compiled libspdlog), one logger
// that writes to stderr (stdout stays for machine-readable output such as semmapd's
// "listening on" line), levels set once at start (semmapd --log-level). Library code logs
// through these four functions and never prints on its own.
#pragma once

#include <spdlog/logger.h>

#include <string_view>
#include <utility>

#include "common/status.h"

namespace semmap {

enum class LogLevel { kDebug, kInfo, kWarning, kError, kOff };

// "debug", "info", "warning" (or "warn"), "error", "off"; INVALID_ARGUMENT otherwise.
StatusOr<LogLevel> ParseLogLevel(std::string_view name);
std::string_view LogLevelName(LogLevel level);

// Process-wide; the default is kInfo. Thread-safe.
void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();

// The logger (created on first use; thread-safe). Prefer the functions below.
spdlog::logger& Logger();

template <typename... Args>
void LogDebug(spdlog::format_string_t<Args...> format, Args&&... args) {
  Logger().debug(format, std::forward<Args>(args)...);
}
template <typename... Args>
void LogInfo(spdlog::format_string_t<Args...> format, Args&&... args) {
  Logger().info(format, std::forward<Args>(args)...);
}
template <typename... Args>
void LogWarning(spdlog::format_string_t<Args...> format, Args&&... args) {
  Logger().warn(format, std::forward<Args>(args)...);
}
template <typename... Args>
void LogError(spdlog::format_string_t<Args...> format, Args&&... args) {
  Logger().error(format, std::forward<Args>(args)...);
}

}  // namespace semmap
