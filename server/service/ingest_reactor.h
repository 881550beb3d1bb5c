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
#include <mutex>
#include <optional>

#include "core/pipeline/ingest_manager.h"
#include "semmap/v1/service.grpc.pb.h"

namespace semmap {

class IngestReactor final : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  IngestReactor(grpc::CallbackServerContext* context, IngestManager* manager);

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

  void Run(const Actions& actions);
  void DecideReadLocked(Actions* actions);
  void DecideWriteOrFinishLocked(Actions* actions);
  void EnqueueLocked(v1::IngestResponse response);
  void PushToSessionLocked(IngestMessage message);

  // Called by the Sink.
  void Started(const SessionInfo& session);
  void Ack(const FrameAckInfo& ack);
  void Progress(const IngestProgressInfo& progress);
  void QueueRoom();
  void Finished(const Status& status, const IngestSummaryInfo& summary);

  static constexpr size_t kMaxPendingResponses = 64;

  grpc::CallbackServerContext* const context_;
  std::shared_ptr<Sink> sink_;
  std::shared_ptr<IngestSession> session_;

  std::mutex mutex_;
  grpc::ByteBuffer request_;
  uint64_t messages_read_ = 0;
  bool read_in_flight_ = false;
  bool reads_closed_ = false;  // half-close seen, protocol finished, or stream finishing
  bool end_held_ = false;      // end read; waiting for the half-close that must follow
  std::deque<v1::IngestResponse> outgoing_;
  std::optional<grpc::ByteBuffer> writing_;
  bool progress_queued_ = false;  // a not-yet-sent progress is coalesced with newer ones
  std::optional<grpc::Status> finish_status_;
  bool finish_called_ = false;
  bool client_gone_ = false;
};

}  // namespace semmap
