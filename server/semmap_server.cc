#include "server/semmap_server.h"

#include <fcntl.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "common/logging.h"
#include "core/odometry/mono_vo_model.h"
#include "core/query/store_map_query.h"
#include "core/slam/bow_vocabulary.h"
#include "server/server_credentials.h"
#include "server/server_options.h"
#include "server/unix_socket_path.h"
#include "storage/sqlite/sqlite_map_store.h"

namespace semmap {
namespace {

// Start failed after the writer started: stop it; its own error is secondary, so logged.
void StopWriterAfterError(StorageWriter& writer) {
  const Status stopped = writer.Stop();
  if (!stopped.ok())
    LogError("stopping the storage writer after a failed start: {}", stopped.ToString());
}

StatusOr<int> LockDataDir(const std::string& dir) {
  const std::string path = dir + "/LOCK";
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return UnavailableError("cannot open " + path);
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    return FailedPreconditionError("data directory " + dir +
                                   " is in use by another semmapd (lock " + path + ")");
  }
  return fd;
}

}  // namespace

StatusOr<std::unique_ptr<SemmapServer>> SemmapServer::Start(const ServerOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  // TLS files first: a typo there should not cost a database open and a restore.
  SEMMAP_ASSIGN_OR_RETURN(std::shared_ptr<grpc::ServerCredentials> credentials,
                          MakeServerCredentials(options));
  if (options.tls_cert_file.empty() && !IsLoopbackAddress(options.listen)) {
    LogWarning(
        "serving {} in plaintext (--allow-insecure): anyone who can reach it can read, "
        "change and delete every map",
        options.listen);
  }
  std::unique_ptr<Authorizer> authorizer;
  if (!options.auth_tokens_file.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(authorizer, Authorizer::Load(options.auth_tokens_file));
    LogInfo("serving callers with one of {} tokens from {} (health stays open)",
            authorizer->num_tokens(), options.auth_tokens_file);
  }
  std::unique_ptr<SemmapServer> server(new SemmapServer());
  server->authorizer_ = std::move(authorizer);
  server->options_ = options;

  std::error_code ec;
  std::filesystem::create_directories(options.data_dir, ec);
  if (ec) {
    return FailedPreconditionError("cannot create data directory " + options.data_dir + ": " +
                                   ec.message());
  }
  SEMMAP_ASSIGN_OR_RETURN(server->lock_fd_, LockDataDir(options.data_dir));

  const std::string db_path = options.data_dir + "/semmap.db";
  SqliteOptions sqlite;
  sqlite.synchronous_full = options.sync_full;
  // The writer opens first so migrations run before the reader connects.
  SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<SqliteMapStore> write_store,
                          SqliteMapStore::Open(db_path, sqlite));
  // One read connection per query worker (WAL: readers run beside each other and the writer).
  std::vector<std::unique_ptr<MapStore>> read_stores;
  for (size_t i = 0; i < options.calls.workers; ++i) {
    SEMMAP_ASSIGN_OR_RETURN(read_stores.emplace_back(), SqliteMapStore::Open(db_path, sqlite));
  }
  StorageWriter::Options writer_options;
  writer_options.queue_capacity = options.storage_queue_capacity;
  SEMMAP_ASSIGN_OR_RETURN(server->writer_,
                          StorageWriter::Start(std::move(write_store), writer_options));
  // Sessions a previous run left open ended when it stopped without ending them.
  int64_t crashed = 0;
  Status marked = server->writer_->RunSync([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(crashed, store.MarkOpenSessionsCrashed());
    return OkStatus();
  });
  if (!marked.ok()) {
    StopWriterAfterError(*server->writer_);
    return marked.WithContext("marking sessions left open");
  }
  if (crashed > 0) {
    LogWarning(
        "{} session(s) were left open by a previous run that did not stop cleanly; marked "
        "crashed (their acknowledged-durable frames are kept)",
        crashed);
  }
  server->query_ = std::make_unique<StoreMapQuery>(std::move(read_stores), options.ingest.layers);
  std::shared_ptr<const BowVocabulary> vocabulary;
  if (!options.vocabulary_path.empty()) {
    StatusOr<BowVocabulary> loaded = BowVocabulary::Load(options.vocabulary_path);
    if (loaded.ok()) {
      vocabulary = std::make_shared<const BowVocabulary>(std::move(loaded).value());
    } else if (!options.vocabulary_optional) {
      StopWriterAfterError(*server->writer_);
      return loaded.status().WithContext("--vocabulary " + options.vocabulary_path);
    } else {
      LogWarning("no place-recognition vocabulary ({}); loop closure by pose proximity only",
                 loaded.status().ToString());
    }
  }
  IngestOptions ingest = options.ingest;
  if (!options.vo_model_path.empty()) {
    StatusOr<std::shared_ptr<const MonoVoModel>> model = MonoVoModel::Load(options.vo_model_path);
    if (model.ok()) {
      ingest.mono_model = std::move(model).value();
      LogInfo("MONO sessions: VO model {} (sha256 {}, input {}x{})", options.vo_model_path,
              ingest.mono_model->info().sha256.substr(0, 12),
              ingest.mono_model->info().camera.width, ingest.mono_model->info().camera.height);
    } else if (!options.vo_model_optional) {
      StopWriterAfterError(*server->writer_);
      return model.status().WithContext("--vo-model " + options.vo_model_path);
    } else {
      ingest.mono_unavailable = "the VO model could not be loaded (" + model.status().ToString() +
                                "); give semmapd a valid --vo-model";
      LogWarning("MONO sessions unavailable: {}", ingest.mono_unavailable);
    }
  }
  StatusOr<std::unique_ptr<ObjectCatalog>> objects =
      ObjectCatalog::Load(server->writer_.get(), options.recognition);
  if (!objects.ok()) {
    StopWriterAfterError(*server->writer_);
    return objects.status().WithContext("loading the object database");
  }
  server->objects_ = std::move(objects).value();
  // Map stages restore through read connections of their own (WAL: next to the writer).
  ingest.open_reader = SqliteMapStore::Opener(db_path, sqlite);
  server->ingest_ = std::make_unique<IngestManager>(server->writer_.get(), std::move(ingest),
                                                    std::move(vocabulary), server->objects_.get());
  WorkerPoolOptions workers;
  workers.threads = options.calls.workers;
  workers.queue_capacity = options.calls.worker_queue;
  workers.thread_name = "query-worker";
  StatusOr<std::unique_ptr<WorkerPool>> pool = WorkerPool::Start(workers);
  if (!pool.ok()) {
    StopWriterAfterError(*server->writer_);
    return pool.status().WithContext("starting the query workers");
  }
  server->workers_ = std::move(pool).value();
  server->service_ = std::make_unique<MapServiceImpl>(
      server->ingest_.get(), server->query_.get(), server->objects_.get(),
      server->authorizer_.get(), server->workers_.get(), options.calls);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  if (IsUnixSocketAddress(options.listen)) {
    const Status free = CheckUnixSocketPathFree(UnixSocketPathOf(options.listen));
    if (!free.ok()) {
      StopWriterAfterError(*server->writer_);
      return free;
    }
  }
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen, credentials, &server->port_);
  builder.RegisterService(server->service_.get());
  builder.SetMaxReceiveMessageSize(options.max_message_mb << 20);
  builder.SetMaxSendMessageSize(options.max_message_mb << 20);
  server->server_ = builder.BuildAndStart();
  if (!server->server_ || server->port_ == 0) {
    server->server_.reset();
    StopWriterAfterError(*server->writer_);
    return UnavailableError(
        "cannot listen on " + options.listen + " (address in use or not valid" +
        (options.tls_cert_file.empty() ? ")" : ", or --tls-cert and --tls-key not a valid pair)"));
  }
  server->server_->GetHealthCheckService()->SetServingStatus(true);
  return server;
}

Status SemmapServer::ReloadAuthTokens() {
  if (authorizer_ == nullptr) return FailedPreconditionError("no --auth-tokens file to re-read");
  SEMMAP_RETURN_IF_ERROR(authorizer_->Reload());
  LogInfo("re-read {}: {} tokens", options_.auth_tokens_file, authorizer_->num_tokens());
  return OkStatus();
}

SemmapServer::~SemmapServer() {
  const Status status = Shutdown();
  if (!status.ok()) LogError("server shutdown: {}", status.ToString());
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

std::string SemmapServer::address() const {
  if (IsUnixSocketAddress(options_.listen)) return options_.listen;
  const std::string host = options_.listen.substr(0, options_.listen.rfind(':'));
  return host + ":" + std::to_string(port_);
}

Status SemmapServer::Shutdown() {
  if (shut_down_) return OkStatus();
  shut_down_ = true;
  if (server_) {
    server_->GetHealthCheckService()->SetServingStatus(false);
    // Streams store what they have queued and finish with UNAVAILABLE; then the server stops.
    ingest_->BeginShutdown();
    // Returns once every call has finished: the workers run until then.
    server_->Shutdown(std::chrono::system_clock::now() +
                      std::chrono::seconds(options_.shutdown_grace_s));
  }
  if (workers_) workers_->Stop();
  if (ingest_) ingest_->Join();
  Status status = writer_ ? writer_->Stop() : OkStatus();  // commits and checkpoints the WAL
  if (server_) server_->Wait();
  return status;
}

}  // namespace semmap
