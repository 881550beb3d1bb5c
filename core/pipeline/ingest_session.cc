#include "core/pipeline/ingest_session.h"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <string>
#include <utility>

#include "common/thread_launcher.h"
#include "common/thread_priority.h"
#include "common/time_util.h"
#include "core/sensor/image_decoding.h"

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

constexpr int kStopCancelled = 1;
constexpr int kStopServer = 2;
constexpr int kStopDeadline = 3;

// "s-20261122-013045": readable, sortable, unique enough; a suffix resolves collisions.
std::string GeneratedSessionName() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buf[32];
  std::strftime(buf, sizeof(buf), "s-%Y%m%d-%H%M%S", &utc);
  return buf;
}

// The session's row (and its map's, on first use), named as asked or with a generated name.
StatusOr<SessionInfo> CreateSessionRow(StorageWriter& writer, const IngestStartRequest& start) {
  SessionInfo created;
  SEMMAP_RETURN_IF_ERROR(writer.RunSync([&](MapStore& store) -> Status {
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
  }));
  return created;
}

}  // namespace

StatusOr<std::unique_ptr<IngestSession>> IngestSession::Start(std::shared_ptr<IngestSink> sink,
                                                              StorageWriter* writer,
                                                              IngestOptions options,
                                                              MapPipelineProvider pipelines,
                                                              std::function<void()> on_finished) {
  std::unique_ptr<IngestSession> session(new IngestSession(
      std::move(sink), writer, std::move(options), std::move(pipelines), std::move(on_finished)));
  const ThreadLauncher& launch =
      session->options_.launch_thread ? session->options_.launch_thread : LaunchThread;
  IngestSession* raw = session.get();
  StatusOr<std::thread> decoder = launch([raw] {
    NameCurrentThread("ingest-decode");
    RunCurrentThreadAs(ThreadTier::kPerFrame);  // below gRPC's threads and the query workers
    raw->RunDecoder();
  });
  if (decoder.ok()) {
    session->decoder_ = std::move(decoder).value();
    StatusOr<std::thread> worker = launch([raw] {
      NameCurrentThread("ingest-track");
      RunCurrentThreadAs(ThreadTier::kPerFrame);
      raw->Run();
    });
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
                             IngestOptions options, MapPipelineProvider pipelines,
                             std::function<void()> on_finished)
    : sink_(std::move(sink)),
      writer_(writer),
      options_(std::move(options)),
      on_finished_(std::move(on_finished)),
      queue_(options_.queue_capacity),
      pipelines_(std::move(pipelines)),
      protocol_(options_.max_frame_bytes) {
  if (options_.max_frames_per_second > 0) {
    // Two seconds' worth: a paced client whose frames bunch up behind a stall still passes.
    frame_rate_.emplace(options_.max_frames_per_second,
                        std::max(1.0, 2 * options_.max_frames_per_second));
  }
}

IngestSession::~IngestSession() {
  Stop();
  staged_.Shutdown();
  for (std::thread* thread : {&decoder_, &worker_}) {
    if (thread->joinable()) thread->join();
  }
}

bool IngestSession::TryEnqueue(IngestMessage& message) {
  if (!HasRoom()) return false;
  if (const auto* frame = std::get_if<IngestFrame>(&message);
      frame != nullptr && frame_rate_ && !frame_rate_->TryTake()) {
    char limit[32];
    std::snprintf(limit, sizeof(limit), "%g", frame_rate_->rate_per_s());
    message = IngestInvalid{ResourceExhaustedError(
        std::string("frame rate limit: the stream sent frames faster than the server's limit of ") +
        limit + " frames/s per session (semmapd --max-session-fps) at frame seq " +
        std::to_string(frame->seq) + "; the frames before it are kept. Pace the stream (semmap " +
        "ingest --rate)")};
  }
  if (!queue_.TryPush(message)) return false;
  report_.Received();
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
  SEMMAP_RETURN_IF_ERROR(commits_.error());
  if (auto* invalid = std::get_if<IngestInvalid>(&message)) return invalid->status;
  if (auto* start = std::get_if<IngestStartRequest>(&message)) {
    if (ingestor_) return InvalidArgumentError("a second start message in the same stream");
    return HandleStart(*start);
  }
  if (!ingestor_) {
    return InvalidArgumentError("the first message of an ingest stream must be start");
  }
  if (auto* frame = std::get_if<IngestFrame>(&message)) {
    if (staged.images) report_.decode_ms().Add(staged.decode_ms);
    return HandleFrame(*frame, staged.images);
  }
  ended_ = true;  // IngestEnd
  return OkStatus();
}

Status IngestSession::HandleStart(const IngestStartRequest& start) {
  SEMMAP_ASSIGN_OR_RETURN(const KeyframePolicyOptions keyframes,
                          ValidateStart(start, options_.keyframes));
  SEMMAP_ASSIGN_OR_RETURN(
      std::unique_ptr<FrameProcessor> processor,
      MakeFrameProcessor(*start.mode, keyframes, ProcessorContext(), start.camera));
  SEMMAP_ASSIGN_OR_RETURN(SessionInfo created, CreateSessionRow(*writer_, start));
  row_ = created;  // ended by Finish whatever happens next
  // Visible to administrative removals before the map's pipelines are taken (ingest_manager).
  map_id_.store(created.map_id);
  // RGBD and MONO keyframes carry features: the map's SLAM back end closes loops with them.
  const bool visual = *start.mode == SessionMode::kRgbd || *start.mode == SessionMode::kMono;
  std::shared_ptr<MapPipeline> map;
  if (pipelines_) {
    SEMMAP_ASSIGN_OR_RETURN(map, pipelines_(created, visual));
  }
  ingestor_ =
      std::make_unique<FrameIngestor>(created, std::move(processor), std::move(map), visual);
  sink_->OnStarted(ingestor_->session());
  return OkStatus();
}

FrameProcessorContext IngestSession::ProcessorContext() const {
  FrameProcessorContext context;
  context.tracker = options_.tracker;
  context.mono_model = options_.mono_model;
  context.mono_unavailable = options_.mono_unavailable;
  context.mono_method = options_.mono_method;
  return context;
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

Status IngestSession::HandleFrame(IngestFrame& frame,
                                  std::optional<StatusOr<DecodedImages>>& images) {
  const Clock::time_point t0 = Clock::now();
  // Order, size and presence first (their errors win), then the decoded images, then the pose.
  SEMMAP_RETURN_IF_ERROR(protocol_.Check(frame));
  // The decoder saw the same start (it is the first message), so every frame that got here
  // was decoded.
  if (!images) return InternalError("frame seq " + std::to_string(frame.seq) + " was not decoded");
  if (!images->ok()) return images->status();
  SEMMAP_RETURN_IF_ERROR(FrameProtocol::CheckPosePrior(frame));
  DecodedFrame decoded;
  decoded.seq = frame.seq;
  decoded.stamp_ns = *frame.stamp_ns;
  decoded.colour = std::move(images->value().colour);
  decoded.depth = std::move(images->value().depth);
  if (frame.pose_prior) decoded.T_world_camera_prior = ToIsometry(*frame.pose_prior);

  SEMMAP_ASSIGN_OR_RETURN(FrameIngestor::Ingested ingested, ingestor_->Ingest(decoded, frame));
  report_.tracking_ms().Add(ingested.tracking_ms);
  if (ingested.estimate.tracking_timings) {
    report_.AddTrackingParts(*ingested.estimate.tracking_timings);
  }
  if (ingested.estimate.is_keyframe) report_.keyframe_ms().Add(ingested.keyframe_ms);
  protocol_.Accept(frame.seq);
  SEMMAP_RETURN_IF_ERROR(Submit(std::move(ingested.batch), frame.seq));
  SEMMAP_RETURN_IF_ERROR(ingestor_->Publish(decoded, ingested));
  report_.Processed(ingested.estimate);

  FrameAckInfo ack;
  ack.seq = frame.seq;
  ack.T_world_camera = ingested.estimate.T_world_camera;
  ack.is_keyframe = ingested.estimate.is_keyframe;
  ack.lost = ingested.estimate.lost;
  ack.durable_seq = commits_.durable_seq();
  sink_->OnAck(ack);
  report_.frame_ms().Add(MillisecondsSince(t0));
  return OkStatus();
}

Status IngestSession::Submit(WriteBatch batch, uint64_t seq) {
  commits_.Submitted();
  const Clock::time_point submitted_at = Clock::now();
  Status submitted = writer_->Submit(
      std::move(batch), [this, seq, submitted_at](const Status& status, const WriteResult&) {
        OnCommitted(status, seq, MillisecondsSince(submitted_at));
      });
  if (!submitted.ok()) {
    commits_.SubmitFailed();
    return submitted.WithContext("storage");
  }
  return OkStatus();
}

void IngestSession::OnCommitted(const Status& status, uint64_t seq, double latency_ms) {
  const std::optional<uint64_t> durable = commits_.Committed(status, seq, latency_ms);
  sink_->OnProgress(report_.Progress(durable, static_cast<uint32_t>(queue_.size())));
}

void IngestSession::Finish(Status status, SessionEndReason reason) {
  // The back end's writes for this session (loop links, re-anchored poses) land before the
  // final status too, so the stored trajectory is final when the client hears it.
  MapSessionReport map_report;
  if (ingestor_) {
    const Status finished = ingestor_->Finish(&map_report);
    if (status.ok() && !finished.ok()) status = finished;
    report_.LogEnd(ingestor_->session(), map_report);
  }
  // Whatever was submitted is committed (or failed) before the client hears the final status,
  // so the summary's durable_seq is exact.
  commits_.WaitAll();
  if (status.ok()) status = commits_.error();
  if (!status.ok() && reason == SessionEndReason::kCompleted) reason = SessionEndReason::kError;
  const SessionInfo* session = row_ ? &*row_ : nullptr;
  if (session != nullptr) {
    const int64_t session_id = session->id;
    const std::string message = status.ok() ? std::string() : status.ToString();
    Status ended = writer_->RunSync([&](MapStore& store) {
      return store.EndSession(session_id, UnixNowNs(), reason, message);
    });
    if (status.ok() && !ended.ok()) status = ended.WithContext("ending the session");
  }
  const std::optional<uint64_t> durable = commits_.durable_seq();
  IngestSummaryInfo summary =
      report_.Summary(session, commits_.CommitLatency(), durable, std::move(map_report));
  if (!status.ok() && durable) {
    status = Status(status.code(), status.message() + " (frames up to seq " +
                                       std::to_string(*durable) + " are stored)");
  }
  queue_.Shutdown();
  staged_.Shutdown();
  finished_.store(true);
  sink_->OnFinished(status, summary);
  if (on_finished_) on_finished_();
}

}  // namespace semmap
