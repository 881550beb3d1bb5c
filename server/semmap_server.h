// A running semmap server: store, writer thread, ingest manager and the gRPC server wired
// together. Used by semmapd and, in-process on an ephemeral port, by the tests.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "common/map_query.h"
#include "core/pipeline/ingest_manager.h"
#include "server/server_options.h"
#include "server/service/map_service.h"
#include "storage/storage_writer.h"

namespace semmap {

class SemmapServer {
 public:
  // Opens (or creates) the data directory and database and starts serving.
  static StatusOr<std::unique_ptr<SemmapServer>> Start(const ServerOptions& options);
  ~SemmapServer();  // Shutdown()

  // Health NOT_SERVING, stop accepting, let streams store what they have, commit, checkpoint.
  // Idempotent; returns the first storage error.
  Status Shutdown();

  // Re-reads --auth-tokens (SIGHUP); a file that no longer parses keeps the tokens in force.
  Status ReloadAuthTokens();

  int port() const { return port_; }
  std::string address() const;
  MapQueryInterface& query() { return *query_; }
  // Lets tests stall storage to observe backpressure.
  StorageWriter& writer_for_testing() { return *writer_; }
  // Lets tests see when a call has let go of its worker.
  const WorkerPool& workers_for_testing() const { return *workers_; }

 private:
  SemmapServer() = default;

  ServerOptions options_;
  int lock_fd_ = -1;  // flock on the data dir: one server per directory
  std::unique_ptr<StorageWriter> writer_;
  std::unique_ptr<MapQueryInterface> query_;
  std::unique_ptr<ObjectCatalog> objects_;
  std::unique_ptr<IngestManager> ingest_;
  std::unique_ptr<Authorizer> authorizer_;  // before service_, which points to it
  std::unique_ptr<WorkerPool> workers_;     // likewise
  std::unique_ptr<MapServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool shut_down_ = false;
};

}  // namespace semmap
