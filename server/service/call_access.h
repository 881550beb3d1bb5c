// Who may call what under --auth-tokens: the role each call needs and the map it touches.
// read: queries and exports; write: + ingest and object registration; admin: + removals.
#pragma once

#include <grpcpp/grpcpp.h>

#include <string>

#include "semmap/v1/objects.pb.h"
#include "semmap/v1/service.pb.h"
#include "server/auth/token_table.h"

namespace semmap {

struct CallAccess {
  Role role = Role::kAdmin;
  // The map the call reads or changes (empty: every map); null: the call names none and its
  // answer is restricted to the token's maps instead (RestrictToGrant).
  const std::string* map = nullptr;
};

inline CallAccess AccessFor(const v1::ListMapsRequest&) { return {Role::kRead, nullptr}; }
inline CallAccess AccessFor(const v1::ListSessionsRequest& r) { return {Role::kRead, &r.map()}; }
inline CallAccess AccessFor(const v1::GetTrajectoryRequest& r) { return {Role::kRead, &r.map()}; }
inline CallAccess AccessFor(const v1::ExportMapRequest& r) { return {Role::kRead, &r.map()}; }
inline CallAccess AccessFor(const v1::ListObjectsRequest& r) { return {Role::kRead, &r.map()}; }
inline CallAccess AccessFor(const v1::FindObjectsRequest& r) { return {Role::kRead, &r.map()}; }
inline CallAccess AccessFor(const v1::ObjectsNearRequest& r) { return {Role::kRead, &r.map()}; }
inline CallAccess AccessFor(const v1::RegisterObjectRequest& r) { return {Role::kWrite, &r.map()}; }
inline CallAccess AccessFor(const v1::RemoveObjectRequest& r) { return {Role::kAdmin, &r.map()}; }
inline CallAccess AccessFor(const v1::RemoveSessionRequest& r) { return {Role::kAdmin, &r.map()}; }
inline CallAccess AccessFor(const v1::RemoveMapRequest& r) { return {Role::kAdmin, &r.map()}; }
// Ingest needs Role::kWrite and the map of its start message (IngestReactor).

// Answers of calls that name no map, cut down to the maps the token covers.
template <typename Response>
void RestrictToGrant(const TokenGrant&, Response*) {}
inline void RestrictToGrant(const TokenGrant& grant, v1::ListMapsResponse* response) {
  auto* maps = response->mutable_maps();
  for (int i = maps->size() - 1; i >= 0; --i) {
    if (!grant.CoversMap(maps->Get(i).name())) maps->DeleteSubrange(i, 1);
  }
}

// The call's "authorization" metadata, empty when absent.
inline std::string AuthorizationOf(const grpc::CallbackServerContext& context) {
  const auto& metadata = context.client_metadata();
  const auto it = metadata.find("authorization");
  return it == metadata.end() ? std::string() : std::string(it->second.data(), it->second.size());
}

}  // namespace semmap
