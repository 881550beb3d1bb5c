// Small, exception-free text helpers shared by the dataset and trajectory parsers.
// Internal to semmap_datasets: numbers parse with std::from_chars, so they never throw and
// never depend on the process locale (a German locale must not turn "1.5" into 1).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace semmap::datasets_internal {

// One line of a text file with its 1-based line number, '\r' and surrounding blanks removed.
struct TextLine {
  int number = 0;
  std::string_view text;
};

// Reads a whole (small) file. NOT_FOUND when it does not exist, UNAVAILABLE when unreadable.
StatusOr<std::string> ReadWholeFile(const std::string& path);

// Splits `content` into trimmed lines, keeping empty ones so numbering stays right.
std::vector<TextLine> SplitLines(std::string_view content);

std::string_view Trim(std::string_view s);
// Drops everything from the first '#'.
std::string_view StripComment(std::string_view s);
// Splits on runs of blanks and commas ("1, 2 3" -> {"1", "2", "3"}).
std::vector<std::string_view> SplitFields(std::string_view s);

// The whole token must be a number; a leading '+' is allowed.
bool ParseDouble(std::string_view token, double* value);
bool ParseInt(std::string_view token, int* value);
// Seconds ("1341841873.273798" exactly, or "1.038752e-01") to nanoseconds; rejects values that
// do not fit int64 nanoseconds instead of overflowing.
bool ParseStamp(std::string_view token, int64_t* stamp_ns);

// "<path>:<line>: <what>" as INVALID_ARGUMENT.
Status LineError(const std::string& path, int line, std::string_view what);

}  // namespace semmap::datasets_internal
