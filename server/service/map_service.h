// semmap.v1.MapService on gRPC's callback API: one small handler per RPC over the ingest
// manager and the query interface.
//
// Every method is registered raw (byte buffers) and parses its request itself
// (wire_parsing.h): gRPC's own parsing answers a unary request that does not parse with
// UNIMPLEMENTED and no message, and takes a stream message that does not parse for the client's
// half-close. Here both are INVALID_ARGUMENT naming the message.
//
// Every unary and server-streaming call is answered on a WorkerPool: the gRPC callback only
// authorises and parses, so a slow export or registration never holds a gRPC thread. A call
// cancelled (or past its deadline) while it waits for a worker is answered without doing work;
// an export asks the same check as it goes and stops.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <optional>
#include <vector>

#include "common/map_query.h"
#include "common/rate_window.h"
#include "common/worker_pool.h"
#include "core/objects/object_catalog.h"
#include "core/pipeline/ingest_manager.h"
#include "semmap/v1/service.grpc.pb.h"
#include "server/auth/authorizer.h"
#include "server/service/call_access.h"
#include "server/service/call_limits.h"

namespace semmap {

using MapServiceBase =
    v1::MapService::WithRawCallbackMethod_Ingest<v1::MapService::WithRawCallbackMethod_ListMaps<
        v1::MapService::WithRawCallbackMethod_ListSessions<
            v1::MapService::WithRawCallbackMethod_GetTrajectory<
                v1::MapService::WithRawCallbackMethod_ExportMap<
                    v1::MapService::WithRawCallbackMethod_RegisterObject<
                        v1::MapService::WithRawCallbackMethod_ListObjects<
                            v1::MapService::WithRawCallbackMethod_RemoveObject<
                                v1::MapService::WithRawCallbackMethod_FindObjects<
                                    v1::MapService::WithRawCallbackMethod_ObjectsNear<
                                        v1::MapService::WithRawCallbackMethod_RemoveSession<
                                            v1::MapService::WithRawCallbackMethod_RemoveMap<
                                                v1::MapService::Service>>>>>>>>>>>>;

class MapServiceImpl final : public MapServiceBase {
 public:
  // `authorizer`: null serves every call (no --auth-tokens). `workers`: null answers on the
  // gRPC callback thread.
  MapServiceImpl(IngestManager* ingest, MapQueryInterface* query, ObjectCatalog* objects,
                 const Authorizer* authorizer = nullptr, WorkerPool* workers = nullptr,
                 CallLimits limits = {})
      : ingest_(ingest),
        query_(query),
        objects_(objects),
        authorizer_(authorizer),
        workers_(workers),
        limits_(limits),
        registrations_(limits.max_registrations_per_minute, std::chrono::minutes(1)) {}

  using Raw = grpc::ByteBuffer;
  grpc::ServerBidiReactor<Raw, Raw>* Ingest(grpc::CallbackServerContext* context) override;
  grpc::ServerUnaryReactor* ListMaps(grpc::CallbackServerContext* c, const Raw* in,
                                     Raw* out) override;
  grpc::ServerUnaryReactor* ListSessions(grpc::CallbackServerContext* c, const Raw* in,
                                         Raw* out) override;
  grpc::ServerWriteReactor<Raw>* GetTrajectory(grpc::CallbackServerContext* c,
                                               const Raw* in) override;
  grpc::ServerWriteReactor<Raw>* ExportMap(grpc::CallbackServerContext* c, const Raw* in) override;
  grpc::ServerUnaryReactor* RegisterObject(grpc::CallbackServerContext* c, const Raw* in,
                                           Raw* out) override;
  grpc::ServerUnaryReactor* ListObjects(grpc::CallbackServerContext* c, const Raw* in,
                                        Raw* out) override;
  grpc::ServerUnaryReactor* RemoveObject(grpc::CallbackServerContext* c, const Raw* in,
                                         Raw* out) override;
  grpc::ServerUnaryReactor* FindObjects(grpc::CallbackServerContext* c, const Raw* in,
                                        Raw* out) override;
  grpc::ServerUnaryReactor* ObjectsNear(grpc::CallbackServerContext* c, const Raw* in,
                                        Raw* out) override;
  grpc::ServerUnaryReactor* RemoveSession(grpc::CallbackServerContext* c, const Raw* in,
                                          Raw* out) override;
  grpc::ServerUnaryReactor* RemoveMap(grpc::CallbackServerContext* c, const Raw* in,
                                      Raw* out) override;

 private:
  // The handlers, one per request type; Unary / Stream parse, call them and serialise.
  Status Answer(grpc::CallbackServerContext* c, const v1::ListMapsRequest& in,
                v1::ListMapsResponse* out);
  Status Answer(grpc::CallbackServerContext* c, const v1::ListSessionsRequest& in,
                v1::ListSessionsResponse* out);
  StatusOr<std::vector<v1::GetTrajectoryResponse>> Answer(grpc::CallbackServerContext* c,
                                                          const v1::GetTrajectoryRequest& in);
  StatusOr<std::vector<v1::ExportMapResponse>> Answer(grpc::CallbackServerContext* c,
                                                      const v1::ExportMapRequest& in);
  Status Answer(grpc::CallbackServerContext* c, const v1::RegisterObjectRequest& in,
                v1::RegisterObjectResponse* out);
  Status Answer(grpc::CallbackServerContext* c, const v1::ListObjectsRequest& in,
                v1::ListObjectsResponse* out);
  Status Answer(grpc::CallbackServerContext* c, const v1::RemoveObjectRequest& in,
                v1::RemoveObjectResponse* out);
  Status Answer(grpc::CallbackServerContext* c, const v1::FindObjectsRequest& in,
                v1::FindObjectsResponse* out);
  Status Answer(grpc::CallbackServerContext* c, const v1::ObjectsNearRequest& in,
                v1::ObjectsNearResponse* out);
  Status Answer(grpc::CallbackServerContext* c, const v1::RemoveSessionRequest& in,
                v1::RemoveSessionResponse* out);
  Status Answer(grpc::CallbackServerContext* c, const v1::RemoveMapRequest& in,
                v1::RemoveMapResponse* out);

  template <typename Request, typename Response>
  grpc::ServerUnaryReactor* Unary(grpc::CallbackServerContext* context, const Raw* in, Raw* out);
  template <typename Request>
  grpc::ServerWriteReactor<Raw>* Stream(grpc::CallbackServerContext* context, const Raw* in);

  // OK without an authorizer; else the call's token checked against `access` (its grant in
  // *grant).
  Status Authorize(grpc::CallbackServerContext* context, const CallAccess& access,
                   std::optional<TokenGrant>* grant) const;

  // The per-call limits that apply before a call is queued (registrations per minute).
  template <typename Request>
  Status Admit(const Request& request);

  // On a worker (inline without a pool); RESOURCE_EXHAUSTED when the queue is full.
  Status RunOnWorker(std::function<void()> work);

  IngestManager* ingest_;
  MapQueryInterface* query_;
  ObjectCatalog* objects_;
  const Authorizer* authorizer_;
  WorkerPool* workers_;
  const CallLimits limits_;
  RateWindow registrations_;
  std::atomic<size_t> pending_exports_{0};
};

}  // namespace semmap
