// The bearer tokens semmapd accepts (--auth-tokens FILE) and what each may do. One token a
// line: `token role [map ...]`; roles read (queries, exports) < write (+ ingest, object
// registration) < admin (+ removals); no maps: every map. Blank lines and '#' comments are
// skipped. Tokens are kept only as SHA-256 digests and looked up in constant time.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/sha256.h"
#include "common/status.h"

namespace semmap {

enum class Role { kRead = 0, kWrite = 1, kAdmin = 2 };

std::string_view RoleName(Role role);

struct TokenGrant {
  Role role = Role::kRead;
  std::vector<std::string> maps;  // empty: every map

  bool CoversMap(const std::string& map) const;
  bool CoversEveryMap() const { return maps.empty(); }
};

class TokenTable {
 public:
  // INVALID_ARGUMENT "line N: ..." (never quoting a token) for an unknown role, a token shorter
  // than kMinTokenLength or with characters outside printable ASCII, a bad map name, a token
  // given twice, or no token at all.
  static StatusOr<TokenTable> Parse(std::string_view text);

  // The grant of `token`, null when unknown. Every entry is compared, each in constant time,
  // so the time taken says nothing about which bytes matched.
  const TokenGrant* Find(std::string_view token) const;
  size_t size() const { return entries_.size(); }

  static constexpr size_t kMinTokenLength = 16;

 private:
  struct Entry {
    Sha256Digest digest;
    TokenGrant grant;
  };
  std::vector<Entry> entries_;
};

}  // namespace semmap
