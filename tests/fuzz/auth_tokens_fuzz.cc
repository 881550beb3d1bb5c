// The --auth-tokens file (server/auth/token_table). What parses has at least one token; every
// token found by a line's first word resolves to a grant whose maps are valid names.
#include <cstdint>
#include <sstream>
#include <string>

#include "common/name_validation.h"
#include "server/auth/token_table.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text = semmap::fuzz::AsText(data, size);
  semmap::StatusOr<semmap::TokenTable> table = semmap::TokenTable::Parse(text);
  if (!table.ok()) {
    FUZZ_CHECK(table.status().code() == semmap::StatusCode::kInvalidArgument);
    return 0;
  }
  FUZZ_CHECK(table->size() > 0);
  std::istringstream lines{std::string(text)};
  for (std::string line; std::getline(lines, line);) {
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::string token;
    if (!(words >> token)) continue;
    const semmap::TokenGrant* grant = table->Find(token);
    FUZZ_CHECK(grant != nullptr);
    for (const std::string& map : grant->maps) FUZZ_CHECK(semmap::ValidateName("map", map).ok());
  }
  return 0;
}
