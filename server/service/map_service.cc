#include "server/service/map_service.h"

#include <algorithm>
#include <chrono>

#include "rpc/conversions.h"
#include "rpc/object_conversions.h"
#include "server/service/ingest_reactor.h"
#include "server/service/message_stream_reactor.h"
#include "server/service/request_conversions.h"

namespace semmap {
namespace {

constexpr size_t kPosesPerChunk = 512;
constexpr size_t kExportChunkBytes = 1u << 20;  // 1 MiB

grpc::ServerUnaryReactor* FinishUnary(grpc::CallbackServerContext* context, const Status& status) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  reactor->Finish(ToGrpcStatus(status));
  return reactor;
}

// Asked right before a mutation commits: a call the client has given up on takes no effect.
// (One that commits in its last microseconds may still be reported DEADLINE_EXCEEDED by gRPC;
// repeating it then answers ALREADY_EXISTS or NOT_FOUND.)
CancelCheck ClientStillWaiting(grpc::CallbackServerContext* context) {
  return [context]() -> Status {
    if (context->IsCancelled()) {
      return CancelledError("the call was cancelled before it took effect; nothing was changed");
    }
    if (context->deadline() <= std::chrono::system_clock::now()) {
      return DeadlineExceededError(
          "the call's deadline passed before it took effect; nothing was changed");
    }
    return OkStatus();
  };
}

}  // namespace

grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* MapServiceImpl::Ingest(
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
  const ExportRequest export_request = FromProto(*request);
  StatusOr<ExportResult> result = query_->ExportMap(export_request);
  if (!result.ok()) return new Reactor(ToGrpcStatus(result.status()));
  std::vector<v1::ExportMapResponse> messages;
  v1::ExportHeader* header = messages.emplace_back().mutable_header();
  header->set_format(result->format);
  header->set_media_type(result->media_type);
  header->set_total_bytes(result->bytes.size());
  header->mutable_layer_origin()->set_x(result->layer_origin.x());
  header->mutable_layer_origin()->set_y(result->layer_origin.y());
  header->mutable_layer_origin()->set_z(result->layer_origin.z());
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
  StatusOr<RegisterObjectInput> input = FromProto(*request);
  if (!input.ok()) return FinishUnary(context, input.status());
  StatusOr<ObjectType> type = objects_->Register(*input, ClientStillWaiting(context));
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
  return FinishUnary(
      context, objects_->Remove(request->label(), request->map(), ClientStillWaiting(context)));
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
  const NearQuery near = FromProto(*request);
  StatusOr<std::vector<ObjectInstance>> found =
      query_->ObjectsNear(near.map, near.point, near.radius_m, near.label);
  if (found.ok()) {
    for (const ObjectInstance& o : *found) ToProto(o, response->add_objects());
  }
  return FinishUnary(context, found.status());
}

grpc::ServerUnaryReactor* MapServiceImpl::RemoveSession(grpc::CallbackServerContext* context,
                                                        const v1::RemoveSessionRequest* request,
                                                        v1::RemoveSessionResponse* response) {
  if (request->map().empty() || request->session().empty()) {
    return FinishUnary(context, InvalidArgumentError("RemoveSession needs a map and a session"));
  }
  StatusOr<RemovedCounts> removed =
      ingest_->RemoveSession(request->map(), request->session(), ClientStillWaiting(context));
  if (removed.ok()) {
    response->set_frames(static_cast<uint64_t>(removed->frames));
    response->set_keyframes(static_cast<uint64_t>(removed->keyframes));
  }
  return FinishUnary(context, removed.status());
}

grpc::ServerUnaryReactor* MapServiceImpl::RemoveMap(grpc::CallbackServerContext* context,
                                                    const v1::RemoveMapRequest* request,
                                                    v1::RemoveMapResponse* response) {
  if (request->map().empty()) {
    return FinishUnary(context, InvalidArgumentError("RemoveMap needs a map"));
  }
  StatusOr<RemovedCounts> removed = ingest_->RemoveMap(request->map(), ClientStillWaiting(context));
  if (removed.ok()) {
    objects_->ForgetMap(removed->map_id);
    response->set_sessions(static_cast<uint64_t>(removed->sessions));
    response->set_frames(static_cast<uint64_t>(removed->frames));
    response->set_keyframes(static_cast<uint64_t>(removed->keyframes));
  }
  return FinishUnary(context, removed.status());
}

}  // namespace semmap
