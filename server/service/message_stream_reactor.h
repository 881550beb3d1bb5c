// Server-streaming reactor that writes a prepared list of messages one by one, then finishes.
// Queries build their answer up front (bounded by the store), so streaming is just pacing. The
// methods are raw (byte buffers, see wire_parsing.h): the messages are serialised here. The
// handler returns the reactor at once; the answer, built on a worker, arrives by Send or Fail
// (from any thread, once).
#pragma once

#include <grpcpp/grpcpp.h>

#include <utility>
#include <vector>

#include "common/thread_annotations.h"
#include "server/serialization/conversions.h"
#include "server/serialization/wire_parsing.h"

namespace semmap {

class MessageStreamReactor final : public grpc::ServerWriteReactor<grpc::ByteBuffer> {
 public:
  MessageStreamReactor() = default;  // waits for Send or Fail
  template <typename Response>
  explicit MessageStreamReactor(const std::vector<Response>& messages) {
    Send(messages);
  }
  explicit MessageStreamReactor(const grpc::Status& error) { Fail(error); }

  template <typename Response>
  void Send(const std::vector<Response>& messages) {
    Status serialized = OkStatus();
    {
      MutexLock lock(mutex_);
      buffers_.reserve(messages.size());
      for (const Response& message : messages) {
        serialized = SerializeWire(message, &buffers_.emplace_back());
        if (!serialized.ok()) break;
      }
    }
    if (!serialized.ok()) {
      Finish(ToGrpcStatus(serialized));
      return;
    }
    Next();
  }
  void Fail(const grpc::Status& error) { Finish(error); }

  void OnWriteDone(bool ok) override {
    if (!ok) {
      Finish(grpc::Status(grpc::StatusCode::CANCELLED, "client stopped reading"));
      return;
    }
    Next();
  }
  void OnDone() override {
    { MutexLock lock(mutex_); }  // see mutex_
    delete this;
  }

 private:
  void Next() SEMMAP_EXCLUDES(mutex_) {
    const grpc::ByteBuffer* buffer = nullptr;
    {
      MutexLock lock(mutex_);
      if (next_ < buffers_.size()) buffer = &buffers_[next_++];
    }
    if (buffer != nullptr) {
      StartWrite(buffer);
    } else {
      Finish(grpc::Status::OK);
    }
  }

  // gRPC runs this reactor's reactions one at a time and OnDone last, but it orders them in an
  // uninstrumented library that ThreadSanitizer cannot see into; the (never contended) lock
  // makes that order visible. gRPC is never called while it is held.
  Mutex mutex_;
  std::vector<grpc::ByteBuffer> buffers_ SEMMAP_GUARDED_BY(mutex_);
  size_t next_ SEMMAP_GUARDED_BY(mutex_) = 0;
};

}  // namespace semmap
