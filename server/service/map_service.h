// semmap.v1.MapService on gRPC's callback API: one small handler per RPC over the ingest
// manager and the query interface.
#pragma once

#include "common/map_query.h"
#include "semmap/v1/service.grpc.pb.h"
#include "server/ingest/ingest_manager.h"
#include "server/objects/object_catalog.h"

namespace semmap {

// Every method on the callback API; Ingest raw (byte buffers) so that a message that does not
// parse is an error the stream reports, not a silent half-close (see IngestReactor).
using MapServiceBase = v1::MapService::WithRawCallbackMethod_Ingest<
    v1::MapService::WithCallbackMethod_ListMaps<v1::MapService::WithCallbackMethod_ListSessions<
        v1::MapService::WithCallbackMethod_GetTrajectory<
            v1::MapService::WithCallbackMethod_ExportMap<
                v1::MapService::WithCallbackMethod_RegisterObject<
                    v1::MapService::WithCallbackMethod_ListObjects<
                        v1::MapService::WithCallbackMethod_RemoveObject<
                            v1::MapService::WithCallbackMethod_FindObjects<
                                v1::MapService::WithCallbackMethod_ObjectsNear<
                                    v1::MapService::WithCallbackMethod_RemoveSession<
                                        v1::MapService::WithCallbackMethod_RemoveMap<
                                            v1::MapService::Service>>>>>>>>>>>>;

class MapServiceImpl final : public MapServiceBase {
 public:
  MapServiceImpl(IngestManager* ingest, MapQueryInterface* query, ObjectCatalog* objects)
      : ingest_(ingest), query_(query), objects_(objects) {}

  grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* Ingest(
      grpc::CallbackServerContext* context) override;
  grpc::ServerUnaryReactor* ListMaps(grpc::CallbackServerContext* context,
                                     const v1::ListMapsRequest* request,
                                     v1::ListMapsResponse* response) override;
  grpc::ServerUnaryReactor* ListSessions(grpc::CallbackServerContext* context,
                                         const v1::ListSessionsRequest* request,
                                         v1::ListSessionsResponse* response) override;
  grpc::ServerWriteReactor<v1::GetTrajectoryResponse>* GetTrajectory(
      grpc::CallbackServerContext* context, const v1::GetTrajectoryRequest* request) override;
  grpc::ServerWriteReactor<v1::ExportMapResponse>* ExportMap(
      grpc::CallbackServerContext* context, const v1::ExportMapRequest* request) override;
  grpc::ServerUnaryReactor* RegisterObject(grpc::CallbackServerContext* context,
                                           const v1::RegisterObjectRequest* request,
                                           v1::RegisterObjectResponse* response) override;
  grpc::ServerUnaryReactor* ListObjects(grpc::CallbackServerContext* context,
                                        const v1::ListObjectsRequest* request,
                                        v1::ListObjectsResponse* response) override;
  grpc::ServerUnaryReactor* RemoveObject(grpc::CallbackServerContext* context,
                                         const v1::RemoveObjectRequest* request,
                                         v1::RemoveObjectResponse* response) override;
  grpc::ServerUnaryReactor* FindObjects(grpc::CallbackServerContext* context,
                                        const v1::FindObjectsRequest* request,
                                        v1::FindObjectsResponse* response) override;
  grpc::ServerUnaryReactor* ObjectsNear(grpc::CallbackServerContext* context,
                                        const v1::ObjectsNearRequest* request,
                                        v1::ObjectsNearResponse* response) override;
  grpc::ServerUnaryReactor* RemoveSession(grpc::CallbackServerContext* context,
                                          const v1::RemoveSessionRequest* request,
                                          v1::RemoveSessionResponse* response) override;
  grpc::ServerUnaryReactor* RemoveMap(grpc::CallbackServerContext* context,
                                      const v1::RemoveMapRequest* request,
                                      v1::RemoveMapResponse* response) override;

 private:
  IngestManager* ingest_;
  MapQueryInterface* query_;
  ObjectCatalog* objects_;
};

}  // namespace semmap
