// Who may call what (semmapd --auth-tokens): the bearer token of a call against the table of
// tokens, re-read on demand (SIGHUP) without dropping the old table when the new file is bad.
// Without a tokens file every call is allowed (loopback or TLS is then the only guard).
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "common/status.h"
#include "server/auth/token_table.h"

namespace semmap {

class Authorizer {
 public:
  // Reads `path` (INVALID_ARGUMENT naming it and the line when it does not parse).
  static StatusOr<std::unique_ptr<Authorizer>> Load(const std::string& path);

  // Re-reads the file; a file that no longer parses keeps the tokens in force and says why.
  Status Reload();

  // The grant of the call's token. `authorization`: its "authorization" metadata ("Bearer
  // <token>"). UNAUTHENTICATED when that is missing, malformed or names no known token;
  // PERMISSION_DENIED when the token's role is below `needed` or it does not cover `*map`
  // (empty: a call over every map, which needs a token for every map; null: not checked, the
  // caller restricts what it answers to grant.maps). Never says or logs the token.
  StatusOr<TokenGrant> Check(std::string_view authorization, Role needed,
                             const std::string* map) const;

  size_t num_tokens() const;

 private:
  explicit Authorizer(std::string path) : path_(std::move(path)) {}

  const std::string path_;
  mutable std::mutex mutex_;
  std::shared_ptr<const TokenTable> table_;  // guarded by mutex_; replaced whole on Reload
};

}  // namespace semmap
