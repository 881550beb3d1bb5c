// One ingest stream's pipeline, two stages joined by bounded queues: a decoder thread drains
// the input queue and decodes images (PNG/JPEG decoding costs about as much as tracking, so it
// overlaps with the previous frame's tracking); the worker thread checks the protocol
// (FrameProtocol), turns frames into poses and write batches (FrameIngestor), hands them to the
// storage writer and the map's pipeline, and reports (SessionReport, CommitTracker).
//
// Owned by the IngestManager alone (transports hold an IngestSessionHandle); destroyed on the
// manager's reaper thread after `on_finished`, never on one of the session's own threads.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <thread>

#include "common/bounded_queue.h"
#include "common/token_bucket.h"
#include "core/pipeline/commit_tracker.h"
#include "core/pipeline/frame_ingestor.h"
#include "core/pipeline/ingest_options.h"
#include "core/pipeline/ingest_protocol.h"
#include "core/pipeline/ingest_types.h"
#include "core/pipeline/map_pipeline.h"
#include "core/pipeline/session_report.h"
#include "storage/storage_writer.h"

namespace semmap {

// The map pipeline a session streams into (created or found by the owner; a visual session's
// has its SLAM back end running).
using MapPipelineProvider =
    std::function<StatusOr<std::shared_ptr<MapPipeline>>(const SessionInfo& session, bool visual)>;

class IngestSession {
 public:
  // Starts the session's two threads (through options.launch_thread). `pipelines` may be empty:
  // visual sessions then run their front end alone (no loop closure) and no map layers are
  // built. `on_finished` (may be empty) runs once on the worker thread as its last action,
  // after the sink's OnFinished: the owner may then destroy the session (not from inside the
  // callback). RESOURCE_EXHAUSTED when a thread cannot be started (nothing is left running).
  static StatusOr<std::unique_ptr<IngestSession>> Start(std::shared_ptr<IngestSink> sink,
                                                        StorageWriter* writer,
                                                        IngestOptions options,
                                                        MapPipelineProvider pipelines = nullptr,
                                                        std::function<void()> on_finished = {});
  // Stops the stream (as Stop) and joins both threads.
  ~IngestSession();
  IngestSession(const IngestSession&) = delete;
  IngestSession& operator=(const IngestSession&) = delete;

  // Decoded frames waiting for the worker: small, the input queue is the buffer. A session holds
  // at most queue_capacity + kStagedCapacity + 1 (being decoded) frames.
  static constexpr size_t kStagedCapacity = 2;

  // Never blocks. False when the queue is full: pause reading until IngestSink::OnQueueRoom.
  // A frame over the operator's frame-rate limit is queued as the IngestInvalid that ends the
  // stream (RESOURCE_EXHAUSTED): `message` holds it afterwards. Calls are serialised by the
  // caller (the session's handle).
  bool TryEnqueue(IngestMessage& message);
  bool HasRoom() const { return queue_.size() < queue_.capacity(); }

  // The client went away (or its deadline passed): store what is queued, then finish with
  // CANCELLED.
  void Cancel(bool deadline_passed = false);
  // The server is stopping: store what is queued, then finish with UNAVAILABLE.
  void Stop();
  bool finished() const { return finished_.load(); }
  // The map the session streams into; 0 until its start message was accepted.
  int64_t map_id() const { return map_id_.load(); }

 private:
  IngestSession(std::shared_ptr<IngestSink> sink, StorageWriter* writer, IngestOptions options,
                MapPipelineProvider pipelines, std::function<void()> on_finished);

  // A message on its way from the decoder to the worker: frames carry their decoded images
  // (or the decoding error) next to the wire message, which keyframes store as received.
  struct DecodedImages {
    cv::Mat colour;
    std::optional<DecodedDepth> depth;
  };
  struct StagedMessage {
    IngestMessage message;
    std::optional<StatusOr<DecodedImages>> images;  // frames that were worth decoding
    double decode_ms = 0;
    bool idle_timeout = false;  // the message is the decoder's IngestInvalid after the timeout
  };

  void RunDecoder();
  void Run();
  static StatusOr<DecodedImages> DecodeImages(const IngestFrame& frame, int width, int height);
  Status Handle(StagedMessage& staged);
  Status HandleStart(const IngestStartRequest& start);
  FrameProcessorContext ProcessorContext() const;
  Status HandleFrame(IngestFrame& frame, std::optional<StatusOr<DecodedImages>>& images);
  Status Submit(WriteBatch batch, uint64_t seq);
  void OnCommitted(const Status& status, uint64_t seq, double latency_ms);
  // `reason` is how the stream ended as the worker saw it; a failing drain or write turns a
  // completed end into an error.
  void Finish(Status status, SessionEndReason reason);

  std::shared_ptr<IngestSink> sink_;
  StorageWriter* writer_;
  const IngestOptions options_;
  const std::function<void()> on_finished_;
  BoundedQueue<IngestMessage> queue_;
  std::optional<TokenBucket> frame_rate_;  // options.max_frames_per_second, set
  BoundedQueue<StagedMessage> staged_{kStagedCapacity};

  // Worker-thread state.
  MapPipelineProvider pipelines_;
  FrameProtocol protocol_;
  std::optional<SessionInfo> row_;           // the session's stored row, once created
  std::unique_ptr<FrameIngestor> ingestor_;  // from the accepted start message on
  bool ended_ = false;
  SessionReport report_;
  CommitTracker commits_;  // shared with the writer thread's commit callbacks

  std::atomic<int> stop_reason_{0};  // 0 none, 1 cancelled, 2 server stop, 3 deadline passed
  std::atomic<int64_t> map_id_{0};
  std::atomic<bool> finished_{false};
  std::thread decoder_;
  std::thread worker_;
};

}  // namespace semmap
