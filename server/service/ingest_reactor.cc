#include "server/service/ingest_reactor.h"

#include <chrono>

#include "server/serialization/ingest_conversions.h"
#include "server/serialization/wire_parsing.h"
#include "server/service/call_access.h"

namespace semmap {

// Forwards session callbacks to the reactor until the reactor is done; afterwards drops them.
class IngestReactor::Sink final : public IngestSink {
 public:
  explicit Sink(IngestReactor* reactor) : reactor_(reactor) {}
  void Detach() SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    reactor_ = nullptr;
  }
  void OnStarted(const SessionInfo& s) override {
    Call([&](IngestReactor* r) { r->Started(s); });
  }
  void OnAck(const FrameAckInfo& a) override {
    Call([&](IngestReactor* r) { r->Ack(a); });
  }
  void OnProgress(const IngestProgressInfo& p) override {
    Call([&](IngestReactor* r) { r->Progress(p); });
  }
  void OnQueueRoom() override {
    Call([](IngestReactor* r) { r->QueueRoom(); });
  }
  void OnFinished(const Status& st, const IngestSummaryInfo& s) override {
    Call([&](IngestReactor* r) { r->Finished(st, s); });
  }

 private:
  template <typename F>
  void Call(F&& f) SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    if (reactor_ != nullptr) f(reactor_);
  }
  Mutex mutex_;
  IngestReactor* reactor_ SEMMAP_GUARDED_BY(mutex_);
};

IngestReactor::IngestReactor(grpc::CallbackServerContext* context, IngestManager* manager,
                             const Authorizer* authorizer)
    : context_(context),
      authorizer_(authorizer),
      authorization_(AuthorizationOf(*context)),
      sink_(std::make_shared<Sink>(this)) {
  // A caller without a write token gets no session (and takes no stream slot).
  if (authorizer_ != nullptr) {
    if (auto grant = authorizer_->Check(authorization_, Role::kWrite, nullptr); !grant.ok()) {
      {
        MutexLock lock(mutex_);
        finish_called_ = true;
      }
      Finish(ToGrpcStatus(grant.status()));
      return;
    }
  }
  // Open starts the session's threads, which may call the Sink (QueueRoom reads stream_ and
  // read_in_flight_) before this constructor finishes: the state is set under the lock.
  StatusOr<std::shared_ptr<IngestSessionHandle>> stream = manager->Open(sink_);
  if (!stream.ok()) {
    {
      MutexLock lock(mutex_);
      finish_called_ = true;
    }
    Finish(ToGrpcStatus(stream.status()));
    return;
  }
  {
    MutexLock lock(mutex_);
    stream_ = std::move(stream).value();
    read_in_flight_ = true;
  }
  StartRead(&request_);
}

void IngestReactor::Run(const Actions& actions) {
  if (actions.read) StartRead(&request_);
  if (actions.write != nullptr) StartWrite(actions.write);
  if (actions.finish) Finish(*actions.finish);
}

void IngestReactor::PushToSessionLocked(IngestMessage message) {
  // Reads start only while the queue has room and only this reactor enqueues, so this holds.
  if (!stream_->TryEnqueue(message)) {
    reads_closed_ = true;
    stream_->Stop();
  } else if (std::holds_alternative<IngestInvalid>(message)) {
    reads_closed_ = true;  // the session turned a frame into its end (the frame-rate limit)
  }
}

void IngestReactor::DecideReadLocked(Actions* actions) {
  if (read_in_flight_ || reads_closed_ || finish_status_ || !stream_) return;
  if (!end_held_ && !stream_->HasRoom()) return;         // QueueRoom() resumes
  if (outgoing_.size() >= kMaxPendingResponses) return;  // OnWriteDone resumes
  read_in_flight_ = true;
  actions->read = true;
}

void IngestReactor::DecideWriteOrFinishLocked(Actions* actions) {
  if (writing_ || finish_called_) return;
  if (!outgoing_.empty() && !client_gone_) {
    const v1::IngestResponse& next = outgoing_.front();
    if (next.has_progress()) progress_queued_ = false;
    grpc::ByteBuffer buffer;
    const Status serialized = SerializeWire(next, &buffer);
    outgoing_.pop_front();
    if (!serialized.ok()) {
      finish_called_ = true;
      actions->finish = ToGrpcStatus(serialized);
      return;
    }
    writing_ = std::move(buffer);
    actions->write = &*writing_;
    return;
  }
  if (finish_status_) {
    finish_called_ = true;
    actions->finish = *finish_status_;
  }
}

void IngestReactor::EnqueueLocked(v1::IngestResponse response) {
  if (client_gone_ || finish_called_) return;
  outgoing_.push_back(std::move(response));
}

void IngestReactor::OnReadDone(bool ok) {
  Actions actions;
  {
    MutexLock lock(mutex_);
    read_in_flight_ = false;
    if (!ok) {
      // The client closed its side (or the call broke). A close without `end` ends the
      // session the same way; a broken call is handled by OnCancel.
      reads_closed_ = true;
      if (!context_->IsCancelled()) PushToSessionLocked(IngestEnd{});
    } else if (end_held_) {
      reads_closed_ = true;
      PushToSessionLocked(
          IngestInvalid{InvalidArgumentError("a message arrived after the end message")});
    } else {
      ++messages_read_;
      IngestMessage message = ParseIngestRequest(request_, messages_read_);
      request_.Clear();
      if (const auto* start = std::get_if<IngestStartRequest>(&message);
          start != nullptr && authorizer_ != nullptr) {
        if (auto grant = authorizer_->Check(authorization_, Role::kWrite, &start->map);
            !grant.ok()) {
          message = IngestInvalid{grant.status()};
        }
      }
      if (std::holds_alternative<IngestEnd>(message)) {
        end_held_ = true;  // confirmed by the half-close that must follow
      } else {
        if (std::holds_alternative<IngestInvalid>(message)) reads_closed_ = true;
        PushToSessionLocked(std::move(message));
      }
    }
    DecideReadLocked(&actions);
  }
  Run(actions);
}

void IngestReactor::OnWriteDone(bool ok) {
  Actions actions;
  {
    MutexLock lock(mutex_);
    writing_.reset();
    if (!ok) {
      client_gone_ = true;
      outgoing_.clear();
    }
    DecideWriteOrFinishLocked(&actions);
    DecideReadLocked(&actions);
  }
  Run(actions);
}

void IngestReactor::OnCancel() {
  std::shared_ptr<IngestSessionHandle> stream;
  {
    MutexLock lock(mutex_);
    client_gone_ = true;
    reads_closed_ = true;
    outgoing_.clear();
    stream = stream_;
  }
  // The session still stores what it has queued, then reports Finished.
  if (stream) stream->Cancel(context_->deadline() <= std::chrono::system_clock::now());
}

void IngestReactor::OnDone() {
  {
    // gRPC calls OnDone after every other reaction returned. Taking the lock once more orders
    // the destruction after them for ThreadSanitizer too: gRPC's own synchronisation is in an
    // uninstrumented library, invisible to it.
    MutexLock lock(mutex_);
  }
  sink_->Detach();  // after this no session callback reaches the reactor
  delete this;
}

void IngestReactor::Started(const SessionInfo& session) {
  Actions actions;
  {
    MutexLock lock(mutex_);
    v1::IngestResponse response;
    ToProto(session, response.mutable_started());
    EnqueueLocked(std::move(response));
    DecideWriteOrFinishLocked(&actions);
  }
  Run(actions);
}

void IngestReactor::Ack(const FrameAckInfo& ack) {
  Actions actions;
  {
    MutexLock lock(mutex_);
    v1::IngestResponse response;
    ToProto(ack, response.mutable_ack());
    EnqueueLocked(std::move(response));
    DecideWriteOrFinishLocked(&actions);
  }
  Run(actions);
}

void IngestReactor::Progress(const IngestProgressInfo& progress) {
  Actions actions;
  {
    MutexLock lock(mutex_);
    if (progress_queued_) {
      // Replace the queued progress with the newer one: progress never piles up.
      // Reverse iterators, not std::views::reverse: clang 14 (the tsan build) cannot compile
      // libstdc++ 12's <ranges>.
      // NOLINTNEXTLINE(modernize-loop-convert)
      for (auto it = outgoing_.rbegin(); it != outgoing_.rend(); ++it) {
        if (it->has_progress()) {
          ToProto(progress, it->mutable_progress());
          break;
        }
      }
    } else {
      v1::IngestResponse response;
      ToProto(progress, response.mutable_progress());
      EnqueueLocked(std::move(response));
      progress_queued_ = !outgoing_.empty();
    }
    DecideWriteOrFinishLocked(&actions);
  }
  Run(actions);
}

void IngestReactor::QueueRoom() {
  Actions actions;
  {
    MutexLock lock(mutex_);
    DecideReadLocked(&actions);
  }
  Run(actions);
}

void IngestReactor::Finished(const Status& status, const IngestSummaryInfo& summary) {
  Actions actions;
  {
    MutexLock lock(mutex_);
    v1::IngestResponse response;
    ToProto(summary, response.mutable_summary());
    EnqueueLocked(std::move(response));
    reads_closed_ = true;
    finish_status_ = ToGrpcStatus(status);
    DecideWriteOrFinishLocked(&actions);
  }
  Run(actions);
}

}  // namespace semmap
