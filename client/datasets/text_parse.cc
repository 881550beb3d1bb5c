#include "client/datasets/text_parse.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <system_error>

#include "common/time_util.h"

namespace semmap::datasets_internal {
namespace {

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v'; }

std::string_view SkipPlus(std::string_view token) {
  // from_chars rejects a leading '+', which hand-written files do contain.
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  return token;
}

}  // namespace

StatusOr<std::string> ReadWholeFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return NotFoundError(path + ": no such file");
  if (std::filesystem::is_directory(path, ec)) {
    return InvalidArgumentError(path + ": is a directory, not a file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return UnavailableError(path + ": cannot open: " + std::strerror(errno));
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return UnavailableError(path + ": read failed");
  return content;
}

std::vector<TextLine> SplitLines(std::string_view content) {
  std::vector<TextLine> lines;
  int number = 0;
  while (!content.empty()) {
    const size_t end = content.find('\n');
    const std::string_view line = content.substr(0, end);
    lines.push_back({++number, Trim(line)});
    if (end == std::string_view::npos) break;
    content.remove_prefix(end + 1);
  }
  return lines;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && IsBlank(s.front())) s.remove_prefix(1);
  while (!s.empty() && IsBlank(s.back())) s.remove_suffix(1);
  return s;
}

std::string_view StripComment(std::string_view s) {
  const size_t hash = s.find('#');
  return hash == std::string_view::npos ? s : s.substr(0, hash);
}

std::vector<std::string_view> SplitFields(std::string_view s) {
  std::vector<std::string_view> fields;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (IsBlank(s[i]) || s[i] == ',')) ++i;
    const size_t start = i;
    while (i < s.size() && !IsBlank(s[i]) && s[i] != ',') ++i;
    if (i > start) fields.push_back(s.substr(start, i - start));
  }
  return fields;
}

bool ParseDouble(std::string_view token, double* value) {
  token = SkipPlus(token);
  if (token.empty()) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return ec == std::errc() && end == token.data() + token.size();
}

bool ParseInt(std::string_view token, int* value) {
  token = SkipPlus(token);
  if (token.empty()) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return ec == std::errc() && end == token.data() + token.size();
}

bool ParseStamp(std::string_view token, int64_t* stamp_ns) {
  // Range check first: ParseStampSeconds assumes the value fits int64 nanoseconds
  // (about +-9.2e9 s) and would overflow on longer digit strings.
  double approx = 0;
  if (!ParseDouble(token, &approx) || !std::isfinite(approx) || std::abs(approx) > 9.0e9) {
    return false;
  }
  return ParseStampSeconds(std::string(SkipPlus(token)), stamp_ns);
}

Status LineError(const std::string& path, int line, std::string_view what) {
  return InvalidArgumentError(path + ":" + std::to_string(line) + ": " + std::string(what));
}

}  // namespace semmap::datasets_internal
