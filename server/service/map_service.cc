#include "server/service/map_service.h"

#include <algorithm>
#include <chrono>
#include <string>
#include <type_traits>

#include "server/serialization/conversions.h"
#include "server/serialization/object_conversions.h"
#include "server/serialization/request_conversions.h"
#include "server/serialization/wire_parsing.h"
#include "server/service/call_access.h"
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

template <typename Request>
Status MapServiceImpl::Admit(const Request&) {
  if constexpr (std::is_same_v<Request, v1::RegisterObjectRequest>) {
    if (!registrations_.TryAcquire()) {
      return ResourceExhaustedError(
          "object registrations are limited to " + std::to_string(registrations_.max_events()) +
          " per minute on this server (--max-registrations-per-minute); retry in a minute");
    }
  }
  return OkStatus();
}

Status MapServiceImpl::RunOnWorker(std::function<void()> work) {
  if (workers_ == nullptr) {
    work();
    return OkStatus();
  }
  return workers_->Submit(std::move(work));
}

template <typename Request, typename Response>
grpc::ServerUnaryReactor* MapServiceImpl::Unary(grpc::CallbackServerContext* context, const Raw* in,
                                                Raw* out) {
  std::optional<TokenGrant> grant;
  // The token first (role only): a caller without one learns nothing, not even parse errors.
  Status status = Authorize(context, {AccessFor(Request{}).role, nullptr}, &grant);
  Request request;
  if (status.ok()) status = ParseWire(*in, &request, "the request");
  if (status.ok()) status = Authorize(context, AccessFor(request), &grant);
  if (status.ok()) status = Admit(request);
  if (!status.ok()) return FinishUnary(context, status);
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  const Status queued = RunOnWorker(
      [this, context, reactor, out, request = std::move(request), grant = std::move(grant)] {
        // A call given up on while it waited does no work.
        Status answered = ClientStillWaiting(context)();
        Response response;
        if (answered.ok()) answered = Answer(context, request, &response);
        if (answered.ok() && grant) RestrictToGrant(*grant, &response);
        if (answered.ok()) answered = SerializeWire(response, out);
        reactor->Finish(ToGrpcStatus(answered));
      });
  if (!queued.ok()) reactor->Finish(ToGrpcStatus(queued));
  return reactor;
}

template <typename Request>
grpc::ServerWriteReactor<grpc::ByteBuffer>* MapServiceImpl::Stream(
    grpc::CallbackServerContext* context, const Raw* in) {
  std::optional<TokenGrant> grant;
  Status checked = Authorize(context, {AccessFor(Request{}).role, nullptr}, &grant);
  if (!checked.ok()) return new MessageStreamReactor(ToGrpcStatus(checked));
  Request request;
  const Status parsed = ParseWire(*in, &request, "the request");
  if (!parsed.ok()) return new MessageStreamReactor(ToGrpcStatus(parsed));
  checked = Authorize(context, AccessFor(request), &grant);
  if (!checked.ok()) return new MessageStreamReactor(ToGrpcStatus(checked));
  // Exports hold a worker and a read connection for seconds: only a few at once, so queries
  // always find both.
  constexpr bool kExport = std::is_same_v<Request, v1::ExportMapRequest>;
  if (kExport && pending_exports_.fetch_add(1) >= limits_.max_pending_exports) {
    pending_exports_.fetch_sub(1);
    return new MessageStreamReactor(ToGrpcStatus(ResourceExhaustedError(
        std::to_string(limits_.max_pending_exports) +
        " exports are already running or waiting on this server (--max-pending-exports); retry "
        "when one has finished")));
  }
  auto* reactor = new MessageStreamReactor();
  const Status queued = RunOnWorker([this, context, reactor, request = std::move(request)] {
    auto messages = [&]() -> decltype(this->Answer(context, request)) {
      SEMMAP_RETURN_IF_ERROR(ClientStillWaiting(context)());
      return Answer(context, request);
    }();
    // Released before the client can see the answer, so its next export is admitted.
    if (kExport) pending_exports_.fetch_sub(1);
    if (messages.ok()) {
      reactor->Send(*messages);
    } else {
      reactor->Fail(ToGrpcStatus(messages.status()));
    }
  });
  if (!queued.ok()) {
    if (kExport) pending_exports_.fetch_sub(1);
    reactor->Fail(ToGrpcStatus(queued));
  }
  return reactor;
}

grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* MapServiceImpl::Ingest(
    grpc::CallbackServerContext* context) {
  return new IngestReactor(context, ingest_, authorizer_);
}

Status MapServiceImpl::Authorize(grpc::CallbackServerContext* context, const CallAccess& access,
                                 std::optional<TokenGrant>* grant) const {
  if (authorizer_ == nullptr) return OkStatus();
  SEMMAP_ASSIGN_OR_RETURN(*grant,
                          authorizer_->Check(AuthorizationOf(*context), access.role, access.map));
  return OkStatus();
}

#define SEMMAP_UNARY(Method)                                                             \
  grpc::ServerUnaryReactor* MapServiceImpl::Method(grpc::CallbackServerContext* context, \
                                                   const Raw* in, Raw* out) {            \
    return Unary<v1::Method##Request, v1::Method##Response>(context, in, out);           \
  }
SEMMAP_UNARY(ListMaps)
SEMMAP_UNARY(ListSessions)
SEMMAP_UNARY(RegisterObject)
SEMMAP_UNARY(ListObjects)
SEMMAP_UNARY(RemoveObject)
SEMMAP_UNARY(FindObjects)
SEMMAP_UNARY(ObjectsNear)
SEMMAP_UNARY(RemoveSession)
SEMMAP_UNARY(RemoveMap)
#undef SEMMAP_UNARY

grpc::ServerWriteReactor<grpc::ByteBuffer>* MapServiceImpl::GetTrajectory(
    grpc::CallbackServerContext* context, const Raw* in) {
  return Stream<v1::GetTrajectoryRequest>(context, in);
}

grpc::ServerWriteReactor<grpc::ByteBuffer>* MapServiceImpl::ExportMap(
    grpc::CallbackServerContext* context, const Raw* in) {
  return Stream<v1::ExportMapRequest>(context, in);
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext*, const v1::ListMapsRequest&,
                              v1::ListMapsResponse* response) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<MapInfo> maps, query_->ListMaps());
  for (const MapInfo& map : maps) ToProto(map, response->add_maps());
  return OkStatus();
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext*, const v1::ListSessionsRequest& request,
                              v1::ListSessionsResponse* response) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<SessionInfo> sessions, query_->ListSessions(request.map()));
  for (const SessionInfo& s : sessions) ToProto(s, response->add_sessions());
  return OkStatus();
}

StatusOr<std::vector<v1::GetTrajectoryResponse>> MapServiceImpl::Answer(
    grpc::CallbackServerContext*, const v1::GetTrajectoryRequest& request) {
  SEMMAP_ASSIGN_OR_RETURN(
      std::vector<TrajectoryPose> poses,
      query_->GetTrajectory(request.map(), request.session(), request.keyframes_only()));
  std::vector<v1::GetTrajectoryResponse> chunks;
  for (size_t i = 0; i < poses.size(); ++i) {
    if (i % kPosesPerChunk == 0) chunks.emplace_back();
    ToProto(poses[i], chunks.back().add_poses());
  }
  return chunks;
}

StatusOr<std::vector<v1::ExportMapResponse>> MapServiceImpl::Answer(
    grpc::CallbackServerContext* context, const v1::ExportMapRequest& request) {
  SEMMAP_ASSIGN_OR_RETURN(ExportResult result,
                          query_->ExportMap(FromProto(request), ClientStillWaiting(context)));
  std::vector<v1::ExportMapResponse> messages;
  v1::ExportHeader* header = messages.emplace_back().mutable_header();
  header->set_format(result.format);
  header->set_media_type(result.media_type);
  header->set_total_bytes(result.bytes.size());
  header->mutable_layer_origin()->set_x(result.layer_origin.x());
  header->mutable_layer_origin()->set_y(result.layer_origin.y());
  header->mutable_layer_origin()->set_z(result.layer_origin.z());
  for (size_t offset = 0; offset < result.bytes.size(); offset += kExportChunkBytes) {
    messages.emplace_back().set_chunk(result.bytes.substr(offset, kExportChunkBytes));
  }
  v1::ExportTrailer* trailer = messages.emplace_back().mutable_trailer();
  trailer->set_sha256(result.sha256_hex);
  trailer->set_total_bytes(result.bytes.size());
  return messages;
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext* context,
                              const v1::RegisterObjectRequest& request,
                              v1::RegisterObjectResponse* response) {
  SEMMAP_ASSIGN_OR_RETURN(RegisterObjectInput input, FromProto(request));
  SEMMAP_ASSIGN_OR_RETURN(ObjectType type, objects_->Register(input, ClientStillWaiting(context)));
  ToProto(type, response->mutable_object());
  return OkStatus();
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext*, const v1::ListObjectsRequest& request,
                              v1::ListObjectsResponse* response) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectType> types, query_->ListObjectTypes(request.map()));
  for (const ObjectType& t : types) ToProto(t, response->add_objects());
  return OkStatus();
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext* context,
                              const v1::RemoveObjectRequest& request, v1::RemoveObjectResponse*) {
  return objects_->Remove(request.label(), request.map(), ClientStillWaiting(context));
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext*, const v1::FindObjectsRequest& request,
                              v1::FindObjectsResponse* response) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectInstance> found,
                          query_->FindObjects(request.label(), request.map()));
  for (const ObjectInstance& o : found) ToProto(o, response->add_objects());
  return OkStatus();
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext*, const v1::ObjectsNearRequest& request,
                              v1::ObjectsNearResponse* response) {
  const NearQuery near = FromProto(request);
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectInstance> found,
                          query_->ObjectsNear(near.map, near.point, near.radius_m, near.label));
  for (const ObjectInstance& o : found) ToProto(o, response->add_objects());
  return OkStatus();
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext* context,
                              const v1::RemoveSessionRequest& request,
                              v1::RemoveSessionResponse* response) {
  if (request.map().empty() || request.session().empty()) {
    return InvalidArgumentError("RemoveSession needs a map and a session");
  }
  SEMMAP_ASSIGN_OR_RETURN(
      RemovedCounts removed,
      ingest_->RemoveSession(request.map(), request.session(), ClientStillWaiting(context)));
  response->set_frames(static_cast<uint64_t>(removed.frames));
  response->set_keyframes(static_cast<uint64_t>(removed.keyframes));
  return OkStatus();
}

Status MapServiceImpl::Answer(grpc::CallbackServerContext* context,
                              const v1::RemoveMapRequest& request,
                              v1::RemoveMapResponse* response) {
  if (request.map().empty()) return InvalidArgumentError("RemoveMap needs a map");
  SEMMAP_ASSIGN_OR_RETURN(RemovedCounts removed,
                          ingest_->RemoveMap(request.map(), ClientStillWaiting(context)));
  objects_->ForgetMap(removed.map_id);
  response->set_sessions(static_cast<uint64_t>(removed.sessions));
  response->set_frames(static_cast<uint64_t>(removed.frames));
  response->set_keyframes(static_cast<uint64_t>(removed.keyframes));
  return OkStatus();
}

}  // namespace semmap
