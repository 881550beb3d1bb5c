// The semmap client library: the same MapQueryInterface the server implements in-process,
// here over gRPC, plus health checks and streaming ingest.
#pragma once

#include <grpcpp/grpcpp.h>

#include <array>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "client/lib/ingest_stream.h"
#include "common/map_query.h"
#include "semmap/v1/service.grpc.pb.h"

namespace semmap {

// TLS towards semmapd, as PEM text (LoadClientTls reads the files).
struct ClientTls {
  std::string root_certs_pem;   // CA(s) to trust; empty: the system's roots
  std::string cert_chain_pem;   // mutual TLS: this client's certificate chain ...
  std::string private_key_pem;  // ... and its key (both or neither)
};

// Reads --tls-ca / --tls-cert / --tls-key (any may be empty; cert and key go together).
// INVALID_ARGUMENT naming the flag for a file that cannot be read or is not PEM.
StatusOr<ClientTls> LoadClientTls(const std::string& ca_file, const std::string& cert_file,
                                  const std::string& key_file);

struct ClientOptions {
  std::string server = "127.0.0.1:50051";
  std::optional<ClientTls> tls;  // none: plaintext
  // Sent as "authorization: Bearer <token>" with every call but Health (semmapd --auth-tokens).
  std::string token;
  std::chrono::seconds query_timeout{30};
  int max_message_mb = 64;
};

class MapClient final : public MapQueryInterface {
 public:
  explicit MapClient(const ClientOptions& options);

  // "SERVING" / "NOT_SERVING"; UNAVAILABLE when nothing answers within `timeout`.
  StatusOr<std::string> Health(std::chrono::milliseconds timeout = std::chrono::seconds(5));
  // Waits until the server answers SERVING or the timeout passes.
  Status WaitUntilServing(std::chrono::milliseconds timeout);

  StatusOr<std::vector<MapInfo>> ListMaps() override;
  StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& map) override;
  StatusOr<std::vector<TrajectoryPose>> GetTrajectory(const std::string& map,
                                                      const std::string& session,
                                                      bool keyframes_only) override;
  // Reassembles the chunks and checks the trailer's SHA-256 (DATA_LOSS on mismatch).
  // `cancel` is polled every 10 ms while the export runs; its status cancels the call.
  StatusOr<ExportResult> ExportMap(const ExportRequest& request,
                                   const CancelCheck& cancel = {}) override;

  StatusOr<std::vector<ObjectType>> ListObjectTypes(const std::string& map) override;
  StatusOr<std::vector<ObjectInstance>> FindObjects(const std::string& label,
                                                    const std::string& map) override;
  StatusOr<std::vector<ObjectInstance>> ObjectsNear(const std::string& map,
                                                    const Eigen::Vector3d& point, double radius_m,
                                                    const std::string& label) override;
  // Registers an object type from photos (encoded png / jpeg as read from files); `map` empty:
  // global. Without a colour the server picks one.
  StatusOr<ObjectType> RegisterObject(const std::string& label, const std::string& map,
                                      const std::vector<EncodedImage>& photos,
                                      const std::optional<std::array<uint8_t, 3>>& rgb);
  Status RemoveObject(const std::string& label, const std::string& map);

  // Administration (the server rebuilds the map's layers and objects after a session removal,
  // so these wait up to 10 minutes). FAILED_PRECONDITION while a stream ingests into the map.
  StatusOr<RemovedCounts> RemoveSession(const std::string& map, const std::string& session);
  StatusOr<RemovedCounts> RemoveMap(const std::string& map);

  // Opens an ingest stream; fails with the server's status if the start is refused.
  StatusOr<std::unique_ptr<IngestStream>> Ingest(const v1::IngestStart& start,
                                                 IngestStream::AckCallback on_ack = nullptr);

  v1::MapService::Stub& stub() { return *stub_; }

 private:
  // The query deadline and Authenticate.
  void SetDeadline(grpc::ClientContext* context) const;
  // The bearer token, when there is one.
  void Authenticate(grpc::ClientContext* context) const;
  // The export call itself: reads the stream and checks the trailer.
  StatusOr<ExportResult> ReadExport(grpc::ClientContext* context, const ExportRequest& request);

  ClientOptions options_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::MapService::Stub> stub_;
};

}  // namespace semmap
