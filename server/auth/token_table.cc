#include "server/auth/token_table.h"

#include <algorithm>
#include <sstream>

#include "common/name_validation.h"

namespace semmap {
namespace {

bool ConstantTimeEqual(const Sha256Digest& a, const Sha256Digest& b) {
  uint8_t difference = 0;
  for (size_t i = 0; i < a.size(); ++i) difference |= static_cast<uint8_t>(a[i] ^ b[i]);
  return difference == 0;
}

StatusOr<Role> ParseRole(const std::string& word) {
  if (word == "read") return Role::kRead;
  if (word == "write") return Role::kWrite;
  if (word == "admin") return Role::kAdmin;
  return InvalidArgumentError("role must be read, write or admin (got '" + word + "')");
}

bool TokenCharacters(const std::string& token) {
  return std::all_of(token.begin(), token.end(), [](char c) { return c > ' ' && c < 127; });
}

}  // namespace

std::string_view RoleName(Role role) {
  switch (role) {
    case Role::kRead:
      return "read";
    case Role::kWrite:
      return "write";
    case Role::kAdmin:
      return "admin";
  }
  return "unknown";
}

bool TokenGrant::CoversMap(const std::string& map) const {
  return maps.empty() || std::find(maps.begin(), maps.end(), map) != maps.end();
}

StatusOr<TokenTable> TokenTable::Parse(std::string_view text) {
  TokenTable table;
  std::istringstream lines{std::string(text)};
  std::string line;
  int number = 0;
  while (std::getline(lines, line)) {
    ++number;
    const std::string where = "line " + std::to_string(number) + ": ";
    if (line.find('\0') != std::string::npos) return InvalidArgumentError(where + "NUL byte");
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::string token, role_word;
    if (!(words >> token)) continue;  // blank or comment
    if (token.size() < kMinTokenLength || !TokenCharacters(token)) {
      return InvalidArgumentError(where + "a token needs at least " +
                                  std::to_string(kMinTokenLength) +
                                  " printable ASCII characters without spaces");
    }
    if (!(words >> role_word)) return InvalidArgumentError(where + "token without a role");
    Entry entry;
    StatusOr<Role> role = ParseRole(role_word);
    if (!role.ok()) return role.status().WithContext(where.substr(0, where.size() - 2));
    entry.grant.role = *role;
    for (std::string map; words >> map;) {
      SEMMAP_RETURN_IF_ERROR(
          ValidateName("map", map).WithContext(where.substr(0, where.size() - 2)));
      entry.grant.maps.push_back(map);
    }
    entry.digest = Sha256(token);
    for (const Entry& other : table.entries_) {
      if (ConstantTimeEqual(other.digest, entry.digest)) {
        return InvalidArgumentError(where + "this token is already given on an earlier line");
      }
    }
    table.entries_.push_back(std::move(entry));
  }
  if (table.entries_.empty()) return InvalidArgumentError("no token in it");
  return table;
}

const TokenGrant* TokenTable::Find(std::string_view token) const {
  const Sha256Digest digest = Sha256(token);
  const TokenGrant* found = nullptr;
  for (const Entry& entry : entries_) {
    if (ConstantTimeEqual(entry.digest, digest)) found = &entry.grant;
  }
  return found;
}

}  // namespace semmap
