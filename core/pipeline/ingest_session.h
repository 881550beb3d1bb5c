// One ingest stream's pipeline, two stages joined by bounded queues: a decoder thread drains
// the input queue and decodes images (PNG/JPEG decoding costs about as much as tracking, so it
// overlaps with the previous frame's tracking); the worker thread validates, estimates the pose,
// decides keyframes and hands batches to the storage writer and the SLAM back end.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <thread>

#include "common/bounded_queue.h"
#include "common/latency_stats.h"
#include "core/pipeline/frame_processor.h"
#include "core/pipeline/ingest_options.h"
#include "core/pipeline/ingest_types.h"
#include "core/pipeline/map_pipeline.h"
#include "core/slam/slam_backend.h"
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
  // built. RESOURCE_EXHAUSTED when a thread cannot be started (nothing is left running).
  static StatusOr<std::shared_ptr<IngestSession>> Start(std::shared_ptr<IngestSink> sink,
                                                        StorageWriter* writer,
                                                        IngestOptions options,
                                                        MapPipelineProvider pipelines = nullptr);
  ~IngestSession();  // stops and joins the worker
  IngestSession(const IngestSession&) = delete;
  IngestSession& operator=(const IngestSession&) = delete;

  // Decoded frames waiting for the worker: small, the input queue is the buffer. A session holds
  // at most queue_capacity + kStagedCapacity + 1 (being decoded) frames.
  static constexpr size_t kStagedCapacity = 2;

  // Never blocks. False when the queue is full: pause reading until IngestSink::OnQueueRoom.
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
                MapPipelineProvider pipelines);

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
  Status HandleFrame(IngestFrame& frame, std::optional<StatusOr<DecodedImages>>& images);
  // Order, size and presence checks first (their errors win), then the decoded images.
  StatusOr<DecodedFrame> Validate(const IngestFrame& frame,
                                  std::optional<StatusOr<DecodedImages>>& images) const;
  Status SubmitFrame(const DecodedFrame& frame, const IngestFrame& wire,
                     const FrameEstimate& estimate);
  void OnCommitted(const Status& status, uint64_t seq,
                   std::chrono::steady_clock::time_point submitted_at);
  // `reason` is how the stream ended as the worker saw it; a failing drain or write turns a
  // completed end into an error.
  void Finish(Status status, SessionEndReason reason);
  // A keyframe goes to the map's consumers (layers, objects), after its write was submitted.
  Status PublishKeyframe(const DecodedFrame& frame, const FrameEstimate& estimate);
  // Hands the frame (and its keyframe) to the back end, after its write was submitted.
  Status FeedBackend(const DecodedFrame& frame, const FrameEstimate& estimate,
                     const std::optional<uint64_t>& previous_keyframe_seq,
                     const Eigen::Isometry3d& T_world_previous_keyframe);
  void ApplyPendingCorrection();
  std::optional<uint64_t> durable_seq() const;

  std::shared_ptr<IngestSink> sink_;
  StorageWriter* writer_;
  const IngestOptions options_;
  BoundedQueue<IngestMessage> queue_;
  BoundedQueue<StagedMessage> staged_{kStagedCapacity};

  // Worker-thread state.
  std::optional<SessionInfo> session_;
  std::unique_ptr<FrameProcessor> processor_;
  MapPipelineProvider pipelines_;
  std::shared_ptr<MapPipeline> map_;  // released when the session finishes
  SlamBackend* backend_ = nullptr;    // map_'s, for visual sessions
  // Corrections from the back end's thread, applied before the next frame is tracked.
  std::mutex correction_mutex_;
  std::optional<Eigen::Isometry3d> pending_correction_;
  std::optional<uint64_t> last_seq_;
  std::optional<uint64_t> last_keyframe_seq_;
  Eigen::Isometry3d last_keyframe_pose_ = Eigen::Isometry3d::Identity();
  bool ended_ = false;
  std::chrono::steady_clock::time_point started_at_;
  // Worker-thread stage timings (storage_commit_ms_ is guarded by commit_mutex_).
  LatencyStats decode_ms_{"decode"};
  LatencyStats tracking_ms_{"tracking"};
  LatencyStats keyframe_ms_{"keyframe"};
  LatencyStats frame_ms_{"frame"};

  // Shared with the writer thread's commit callbacks.
  mutable std::mutex commit_mutex_;
  std::condition_variable all_committed_;
  size_t pending_writes_ = 0;
  std::optional<uint64_t> durable_seq_;
  Status write_error_;
  LatencyStats storage_commit_ms_{"storage_commit"};

  std::atomic<uint64_t> received_{0};
  std::atomic<uint64_t> frames_{0};  // read by commit callbacks for progress
  std::atomic<uint64_t> keyframes_{0};
  uint64_t lost_frames_ = 0;
  uint64_t segments_ = 0;            // restarts after a sustained tracking loss
  std::atomic<int> stop_reason_{0};  // 0 none, 1 cancelled, 2 server stop, 3 deadline passed
  std::atomic<int64_t> map_id_{0};
  std::atomic<bool> finished_{false};
  std::thread decoder_;
  std::thread worker_;
};

}  // namespace semmap
