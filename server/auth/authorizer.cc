#include "server/auth/authorizer.h"

#include <fstream>
#include <sstream>

namespace semmap {
namespace {

StatusOr<std::shared_ptr<const TokenTable>> ReadTable(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return InvalidArgumentError("--auth-tokens " + path + ": cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  StatusOr<TokenTable> table = TokenTable::Parse(text.str());
  if (!table.ok()) return table.status().WithContext("--auth-tokens " + path);
  return std::make_shared<const TokenTable>(std::move(table).value());
}

}  // namespace

StatusOr<std::unique_ptr<Authorizer>> Authorizer::Load(const std::string& path) {
  std::unique_ptr<Authorizer> authorizer(new Authorizer(path));
  SEMMAP_RETURN_IF_ERROR(authorizer->Reload());
  return authorizer;
}

Status Authorizer::Reload() {
  SEMMAP_ASSIGN_OR_RETURN(std::shared_ptr<const TokenTable> table, ReadTable(path_));
  std::lock_guard lock(mutex_);
  table_ = std::move(table);
  return OkStatus();
}

size_t Authorizer::num_tokens() const {
  std::lock_guard lock(mutex_);
  return table_ ? table_->size() : 0;
}

StatusOr<TokenGrant> Authorizer::Check(std::string_view authorization, Role needed,
                                       const std::string* map) const {
  constexpr std::string_view kBearer = "Bearer ";
  if (authorization.empty()) {
    return UnauthenticatedError("this server needs a token: authorization: Bearer <token>");
  }
  if (authorization.substr(0, kBearer.size()) != kBearer) {
    return UnauthenticatedError("the authorization metadata must be 'Bearer <token>'");
  }
  std::shared_ptr<const TokenTable> table;
  {
    std::lock_guard lock(mutex_);
    table = table_;
  }
  const TokenGrant* grant = table ? table->Find(authorization.substr(kBearer.size())) : nullptr;
  if (grant == nullptr) return UnauthenticatedError("the token is not known to this server");
  if (grant->role < needed) {
    return PermissionDeniedError("this needs a " + std::string(RoleName(needed)) +
                                 " token; the one given is " + std::string(RoleName(grant->role)));
  }
  if (map != nullptr && (map->empty() ? !grant->CoversEveryMap() : !grant->CoversMap(*map))) {
    return PermissionDeniedError(map->empty() ? "the token is limited to some maps: name one"
                                              : "the token does not cover map '" + *map + "'");
  }
  return *grant;
}

}  // namespace semmap
