#include "server/service/map_service.h"

#include "rpc/conversions.h"
#include "server/service/ingest_reactor.h"
#include "server/service/message_stream_reactor.h"

namespace semmap {
namespace {

constexpr size_t kPosesPerChunk = 512;
constexpr size_t kExportChunkBytes = 1u << 20;  // 1 MiB

grpc::ServerUnaryReactor* FinishUnary(grpc::CallbackServerContext* context, const Status& status) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  reactor->Finish(ToGrpcStatus(status));
  return reactor;
}

}  // namespace

grpc::ServerBidiReactor<v1::IngestRequest, v1::IngestResponse>* MapServiceImpl::Ingest(
    grpc::CallbackServerContext* context) {
  return new IngestReactor(context, ingest_);
}

grpc::ServerUnaryReactor* MapServiceImpl::ListMaps(grpc::CallbackServerContext* context,
                                                   const v1::ListMapsRequest*,
                                                   v1::ListMapsResponse* response) {
  StatusOr<std::vector<MapInfo>> maps = query_->ListMaps();
  if (maps.ok()) {
    for (const MapInfo& map : *maps) ToProto(map, response->add_maps());
  }
  return FinishUnary(context, maps.status());
}

grpc::ServerUnaryReactor* MapServiceImpl::ListSessions(grpc::CallbackServerContext* context,
                                                       const v1::ListSessionsRequest* request,
                                                       v1::ListSessionsResponse* response) {
  StatusOr<std::vector<SessionInfo>> sessions = query_->ListSessions(request->map());
  if (sessions.ok()) {
    for (const SessionInfo& s : *sessions) ToProto(s, response->add_sessions());
  }
  return FinishUnary(context, sessions.status());
}

grpc::ServerWriteReactor<v1::GetTrajectoryResponse>* MapServiceImpl::GetTrajectory(
    grpc::CallbackServerContext*, const v1::GetTrajectoryRequest* request) {
  using Reactor = MessageStreamReactor<v1::GetTrajectoryResponse>;
  StatusOr<std::vector<TrajectoryPose>> poses =
      query_->GetTrajectory(request->map(), request->session(), request->keyframes_only());
  if (!poses.ok()) return new Reactor(ToGrpcStatus(poses.status()));
  std::vector<v1::GetTrajectoryResponse> chunks;
  for (size_t i = 0; i < poses->size(); ++i) {
    if (i % kPosesPerChunk == 0) chunks.emplace_back();
    ToProto((*poses)[i], chunks.back().add_poses());
  }
  return new Reactor(std::move(chunks));
}

grpc::ServerWriteReactor<v1::ExportMapResponse>* MapServiceImpl::ExportMap(
    grpc::CallbackServerContext*, const v1::ExportMapRequest* request) {
  using Reactor = MessageStreamReactor<v1::ExportMapResponse>;
  ExportRequest export_request{request->map(), request->format(), request->session()};
  StatusOr<ExportResult> result = query_->ExportMap(export_request);
  if (!result.ok()) return new Reactor(ToGrpcStatus(result.status()));
  std::vector<v1::ExportMapResponse> messages;
  v1::ExportHeader* header = messages.emplace_back().mutable_header();
  header->set_format(result->format);
  header->set_media_type(result->media_type);
  header->set_total_bytes(result->bytes.size());
  for (size_t offset = 0; offset < result->bytes.size(); offset += kExportChunkBytes) {
    messages.emplace_back().set_chunk(result->bytes.substr(offset, kExportChunkBytes));
  }
  v1::ExportTrailer* trailer = messages.emplace_back().mutable_trailer();
  trailer->set_sha256(result->sha256_hex);
  trailer->set_total_bytes(result->bytes.size());
  return new Reactor(std::move(messages));
}

}  // namespace semmap
