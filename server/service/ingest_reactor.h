// The Ingest RPC: one reactor per stream. It converts messages and hands them to the session's
// bounded queue, asking gRPC for the next message only while that queue has room, so a slow
// pipeline pushes back on the client through HTTP/2 flow control instead of buffering.
// Reactions never block; the session answers through a Sink that outlives the reactor safely.
//
// The method is registered raw (byte buffers): gRPC reports a request that does not parse the
// same way as the client's half-close, which would end the session OK and silently drop
// everything after it. Parsing here makes such a message an INVALID_ARGUMENT end instead.
#pragma once

#include <grpcpp/grpcpp.h>

#include <deque>
#include <memory>
#include <optional>

#include "common/thread_annotations.h"
#include "core/pipeline/ingest_manager.h"
#include "semmap/v1/service.grpc.pb.h"
#include "server/auth/authorizer.h"

namespace semmap {

class IngestReactor final : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  // `authorizer` (may be null): the call needs a write token covering its start's map.
  IngestReactor(grpc::CallbackServerContext* context, IngestManager* manager,
                const Authorizer* authorizer = nullptr);

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  class Sink;
  friend class Sink;
  // What to do once the mutex is released (gRPC calls are never made while holding it).
  struct Actions {
    bool read = false;
    const grpc::ByteBuffer* write = nullptr;
    std::optional<grpc::Status> finish;
  };

  void Run(const Actions& actions) SEMMAP_EXCLUDES(mutex_);
  void DecideReadLocked(Actions* actions) SEMMAP_REQUIRES(mutex_);
  void DecideWriteOrFinishLocked(Actions* actions) SEMMAP_REQUIRES(mutex_);
  void EnqueueLocked(v1::IngestResponse response) SEMMAP_REQUIRES(mutex_);
  void PushToSessionLocked(IngestMessage message) SEMMAP_REQUIRES(mutex_);

  // Called by the Sink.
  void Started(const SessionInfo& session) SEMMAP_EXCLUDES(mutex_);
  void Ack(const FrameAckInfo& ack) SEMMAP_EXCLUDES(mutex_);
  void Progress(const IngestProgressInfo& progress) SEMMAP_EXCLUDES(mutex_);
  void QueueRoom() SEMMAP_EXCLUDES(mutex_);
  void Finished(const Status& status, const IngestSummaryInfo& summary) SEMMAP_EXCLUDES(mutex_);

  static constexpr size_t kMaxPendingResponses = 64;

  grpc::CallbackServerContext* const context_;
  const Authorizer* const authorizer_;
  const std::string authorization_;  // the call's bearer token metadata
  const std::shared_ptr<Sink> sink_;

  // Lock order: the Sink's mutex (held while it calls the reactor) before this one.
  Mutex mutex_;
  // Set in the constructor once Open returns, when the session may already call the Sink. A handle:
  // the IngestManager owns the session and destroys it off the network threads.
  std::shared_ptr<IngestSessionHandle> stream_ SEMMAP_GUARDED_BY(mutex_);
  // gRPC fills it between StartRead and OnReadDone; read here only under mutex_.
  grpc::ByteBuffer request_ SEMMAP_GUARDED_BY(mutex_);
  uint64_t messages_read_ SEMMAP_GUARDED_BY(mutex_) = 0;
  bool read_in_flight_ SEMMAP_GUARDED_BY(mutex_) = false;
  // Half-close seen, protocol finished, or stream finishing.
  bool reads_closed_ SEMMAP_GUARDED_BY(mutex_) = false;
  // End read; waiting for the half-close that must follow.
  bool end_held_ SEMMAP_GUARDED_BY(mutex_) = false;
  std::deque<v1::IngestResponse> outgoing_ SEMMAP_GUARDED_BY(mutex_);
  std::optional<grpc::ByteBuffer> writing_ SEMMAP_GUARDED_BY(mutex_);
  // A not-yet-sent progress is coalesced with newer ones.
  bool progress_queued_ SEMMAP_GUARDED_BY(mutex_) = false;
  std::optional<grpc::Status> finish_status_ SEMMAP_GUARDED_BY(mutex_);
  bool finish_called_ SEMMAP_GUARDED_BY(mutex_) = false;
  bool client_gone_ SEMMAP_GUARDED_BY(mutex_) = false;
};

}  // namespace semmap
