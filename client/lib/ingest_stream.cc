#include "client/lib/ingest_stream.h"

#include "server/serialization/conversions.h"

namespace semmap {

StatusOr<std::unique_ptr<IngestStream>> IngestStream::Open(v1::MapService::Stub* stub,
                                                           const v1::IngestStart& start,
                                                           AckCallback on_ack,
                                                           const std::string& token) {
  std::unique_ptr<IngestStream> stream(new IngestStream());
  stream->on_ack_ = std::move(on_ack);
  if (!token.empty()) stream->context_.AddMetadata("authorization", "Bearer " + token);
  stream->stream_ = stub->Ingest(&stream->context_);
  v1::IngestRequest request;
  *request.mutable_start() = start;
  const bool sent = stream->stream_->Write(request);
  stream->reader_ = std::thread([s = stream.get()] { s->ReadLoop(); });
  if (!sent) return stream->FinalStatus();
  // Wait for `started` (or the stream's end) so a refused start is reported here.
  std::unique_lock lock(stream->mutex_);
  stream->changed_.wait(lock, [&] { return stream->got_started_ || stream->reader_done_; });
  if (!stream->got_started_) {
    lock.unlock();
    return stream->FinalStatus();
  }
  return stream;
}

IngestStream::~IngestStream() {
  bool done;
  {
    std::lock_guard lock(mutex_);
    done = final_status_.has_value();
  }
  if (!done) {
    context_.TryCancel();
    Status ignored = FinalStatus();
    (void)ignored;
  }
  if (reader_.joinable()) reader_.join();
}

void IngestStream::ReadLoop() {
  v1::IngestResponse response;
  while (stream_->Read(&response)) {
    if (response.has_ack() && on_ack_) on_ack_(response.ack());  // outside the lock
    std::lock_guard lock(mutex_);
    switch (response.msg_case()) {
      case v1::IngestResponse::kStarted:
        started_ = response.started();
        got_started_ = true;
        break;
      case v1::IngestResponse::kAck:
        ++acks_;
        if (response.ack().has_durable_seq()) durable_seq_ = response.ack().durable_seq();
        break;
      case v1::IngestResponse::kProgress:
        if (response.progress().has_durable_seq()) {
          durable_seq_ = response.progress().durable_seq();
        }
        break;
      case v1::IngestResponse::kSummary:
        summary_ = response.summary();
        if (summary_->has_durable_seq()) durable_seq_ = summary_->durable_seq();
        break;
      case v1::IngestResponse::MSG_NOT_SET:
        break;
    }
    changed_.notify_all();
  }
  std::lock_guard lock(mutex_);
  reader_done_ = true;
  changed_.notify_all();
}

Status IngestStream::FinalStatus() {
  {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return reader_done_; });
    if (final_status_) return *final_status_;
  }
  if (reader_.joinable() && reader_.get_id() != std::this_thread::get_id()) reader_.join();
  Status status = FromGrpcStatus(stream_->Finish());
  std::lock_guard lock(mutex_);
  final_status_ = status;
  return status;
}

Status IngestStream::Write(v1::Frame&& frame) {
  v1::IngestRequest request;
  *request.mutable_frame() = std::move(frame);
  if (stream_->Write(request)) return OkStatus();
  // The server ended the stream: its status says why.
  const Status status = FinalStatus();
  return status.ok() ? AbortedError("the server ended the stream early") : status;
}

StatusOr<v1::IngestSummary> IngestStream::Finish() {
  v1::IngestRequest request;
  request.mutable_end();
  stream_->Write(request);  // failure shows up in the final status
  stream_->WritesDone();
  SEMMAP_RETURN_IF_ERROR(FinalStatus());
  std::lock_guard lock(mutex_);
  if (!summary_) return InternalError("the server ended the stream without a summary");
  return *summary_;
}

void IngestStream::Cancel() { context_.TryCancel(); }

std::optional<uint64_t> IngestStream::durable_seq() const {
  std::lock_guard lock(mutex_);
  return durable_seq_;
}

uint64_t IngestStream::acks() const {
  std::lock_guard lock(mutex_);
  return acks_;
}

}  // namespace semmap
