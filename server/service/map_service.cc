#include "server/service/map_service.h"

#include <algorithm>

#include "rpc/conversions.h"
#include "rpc/object_conversions.h"
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
  ExportRequest export_request;
  export_request.map = request->map();
  export_request.format = request->format();
  export_request.session = request->session();
  export_request.ascii = request->ascii();
  export_request.voxel_m = request->voxel();
  export_request.view = request->view();
  export_request.width_px = static_cast<int>(std::min<uint32_t>(request->width(), 1u << 20));
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

grpc::ServerUnaryReactor* MapServiceImpl::RegisterObject(grpc::CallbackServerContext* context,
                                                         const v1::RegisterObjectRequest* request,
                                                         v1::RegisterObjectResponse* response) {
  RegisterObjectInput input;
  input.label = request->label();
  input.map = request->map();
  for (const v1::CompressedImage& photo : request->photos()) {
    input.photos.push_back({photo.format(), photo.data()});
  }
  if (request->has_colour()) {
    const v1::Colour& c = request->colour();
    if (c.r() > 255 || c.g() > 255 || c.b() > 255) {
      return FinishUnary(context, InvalidArgumentError("colour channels must be 0..255"));
    }
    input.rgb = FromProto(c);
  }
  StatusOr<ObjectType> type = objects_->Register(input);
  if (type.ok()) ToProto(*type, response->mutable_object());
  return FinishUnary(context, type.status());
}

grpc::ServerUnaryReactor* MapServiceImpl::ListObjects(grpc::CallbackServerContext* context,
                                                      const v1::ListObjectsRequest* request,
                                                      v1::ListObjectsResponse* response) {
  StatusOr<std::vector<ObjectType>> types = query_->ListObjectTypes(request->map());
  if (types.ok()) {
    for (const ObjectType& t : *types) ToProto(t, response->add_objects());
  }
  return FinishUnary(context, types.status());
}

grpc::ServerUnaryReactor* MapServiceImpl::RemoveObject(grpc::CallbackServerContext* context,
                                                       const v1::RemoveObjectRequest* request,
                                                       v1::RemoveObjectResponse*) {
  return FinishUnary(context, objects_->Remove(request->label(), request->map()));
}

grpc::ServerUnaryReactor* MapServiceImpl::FindObjects(grpc::CallbackServerContext* context,
                                                      const v1::FindObjectsRequest* request,
                                                      v1::FindObjectsResponse* response) {
  StatusOr<std::vector<ObjectInstance>> found =
      query_->FindObjects(request->label(), request->map());
  if (found.ok()) {
    for (const ObjectInstance& o : *found) ToProto(o, response->add_objects());
  }
  return FinishUnary(context, found.status());
}

grpc::ServerUnaryReactor* MapServiceImpl::ObjectsNear(grpc::CallbackServerContext* context,
                                                      const v1::ObjectsNearRequest* request,
                                                      v1::ObjectsNearResponse* response) {
  StatusOr<std::vector<ObjectInstance>> found = query_->ObjectsNear(
      request->map(), FromProto(request->point()), request->radius(), request->label());
  if (found.ok()) {
    for (const ObjectInstance& o : *found) ToProto(o, response->add_objects());
  }
  return FinishUnary(context, found.status());
}

}  // namespace semmap
