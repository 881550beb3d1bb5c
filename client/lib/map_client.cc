#include "client/lib/map_client.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "common/pem_file.h"
#include "common/sha256.h"
#include "common/thread_annotations.h"
#include "common/thread_launcher.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "server/serialization/conversions.h"
#include "server/serialization/object_conversions.h"

namespace semmap {

StatusOr<ClientTls> LoadClientTls(const std::string& ca_file, const std::string& cert_file,
                                  const std::string& key_file) {
  if (cert_file.empty() != key_file.empty()) {
    return InvalidArgumentError("--tls-cert and --tls-key go together");
  }
  ClientTls tls;
  if (!ca_file.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(tls.root_certs_pem, ReadPemFile(ca_file, "--tls-ca"));
  }
  if (!cert_file.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(tls.cert_chain_pem, ReadPemFile(cert_file, "--tls-cert"));
    SEMMAP_ASSIGN_OR_RETURN(tls.private_key_pem, ReadPemFile(key_file, "--tls-key"));
  }
  return tls;
}

MapClient::MapClient(const ClientOptions& options) : options_(options) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(options.max_message_mb << 20);
  args.SetMaxSendMessageSize(options.max_message_mb << 20);
  // One connection per MapClient: gRPC otherwise shares one TCP connection between channels
  // with equal arguments, and a small query then waits behind another client's frames.
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (options.tls) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = options.tls->root_certs_pem;
    ssl.pem_cert_chain = options.tls->cert_chain_pem;
    ssl.pem_private_key = options.tls->private_key_pem;
    credentials = grpc::SslCredentials(ssl);
  }
  channel_ = grpc::CreateCustomChannel(options.server, credentials, args);
  stub_ = v1::MapService::NewStub(channel_);
}

void MapClient::SetDeadline(grpc::ClientContext* context) const {
  context->set_deadline(std::chrono::system_clock::now() + options_.query_timeout);
  Authenticate(context);
}

void MapClient::Authenticate(grpc::ClientContext* context) const {
  if (!options_.token.empty()) context->AddMetadata("authorization", "Bearer " + options_.token);
}

StatusOr<std::string> MapClient::Health(std::chrono::milliseconds timeout) {
  auto health = grpc::health::v1::Health::NewStub(channel_);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + timeout);
  context.set_wait_for_ready(true);  // ride out a server that is still starting
  grpc::health::v1::HealthCheckRequest request;
  grpc::health::v1::HealthCheckResponse response;
  const grpc::Status status = health->Check(&context, request, &response);
  if (status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) {
    return UnavailableError("no semmapd answered at " + options_.server);
  }
  if (!status.ok()) return FromGrpcStatus(status);
  return grpc::health::v1::HealthCheckResponse::ServingStatus_Name(response.status());
}

Status MapClient::WaitUntilServing(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  Status last = UnavailableError("no semmapd answered at " + options_.server);
  while (std::chrono::steady_clock::now() < deadline) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    StatusOr<std::string> health = Health(std::max(left, std::chrono::milliseconds(1)));
    if (health.ok() && *health == "SERVING") return OkStatus();
    if (!health.ok()) last = health.status();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return last;
}

StatusOr<std::vector<MapInfo>> MapClient::ListMaps() {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::ListMapsResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->ListMaps(&context, {}, &response)));
  std::vector<MapInfo> maps;
  for (const v1::MapInfo& m : response.maps()) maps.push_back(FromProto(m));
  return maps;
}

StatusOr<std::vector<SessionInfo>> MapClient::ListSessions(const std::string& map) {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::ListSessionsRequest request;
  request.set_map(map);
  v1::ListSessionsResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->ListSessions(&context, request, &response)));
  std::vector<SessionInfo> sessions;
  for (const v1::SessionInfo& s : response.sessions()) sessions.push_back(FromProto(s));
  return sessions;
}

StatusOr<std::vector<TrajectoryPose>> MapClient::GetTrajectory(const std::string& map,
                                                               const std::string& session,
                                                               bool keyframes_only) {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::GetTrajectoryRequest request;
  request.set_map(map);
  request.set_session(session);
  request.set_keyframes_only(keyframes_only);
  auto reader = stub_->GetTrajectory(&context, request);
  std::vector<TrajectoryPose> poses;
  v1::GetTrajectoryResponse chunk;
  while (reader->Read(&chunk)) {
    for (const v1::TrajectoryPose& p : chunk.poses()) poses.push_back(FromProto(p));
  }
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(reader->Finish()));
  return poses;
}

StatusOr<ExportResult> MapClient::ExportMap(const ExportRequest& request,
                                            const CancelCheck& cancel) {
  grpc::ClientContext context;
  SetDeadline(&context);
  // The server builds the export before its first message: the watcher cancels the call
  // while this thread waits in Read().
  std::atomic<bool> done{false};
  Status cancelled = OkStatus();
  Mutex cancelled_mutex;
  std::thread watcher;
  if (cancel) {
    SEMMAP_ASSIGN_OR_RETURN(watcher, LaunchThread([&] {
                              while (!done.load()) {
                                Status status = cancel();
                                if (!status.ok()) {
                                  {
                                    MutexLock lock(cancelled_mutex);
                                    cancelled = std::move(status);
                                  }
                                  context.TryCancel();
                                  return;
                                }
                                std::this_thread::sleep_for(std::chrono::milliseconds(10));
                              }
                            }));
  }
  StatusOr<ExportResult> result = ReadExport(&context, request);
  done.store(true);
  if (watcher.joinable()) watcher.join();
  MutexLock lock(cancelled_mutex);
  if (!cancelled.ok()) return cancelled;
  return result;
}

StatusOr<ExportResult> MapClient::ReadExport(grpc::ClientContext* context,
                                             const ExportRequest& request) {
  v1::ExportMapRequest wire;
  wire.set_map(request.map);
  wire.set_format(request.format);
  wire.set_session(request.session);
  wire.set_ascii(request.ascii);
  wire.set_voxel(request.voxel_m);
  wire.set_view(request.view);
  wire.set_width(static_cast<uint32_t>(std::max(request.width_px, 0)));
  auto reader = stub_->ExportMap(context, wire);
  ExportResult result;
  Sha256Hasher hasher;
  std::optional<v1::ExportTrailer> trailer;
  v1::ExportMapResponse message;
  while (reader->Read(&message)) {
    if (message.has_header()) {
      result.format = message.header().format();
      result.media_type = message.header().media_type();
      // A size hint from the server; never trusted beyond what a message could carry.
      result.bytes.reserve(static_cast<size_t>(
          std::min<uint64_t>(message.header().total_bytes(), uint64_t{1} << 30)));
      const v1::Vector3& origin = message.header().layer_origin();
      result.layer_origin = Eigen::Vector3d(origin.x(), origin.y(), origin.z());
    } else if (message.has_trailer()) {
      trailer = message.trailer();
    } else {
      hasher.Update(message.chunk());
      result.bytes += message.chunk();
    }
  }
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(reader->Finish()));
  if (!trailer) return DataLossError("the export ended without its checksum trailer");
  result.sha256_hex = ToHex(hasher.Finish());
  if (result.sha256_hex != trailer->sha256() || result.bytes.size() != trailer->total_bytes()) {
    return DataLossError(
        "export checksum mismatch: received " + std::to_string(result.bytes.size()) +
        " bytes with sha256 " + result.sha256_hex + ", server sent " +
        std::to_string(trailer->total_bytes()) + " bytes with sha256 " + trailer->sha256());
  }
  return result;
}

StatusOr<std::vector<ObjectType>> MapClient::ListObjectTypes(const std::string& map) {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::ListObjectsRequest request;
  request.set_map(map);
  v1::ListObjectsResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->ListObjects(&context, request, &response)));
  std::vector<ObjectType> types;
  for (const v1::ObjectTypeInfo& t : response.objects()) types.push_back(FromProto(t));
  return types;
}

StatusOr<std::vector<ObjectInstance>> MapClient::FindObjects(const std::string& label,
                                                             const std::string& map) {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::FindObjectsRequest request;
  request.set_label(label);
  request.set_map(map);
  v1::FindObjectsResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->FindObjects(&context, request, &response)));
  std::vector<ObjectInstance> out;
  for (const v1::ObjectInstanceInfo& o : response.objects()) out.push_back(FromProto(o));
  return out;
}

StatusOr<std::vector<ObjectInstance>> MapClient::ObjectsNear(const std::string& map,
                                                             const Eigen::Vector3d& point,
                                                             double radius_m,
                                                             const std::string& label) {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::ObjectsNearRequest request;
  request.set_map(map);
  ToProto(point, request.mutable_point());
  request.set_radius(radius_m);
  request.set_label(label);
  v1::ObjectsNearResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->ObjectsNear(&context, request, &response)));
  std::vector<ObjectInstance> out;
  for (const v1::ObjectInstanceInfo& o : response.objects()) out.push_back(FromProto(o));
  return out;
}

StatusOr<ObjectType> MapClient::RegisterObject(const std::string& label, const std::string& map,
                                               const std::vector<EncodedImage>& photos,
                                               const std::optional<std::array<uint8_t, 3>>& rgb) {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::RegisterObjectRequest request;
  request.set_label(label);
  request.set_map(map);
  for (const EncodedImage& photo : photos) {
    v1::CompressedImage* out = request.add_photos();
    out->set_format(photo.format);
    out->set_data(photo.bytes);
  }
  if (rgb) ToProto(*rgb, request.mutable_colour());
  v1::RegisterObjectResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->RegisterObject(&context, request, &response)));
  return FromProto(response.object());
}

Status MapClient::RemoveObject(const std::string& label, const std::string& map) {
  grpc::ClientContext context;
  SetDeadline(&context);
  v1::RemoveObjectRequest request;
  request.set_label(label);
  request.set_map(map);
  v1::RemoveObjectResponse response;
  return FromGrpcStatus(stub_->RemoveObject(&context, request, &response));
}

namespace {
constexpr std::chrono::minutes kRemovalTimeout{10};
}  // namespace

StatusOr<RemovedCounts> MapClient::RemoveSession(const std::string& map,
                                                 const std::string& session) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + kRemovalTimeout);
  Authenticate(&context);
  v1::RemoveSessionRequest request;
  request.set_map(map);
  request.set_session(session);
  v1::RemoveSessionResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->RemoveSession(&context, request, &response)));
  RemovedCounts counts;
  counts.sessions = 1;
  counts.frames = static_cast<int64_t>(response.frames());
  counts.keyframes = static_cast<int64_t>(response.keyframes());
  return counts;
}

StatusOr<RemovedCounts> MapClient::RemoveMap(const std::string& map) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + kRemovalTimeout);
  Authenticate(&context);
  v1::RemoveMapRequest request;
  request.set_map(map);
  v1::RemoveMapResponse response;
  SEMMAP_RETURN_IF_ERROR(FromGrpcStatus(stub_->RemoveMap(&context, request, &response)));
  RemovedCounts counts;
  counts.sessions = static_cast<int64_t>(response.sessions());
  counts.frames = static_cast<int64_t>(response.frames());
  counts.keyframes = static_cast<int64_t>(response.keyframes());
  return counts;
}

StatusOr<std::unique_ptr<IngestStream>> MapClient::Ingest(const v1::IngestStart& start,
                                                          IngestStream::AckCallback on_ack) {
  return IngestStream::Open(stub_.get(), start, std::move(on_ack), options_.token);
}

}  // namespace semmap
