// Client side of one Ingest stream. Write() blocks while the server pushes back (HTTP/2 flow
// control), so a slow server slows the client down instead of buffering frames anywhere.
#pragma once

#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "common/status.h"
#include "semmap/v1/service.grpc.pb.h"

namespace semmap {

class IngestStream {
 public:
  // Runs on the stream's reader thread for every ack, in seq order.
  using AckCallback = std::function<void(const v1::FrameAck&)>;

  // `token`: sent as the bearer token when not empty.
  static StatusOr<std::unique_ptr<IngestStream>> Open(v1::MapService::Stub* stub,
                                                      const v1::IngestStart& start,
                                                      AckCallback on_ack,
                                                      const std::string& token = "");
  ~IngestStream();  // cancels the stream if Finish() was not called

  // Sends one frame (its bytes are moved, not copied). Fails with the stream's final status once
  // the server has ended it.
  Status Write(v1::Frame&& frame);
  // Sends end, closes the write side and waits for the summary and the final status.
  StatusOr<v1::IngestSummary> Finish();
  // Breaks the stream off (the server stores what it received).
  void Cancel();

  const v1::IngestStarted& started() const { return started_; }
  std::optional<uint64_t> durable_seq() const;
  uint64_t acks() const;

 private:
  IngestStream() = default;
  void ReadLoop();
  Status FinalStatus();

  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::IngestRequest, v1::IngestResponse>> stream_;
  AckCallback on_ack_;
  v1::IngestStarted started_;
  std::thread reader_;

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool got_started_ = false;
  bool reader_done_ = false;
  std::optional<v1::IngestSummary> summary_;
  std::optional<uint64_t> durable_seq_;
  uint64_t acks_ = 0;
  std::optional<Status> final_status_;
};

}  // namespace semmap
