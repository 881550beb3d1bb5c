#include "core/pipeline/session_report.h"

#include <utility>

#include "common/logging.h"

namespace semmap {

void SessionReport::Processed(const FrameEstimate& estimate) {
  frames_.fetch_add(1);
  if (estimate.is_keyframe) keyframes_.fetch_add(1);
  if (estimate.lost) ++lost_frames_;
  if (estimate.new_segment) ++segments_;
}

IngestProgressInfo SessionReport::Progress(std::optional<uint64_t> durable_seq,
                                           uint32_t queue_depth) const {
  IngestProgressInfo progress;
  progress.durable_seq = durable_seq;
  progress.frames_received = received_.load();
  progress.frames_processed = frames_.load();
  progress.keyframes = keyframes_.load();
  progress.queue_depth = queue_depth;
  return progress;
}

IngestSummaryInfo SessionReport::Summary(const SessionInfo* session,
                                         const LatencySummary& storage_commit,
                                         std::optional<uint64_t> durable_seq,
                                         MapSessionReport map) const {
  IngestSummaryInfo summary;
  if (session != nullptr) {
    summary.map = session->map_name;
    summary.session = session->name;
  }
  summary.frames = frames_.load();
  summary.lost_frames = lost_frames_;
  summary.new_segments = segments_;
  summary.loop_closures = map.loop_closures;
  summary.keyframes = keyframes_.load();
  summary.durable_seq = durable_seq;
  summary.duration_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started_at_).count();
  summary.stages = {decode_ms_.Summarize(),         tracking_ms_.Summarize(),
                    keyframe_ms_.Summarize(),       storage_commit,
                    frame_ms_.Summarize(),          tracking_extract_ms_.Summarize(),
                    tracking_match_ms_.Summarize(), tracking_pose_ms_.Summarize()};
  for (LatencySummary& stage : map.stages) summary.stages.push_back(std::move(stage));
  return summary;
}

namespace {

double Mib(size_t bytes) { return static_cast<double>(bytes) / (1024.0 * 1024.0); }

}  // namespace

void SessionReport::AddTrackingParts(const TrackingTimings& parts) {
  tracking_extract_ms_.Add(parts.extract_ms);
  tracking_match_ms_.Add(parts.match_ms);
  tracking_pose_ms_.Add(parts.pose_ms);
}

void SessionReport::LogEnd(const SessionInfo& session, const MapSessionReport& map) const {
  if (!map.backend) return;
  const SlamBackendStats& stats = *map.backend;
  LogInfo(
      "session '{}' of map '{}' ended: {} lost frames, {} restarts; map back end: {} "
      "keyframes ({} restored, {} culled as redundant), {} restored map points, {} loop "
      "candidates, {} accepted, {} rejected by geometry, {} "
      "by xi, {} taken back by the graph, {} optimisations ({} failed), queue high water {}; "
      "local BA: {} runs ({} failed, {} time-limited, {} shrunk, {} skipped), p50 {:.1f} ms, "
      "{} outlier observations removed, {} map points ({} observations), {} culled, {} fused "
      "across loops; point fusion: {} observations joined, {} duplicates fused; holds ~{:.1f} MiB "
      "(features {:.1f}, place index {:.1f}, map points {:.1f}); keyframe features {} released, "
      "{} read back, {} unreadable",
      session.name, session.map_name, lost_frames_, segments_, stats.keyframes,
      stats.restored_keyframes, stats.keyframes_culled, stats.restored_map_points, stats.candidates,
      stats.loops_accepted, stats.rejected_geometry, stats.rejected_xi, stats.rejected_inconsistent,
      stats.optimisations, stats.failed_optimisations, stats.queue_high_water, stats.local_ba_runs,
      stats.local_ba_failures, stats.local_ba_time_limited, stats.local_ba_shrunk,
      stats.local_ba_skipped, stats.local_ba_ms.p50_ms, stats.ba_outliers_removed, stats.map_points,
      stats.map_point_observations, stats.map_points_culled, stats.map_points_fused,
      stats.map_point_observations_joined, stats.map_points_fused_by_projection,
      Mib(stats.features_bytes + stats.place_index_bytes + stats.map_point_bytes),
      Mib(stats.features_bytes), Mib(stats.place_index_bytes), Mib(stats.map_point_bytes),
      stats.features_released, stats.features_read_back, stats.features_unreadable);
}

}  // namespace semmap
