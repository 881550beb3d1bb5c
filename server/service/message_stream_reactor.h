// Server-streaming reactor that writes a prepared list of messages one by one, then finishes.
// Queries build their answer up front (bounded by the store), so streaming is just pacing. The
// methods are raw (byte buffers, see wire_parsing.h): the messages are serialised here.
#pragma once

#include <grpcpp/grpcpp.h>

#include <utility>
#include <vector>

#include "server/serialization/conversions.h"
#include "server/serialization/wire_parsing.h"

namespace semmap {

class MessageStreamReactor final : public grpc::ServerWriteReactor<grpc::ByteBuffer> {
 public:
  template <typename Response>
  explicit MessageStreamReactor(const std::vector<Response>& messages) {
    buffers_.reserve(messages.size());
    for (const Response& message : messages) {
      const Status serialized = SerializeWire(message, &buffers_.emplace_back());
      if (!serialized.ok()) {
        Finish(ToGrpcStatus(serialized));
        return;
      }
    }
    Next();
  }
  explicit MessageStreamReactor(const grpc::Status& error) { Finish(error); }

  void OnWriteDone(bool ok) override {
    if (!ok) {
      Finish(grpc::Status(grpc::StatusCode::CANCELLED, "client stopped reading"));
      return;
    }
    Next();
  }
  void OnDone() override { delete this; }

 private:
  void Next() {
    if (next_ < buffers_.size()) {
      StartWrite(&buffers_[next_++]);
    } else {
      Finish(grpc::Status::OK);
    }
  }

  std::vector<grpc::ByteBuffer> buffers_;
  size_t next_ = 0;
};

}  // namespace semmap
