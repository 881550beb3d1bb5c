// Server-streaming reactor that writes a prepared list of messages one by one, then finishes.
// Queries build their answer up front (bounded by the store), so streaming is just pacing.
#pragma once

#include <grpcpp/grpcpp.h>

#include <utility>
#include <vector>

namespace semmap {

template <typename Response>
class MessageStreamReactor final : public grpc::ServerWriteReactor<Response> {
 public:
  explicit MessageStreamReactor(std::vector<Response> messages) : messages_(std::move(messages)) {
    Next();
  }
  explicit MessageStreamReactor(const grpc::Status& error) { this->Finish(error); }

  void OnWriteDone(bool ok) override {
    if (!ok) {
      this->Finish(grpc::Status(grpc::StatusCode::CANCELLED, "client stopped reading"));
      return;
    }
    Next();
  }
  void OnDone() override { delete this; }

 private:
  void Next() {
    if (next_ < messages_.size()) {
      this->StartWrite(&messages_[next_++]);
    } else {
      this->Finish(grpc::Status::OK);
    }
  }

  std::vector<Response> messages_;
  size_t next_ = 0;
};

}  // namespace semmap
