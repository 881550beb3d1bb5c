#include "core/pipeline/ingest_session.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <string>
#include <utility>

#include "common/logging.h"
#include "common/name_validation.h"
#include "common/thread_launcher.h"
#include "common/time_util.h"
#include "core/sensor/image_decoding.h"
#include "core/slam/feature_codec.h"

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

// The information of a visual estimate, or a weak one (unit, i.e. about one pixel's worth
// per unit of motion) when the mode measures none, so the pose graph stays well posed.
Eigen::Matrix<double, 6, 6> OdometryInformation(const FrameEstimate& estimate) {
  if (estimate.information.allFinite() && estimate.information.diagonal().minCoeff() > 0) {
    return estimate.information;
  }
  return Eigen::Matrix<double, 6, 6>::Identity();
}

constexpr int kStopCancelled = 1;
constexpr int kStopServer = 2;
constexpr int kStopDeadline = 3;

// Stored seqs are SQLite integers (int64).
constexpr uint64_t kMaxSeq = static_cast<uint64_t>(std::numeric_limits<int64_t>::max());

// "s-20261122-013045": readable, sortable, unique enough; a suffix resolves collisions.
std::string GeneratedSessionName() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buf[32];
  std::strftime(buf, sizeof(buf), "s-%Y%m%d-%H%M%S", &utc);
  return buf;
}

}  // namespace

StatusOr<std::shared_ptr<IngestSession>> IngestSession::Start(std::shared_ptr<IngestSink> sink,
                                                              StorageWriter* writer,
                                                              IngestOptions options,
                                                              MapPipelineProvider pipelines) {
  std::shared_ptr<IngestSession> session(
      new IngestSession(std::move(sink), writer, std::move(options), std::move(pipelines)));
  const ThreadLauncher& launch =
      session->options_.launch_thread ? session->options_.launch_thread : LaunchThread;
  IngestSession* raw = session.get();
  StatusOr<std::thread> decoder = launch([raw] { raw->RunDecoder(); });
  if (decoder.ok()) {
    session->decoder_ = std::move(decoder).value();
    StatusOr<std::thread> worker = launch([raw] { raw->Run(); });
    if (worker.ok()) {
      session->worker_ = std::move(worker).value();
      return session;
    }
    decoder = worker.status();
  }
  // The destructor stops and joins whatever did start; the session never reports anything.
  session->finished_.store(true);
  return decoder.status().WithContext("ingest stream");
}

IngestSession::IngestSession(std::shared_ptr<IngestSink> sink, StorageWriter* writer,
                             IngestOptions options, MapPipelineProvider pipelines)
    : sink_(std::move(sink)),
      writer_(writer),
      options_(std::move(options)),
      queue_(options_.queue_capacity),
      pipelines_(std::move(pipelines)),
      started_at_(std::chrono::steady_clock::now()) {}

IngestSession::~IngestSession() {
  Stop();
  staged_.Shutdown();
  // The last reference can be dropped by a callback running on one of the session's own
  // threads (through the sink); they touch no member after that, so letting it exit is safe.
  for (std::thread* thread : {&decoder_, &worker_}) {
    if (!thread->joinable()) continue;
    if (thread->get_id() == std::this_thread::get_id()) {
      thread->detach();
    } else {
      thread->join();
    }
  }
}

bool IngestSession::TryEnqueue(IngestMessage& message) {
  if (!queue_.TryPush(message)) return false;
  received_.fetch_add(1);
  return true;
}

void IngestSession::Cancel(bool deadline_passed) {
  int none = 0;
  stop_reason_.compare_exchange_strong(none, deadline_passed ? kStopDeadline : kStopCancelled);
  queue_.Shutdown();
}

void IngestSession::Stop() {
  int none = 0;
  stop_reason_.compare_exchange_strong(none, kStopServer);
  queue_.Shutdown();
}

void IngestSession::RunDecoder() {
  std::optional<std::pair<int, int>> size;  // of the start message's camera
  const auto idle_timeout = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.idle_timeout_s));
  for (;;) {
    std::optional<IngestMessage> message =
        options_.idle_timeout_s > 0 ? queue_.PopFor(idle_timeout) : queue_.Pop();
    if (!message && !queue_.is_shutdown()) {
      // Nothing from the client for the whole timeout: end the session, keeping what it sent.
      StagedMessage timeout;
      timeout.idle_timeout = true;
      char seconds[32];
      std::snprintf(seconds, sizeof(seconds), "%g", options_.idle_timeout_s);
      timeout.message = IngestInvalid{
          DeadlineExceededError(std::string("no message from the client for ") + seconds +
                                " s (the server's idle timeout, semmapd --stream-idle-timeout-s)")};
      queue_.Shutdown();
      if (staged_.Push(std::move(timeout))) staged_.Shutdown();
      return;
    }
    if (!message) break;
    sink_->OnQueueRoom();
    StagedMessage staged;
    if (const auto* start = std::get_if<IngestStartRequest>(&*message)) {
      if (!size) size = std::make_pair(start->camera.width, start->camera.height);
    } else if (const auto* frame = std::get_if<IngestFrame>(&*message)) {
      // Frames the worker will refuse anyway (no start, too large, no colour) are not decoded.
      if (size && frame->colour && frame->payload_bytes <= options_.max_frame_bytes) {
        const Clock::time_point t0 = Clock::now();
        staged.images = DecodeImages(*frame, size->first, size->second);
        staged.decode_ms = MillisecondsSince(t0);
      }
    }
    staged.message = std::move(*message);
    if (!staged_.Push(std::move(staged))) return;  // the worker finished early
  }
  staged_.Shutdown();  // the worker drains what is staged, then sees the end
}

void IngestSession::Run() {
  while (std::optional<StagedMessage> staged = staged_.Pop()) {
    Status status = Handle(*staged);
    if (!status.ok()) {
      Finish(std::move(status),
             staged->idle_timeout ? SessionEndReason::kIdleTimeout : SessionEndReason::kError);
      return;
    }
    if (ended_) {
      Finish(OkStatus(), SessionEndReason::kCompleted);
      return;
    }
  }
  // The queue was shut down and drained before the client's end message.
  switch (stop_reason_.load()) {
    case kStopCancelled:
      Finish(CancelledError("the client cancelled the stream"), SessionEndReason::kCancelled);
      break;
    case kStopDeadline:
      Finish(DeadlineExceededError("the call's deadline passed"), SessionEndReason::kCancelled);
      break;
    default:
      Finish(UnavailableError("the server is shutting down"), SessionEndReason::kServerStopped);
      break;
  }
}

Status IngestSession::Handle(StagedMessage& staged) {
  IngestMessage& message = staged.message;
  {
    std::lock_guard lock(commit_mutex_);
    if (!write_error_.ok()) return write_error_;
  }
  if (auto* invalid = std::get_if<IngestInvalid>(&message)) return invalid->status;
  if (auto* start = std::get_if<IngestStartRequest>(&message)) {
    if (session_) return InvalidArgumentError("a second start message in the same stream");
    return HandleStart(*start);
  }
  if (!session_) return InvalidArgumentError("the first message of an ingest stream must be start");
  if (auto* frame = std::get_if<IngestFrame>(&message)) {
    if (staged.images) decode_ms_.Add(staged.decode_ms);
    return HandleFrame(*frame, staged.images);
  }
  ended_ = true;  // IngestEnd
  return OkStatus();
}

Status IngestSession::HandleStart(const IngestStartRequest& start) {
  SEMMAP_RETURN_IF_ERROR(ValidateName("map", start.map));
  if (!start.session.empty()) SEMMAP_RETURN_IF_ERROR(ValidateName("session", start.session));
  if (!start.mode) return InvalidArgumentError("start.mode is unspecified");
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(start.camera).WithContext("start.camera"));
  KeyframePolicyOptions kf = options_.keyframes;
  if (start.keyframe_min_motion != 0) kf.min_motion = start.keyframe_min_motion;
  if (start.keyframe_rotation_weight != 0) kf.rotation_weight = start.keyframe_rotation_weight;
  SEMMAP_RETURN_IF_ERROR(kf.Validate().WithContext("start.keyframes"));
  SEMMAP_ASSIGN_OR_RETURN(processor_,
                          MakeFrameProcessor(*start.mode, kf, options_.tracker, start.camera));

  SessionInfo created;
  Status status = writer_->RunSync([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(MapInfo map, store.GetOrCreateMap(start.map));
    SessionInfo info;
    info.map_id = map.id;
    info.mode = *start.mode;
    info.camera = start.camera;
    info.started_unix_ns = UnixNowNs();
    if (!start.session.empty()) {
      info.name = start.session;
      SEMMAP_ASSIGN_OR_RETURN(created, store.CreateSession(info));
      return OkStatus();
    }
    const std::string base = GeneratedSessionName();
    for (int attempt = 1; attempt <= 100; ++attempt) {
      info.name = attempt == 1 ? base : base + "-" + std::to_string(attempt);
      StatusOr<SessionInfo> result = store.CreateSession(info);
      if (result.ok()) {
        created = std::move(result).value();
        return OkStatus();
      }
      if (result.status().code() != StatusCode::kAlreadyExists) return result.status();
    }
    return InternalError("could not generate a unique session name");
  });
  SEMMAP_RETURN_IF_ERROR(status);
  // Visible to administrative removals before the map's pipelines are taken (ingest_manager).
  map_id_.store(created.map_id);
  if (pipelines_) {
    const bool visual = *start.mode == SessionMode::kRgbd;
    SEMMAP_ASSIGN_OR_RETURN(map_, pipelines_(created, visual));
    if (visual) backend_ = map_->backend();
  }
  if (backend_) {
    backend_->RegisterSession(created.id, created.camera, [this](const Eigen::Isometry3d& T) {
      std::lock_guard lock(correction_mutex_);
      pending_correction_ = pending_correction_ ? T * *pending_correction_ : T;
    });
  }
  session_ = created;
  sink_->OnStarted(*session_);
  return OkStatus();
}

StatusOr<IngestSession::DecodedImages> IngestSession::DecodeImages(const IngestFrame& frame,
                                                                   int width, int height) {
  const std::string where = "frame seq " + std::to_string(frame.seq);
  DecodedImages images;
  StatusOr<cv::Mat> colour = DecodeColour(*frame.colour, width, height);
  if (!colour.ok()) return colour.status().WithContext(where);
  images.colour = std::move(colour).value();
  if (frame.depth) {
    StatusOr<DecodedDepth> depth = DecodeDepth(*frame.depth, width, height);
    if (!depth.ok()) return depth.status().WithContext(where);
    images.depth = std::move(depth).value();
  }
  return images;
}

StatusOr<DecodedFrame> IngestSession::Validate(
    const IngestFrame& frame, std::optional<StatusOr<DecodedImages>>& images) const {
  if (frame.seq > kMaxSeq) {
    return InvalidArgumentError("frame seq " + std::to_string(frame.seq) +
                                " is above the largest allowed seq, 2^63 - 1");
  }
  if (last_seq_ && frame.seq <= *last_seq_) {
    return InvalidArgumentError("frame seq " + std::to_string(frame.seq) +
                                " is not greater than the previous seq " +
                                std::to_string(*last_seq_));
  }
  if (frame.payload_bytes > options_.max_frame_bytes) {
    return ResourceExhaustedError("frame seq " + std::to_string(frame.seq) + " carries " +
                                  std::to_string(frame.payload_bytes) +
                                  " image bytes; the limit is " +
                                  std::to_string(options_.max_frame_bytes));
  }
  if (!frame.stamp_ns) {
    return InvalidArgumentError("frame seq " + std::to_string(frame.seq) + " has no timestamp");
  }
  if (!frame.colour) {
    return InvalidArgumentError("frame seq " + std::to_string(frame.seq) + " has no colour image");
  }
  DecodedFrame decoded;
  decoded.seq = frame.seq;
  decoded.stamp_ns = *frame.stamp_ns;
  const std::string where = "frame seq " + std::to_string(frame.seq);
  // The decoder saw the same start (it is the first message), so every frame that got here
  // was decoded.
  if (!images) return InternalError(where + " was not decoded");
  if (!images->ok()) return images->status();
  decoded.colour = std::move(images->value().colour);
  decoded.depth = std::move(images->value().depth);
  if (frame.pose_prior) {
    Status pose_ok = ValidatePoseTq(*frame.pose_prior);
    if (!pose_ok.ok()) return pose_ok.WithContext(where + " pose_prior");
    decoded.T_world_camera_prior = ToIsometry(*frame.pose_prior);
  }
  return decoded;
}

Status IngestSession::HandleFrame(IngestFrame& frame,
                                  std::optional<StatusOr<DecodedImages>>& images) {
  const Clock::time_point t0 = Clock::now();
  SEMMAP_ASSIGN_OR_RETURN(DecodedFrame decoded, Validate(frame, images));
  ApplyPendingCorrection();
  const Clock::time_point t1 = Clock::now();
  SEMMAP_ASSIGN_OR_RETURN(FrameEstimate estimate, processor_->Process(decoded));
  tracking_ms_.Add(MillisecondsSince(t1));
  last_seq_ = frame.seq;
  if (estimate.new_segment) {
    last_keyframe_seq_.reset();  // no odometry link across the break
    ++segments_;
  }
  const std::optional<uint64_t> previous_keyframe_seq = last_keyframe_seq_;
  const Eigen::Isometry3d T_world_previous_keyframe = last_keyframe_pose_;
  SEMMAP_RETURN_IF_ERROR(SubmitFrame(decoded, frame, estimate));
  if (backend_) {
    SEMMAP_RETURN_IF_ERROR(
        FeedBackend(decoded, estimate, previous_keyframe_seq, T_world_previous_keyframe));
  }
  if (map_ && estimate.is_keyframe) SEMMAP_RETURN_IF_ERROR(PublishKeyframe(decoded, estimate));
  ++frames_;
  if (estimate.is_keyframe) ++keyframes_;
  if (estimate.lost) ++lost_frames_;

  FrameAckInfo ack;
  ack.seq = frame.seq;
  ack.T_world_camera = estimate.T_world_camera;
  ack.is_keyframe = estimate.is_keyframe;
  ack.lost = estimate.lost;
  ack.durable_seq = durable_seq();
  sink_->OnAck(ack);
  frame_ms_.Add(MillisecondsSince(t0));
  return OkStatus();
}

Status IngestSession::SubmitFrame(const DecodedFrame& frame, const IngestFrame& wire,
                                  const FrameEstimate& estimate) {
  WriteBatch batch;
  TrajectoryPose pose;
  pose.seq = static_cast<int64_t>(frame.seq);
  pose.stamp_ns = frame.stamp_ns;
  pose.T_world_camera = estimate.T_world_camera;
  pose.is_keyframe = estimate.is_keyframe;
  pose.lost = estimate.lost;
  batch.frames.emplace_back(session_->id, pose);

  if (estimate.is_keyframe) {
    const Clock::time_point t0 = Clock::now();
    KeyframeRecord kf;
    kf.session_id = session_->id;
    kf.seq = pose.seq;
    kf.stamp_ns = frame.stamp_ns;
    kf.T_world_camera = estimate.T_world_camera;
    SEMMAP_ASSIGN_OR_RETURN(kf.colour, EncodeColourForStorage(*wire.colour, frame.colour));
    if (frame.depth) {
      SEMMAP_ASSIGN_OR_RETURN(kf.depth, EncodeDepthForStorage(*wire.depth, *frame.depth));
      kf.depth_scale = frame.depth->depth_scale;
    }
    if (estimate.keyframe_features) {
      kf.features_format = std::string(kFeatureCodecFormat);
      kf.features = EncodeFeatures(*estimate.keyframe_features);
    }
    batch.keyframes.push_back(std::move(kf));
    if (last_keyframe_seq_) {
      // Odometry edge from the previous keyframe; ids are resolved by the store.
      LinkRecord link;
      link.map_id = session_->map_id;
      link.kind = LinkKind::kOdometry;
      link.from_session_id = session_->id;
      link.from_seq = static_cast<int64_t>(*last_keyframe_seq_);
      link.to_session_id = session_->id;
      link.to_seq = pose.seq;
      link.T_from_to = last_keyframe_pose_.inverse() * estimate.T_world_camera;
      link.information = OdometryInformation(estimate);
      batch.links.push_back(link);
    }
    last_keyframe_seq_ = frame.seq;
    last_keyframe_pose_ = estimate.T_world_camera;
    keyframe_ms_.Add(MillisecondsSince(t0));
  }

  {
    std::lock_guard lock(commit_mutex_);
    ++pending_writes_;
  }
  const uint64_t seq = frame.seq;
  const Clock::time_point submitted_at = Clock::now();
  Status submitted = writer_->Submit(
      std::move(batch), [this, seq, submitted_at](const Status& status, const WriteResult&) {
        OnCommitted(status, seq, submitted_at);
      });
  if (!submitted.ok()) {
    std::lock_guard lock(commit_mutex_);
    --pending_writes_;
    all_committed_.notify_all();
    return submitted.WithContext("storage");
  }
  return OkStatus();
}

void IngestSession::OnCommitted(const Status& status, uint64_t seq,
                                Clock::time_point submitted_at) {
  IngestProgressInfo progress;
  {
    std::lock_guard lock(commit_mutex_);
    storage_commit_ms_.Add(MillisecondsSince(submitted_at));
    --pending_writes_;
    if (status.ok()) {
      if (!durable_seq_ || seq > *durable_seq_) durable_seq_ = seq;
    } else if (write_error_.ok()) {
      write_error_ = status.WithContext("storing frame seq " + std::to_string(seq) + " failed");
    }
    progress.durable_seq = durable_seq_;
    all_committed_.notify_all();
  }
  progress.frames_received = received_.load();
  progress.frames_processed = frames_.load();
  progress.keyframes = keyframes_.load();
  progress.queue_depth = static_cast<uint32_t>(queue_.size());
  sink_->OnProgress(progress);
}

Status IngestSession::FeedBackend(const DecodedFrame& frame, const FrameEstimate& estimate,
                                  const std::optional<uint64_t>& previous_keyframe_seq,
                                  const Eigen::Isometry3d& T_world_previous_keyframe) {
  const int64_t seq = static_cast<int64_t>(frame.seq);
  if (estimate.is_keyframe && estimate.keyframe_features) {
    KeyframeEvent event;
    event.session_id = session_->id;
    event.seq = seq;
    event.T_world_keyframe = estimate.T_world_camera;
    event.features = estimate.keyframe_features;
    if (previous_keyframe_seq) {
      event.previous_seq = static_cast<int64_t>(*previous_keyframe_seq);
      event.T_previous_keyframe = T_world_previous_keyframe.inverse() * estimate.T_world_camera;
    }
    event.information = OdometryInformation(estimate);
    SEMMAP_RETURN_IF_ERROR(backend_->AddKeyframe(std::move(event)));
  }
  if (!last_keyframe_seq_) return OkStatus();  // nothing to anchor to yet
  FrameAnchorEvent anchor;
  anchor.session_id = session_->id;
  anchor.seq = seq;
  anchor.anchor_seq = static_cast<int64_t>(*last_keyframe_seq_);
  anchor.T_anchor_frame = last_keyframe_pose_.inverse() * estimate.T_world_camera;
  anchor.T_world_frame = estimate.T_world_camera;
  return backend_->AddFrame(anchor);
}

Status IngestSession::PublishKeyframe(const DecodedFrame& frame, const FrameEstimate& estimate) {
  MapKeyframe keyframe;
  keyframe.session_id = session_->id;
  keyframe.seq = static_cast<int64_t>(frame.seq);
  keyframe.stamp_ns = frame.stamp_ns;
  keyframe.camera = session_->camera;
  keyframe.colour = frame.colour;
  keyframe.depth = frame.depth;
  keyframe.features = estimate.keyframe_features;
  // Visual sessions' keyframes are placed by the back end (in its corrected frame); the others'
  // poses are final as they are.
  if (!backend_) keyframe.T_world_keyframe = estimate.T_world_camera;
  return map_->PublishKeyframe(keyframe);
}

void IngestSession::ApplyPendingCorrection() {
  std::optional<Eigen::Isometry3d> correction;
  {
    std::lock_guard lock(correction_mutex_);
    correction.swap(pending_correction_);
  }
  if (!correction) return;
  processor_->ApplyCorrection(*correction);
  last_keyframe_pose_ = *correction * last_keyframe_pose_;
}

std::optional<uint64_t> IngestSession::durable_seq() const {
  std::lock_guard lock(commit_mutex_);
  return durable_seq_;
}

void IngestSession::Finish(Status status, SessionEndReason reason) {
  // The back end's writes for this session (loop links, re-anchored poses) land before the
  // final status too, so the stored trajectory is final when the client hears it.
  MapSessionReport map_report;
  if (map_ && session_) {
    const Status finished = map_->FinishSession(session_->id, &map_report);
    if (status.ok() && !finished.ok()) status = finished;
    if (map_report.backend) {
      const SlamBackendStats& stats = *map_report.backend;
      // One line per session for operators: what the map's back end did so far.
      LogInfo(
          "session '{}' of map '{}' ended: {} lost frames, {} restarts; map back end: {} "
          "keyframes ({} restored), {} loop candidates, {} accepted, {} rejected by geometry, {} "
          "by xi, {} taken back by the graph, {} optimisations ({} failed), queue high water {}",
          session_->name, session_->map_name, lost_frames_, segments_, stats.keyframes,
          stats.restored_keyframes, stats.candidates, stats.loops_accepted, stats.rejected_geometry,
          stats.rejected_xi, stats.rejected_inconsistent, stats.optimisations,
          stats.failed_optimisations, stats.queue_high_water);
    }
  }
  // The map is the manager's again: idle once no session holds it.
  backend_ = nullptr;
  map_.reset();
  // Whatever was submitted is committed (or failed) before the client hears the final status,
  // so the summary's durable_seq is exact.
  {
    std::unique_lock lock(commit_mutex_);
    all_committed_.wait(lock, [&] { return pending_writes_ == 0; });
    if (status.ok() && !write_error_.ok()) status = write_error_;
  }
  IngestSummaryInfo summary;
  if (!status.ok() && reason == SessionEndReason::kCompleted) reason = SessionEndReason::kError;
  if (session_) {
    const int64_t session_id = session_->id;
    const std::string message = status.ok() ? std::string() : status.ToString();
    Status ended = writer_->RunSync([&](MapStore& store) {
      return store.EndSession(session_id, UnixNowNs(), reason, message);
    });
    if (status.ok() && !ended.ok()) status = ended.WithContext("ending the session");
    summary.map = session_->map_name;
    summary.session = session_->name;
  }
  summary.frames = frames_.load();
  summary.lost_frames = lost_frames_;
  summary.new_segments = segments_;
  summary.loop_closures = map_report.loop_closures;
  summary.keyframes = keyframes_.load();
  summary.durable_seq = durable_seq();
  summary.duration_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started_at_).count();
  summary.stages = {decode_ms_.Summarize(), tracking_ms_.Summarize(), keyframe_ms_.Summarize()};
  {
    std::lock_guard lock(commit_mutex_);
    summary.stages.push_back(storage_commit_ms_.Summarize());
  }
  summary.stages.push_back(frame_ms_.Summarize());
  for (LatencySummary& stage : map_report.stages) summary.stages.push_back(std::move(stage));
  if (!status.ok() && summary.durable_seq) {
    status = Status(status.code(), status.message() + " (frames up to seq " +
                                       std::to_string(*summary.durable_seq) + " are stored)");
  }
  queue_.Shutdown();
  staged_.Shutdown();
  finished_.store(true);
  sink_->OnFinished(status, summary);
}

}  // namespace semmap
