// What a session reports about itself: frame counters, the per-stage latencies of the worker,
// the summary the client gets at the end, and the operator's log line. Counters read by the
// writer thread's progress callbacks are atomic; everything else belongs to the worker thread.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>

#include "common/latency_stats.h"
#include "core/pipeline/frame_processor.h"
#include "core/pipeline/ingest_types.h"
#include "core/pipeline/map_pipeline.h"

namespace semmap {

class SessionReport {
 public:
  SessionReport() : started_at_(std::chrono::steady_clock::now()) {}

  void Received() { received_.fetch_add(1); }
  // A frame was processed, acknowledged or not yet.
  void Processed(const FrameEstimate& estimate);

  // Worker-thread stage timings (milliseconds).
  LatencyStats& decode_ms() { return decode_ms_; }
  LatencyStats& tracking_ms() { return tracking_ms_; }
  // Tracking's parts, from the tracker's own timings (RGBD sessions).
  void AddTrackingParts(const TrackingTimings& parts);
  LatencyStats& keyframe_ms() { return keyframe_ms_; }
  LatencyStats& frame_ms() { return frame_ms_; }

  // Any thread.
  IngestProgressInfo Progress(std::optional<uint64_t> durable_seq, uint32_t queue_depth) const;
  // The worker, at the end: the summary, the stages in the documented order (decode, tracking,
  // keyframe, storage_commit, frame, tracking_extract, tracking_match, tracking_pose, then the
  // map's).
  IngestSummaryInfo Summary(const SessionInfo* session, const LatencySummary& storage_commit,
                            std::optional<uint64_t> durable_seq, MapSessionReport map) const;
  // One line per session for operators: what the map's back end did so far.
  void LogEnd(const SessionInfo& session, const MapSessionReport& map) const;

 private:
  std::chrono::steady_clock::time_point started_at_;
  std::atomic<uint64_t> received_{0};
  std::atomic<uint64_t> frames_{0};
  std::atomic<uint64_t> keyframes_{0};
  uint64_t lost_frames_ = 0;
  uint64_t segments_ = 0;  // restarts after a sustained tracking loss
  LatencyStats decode_ms_{"decode"};
  LatencyStats tracking_ms_{"tracking"};
  LatencyStats keyframe_ms_{"keyframe"};
  LatencyStats frame_ms_{"frame"};
  LatencyStats tracking_extract_ms_{"tracking_extract"};
  LatencyStats tracking_match_ms_{"tracking_match"};
  LatencyStats tracking_pose_ms_{"tracking_pose"};
};

}  // namespace semmap
