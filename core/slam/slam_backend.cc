#include "core/slam/slam_backend.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>

#include "common/logging.h"
#include "common/time_util.h"
#include "core/slam/feature_codec.h"

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

constexpr double kPi = 3.14159265358979323846;

// Poses closer than this are the same for storage (re-anchoring writes only real moves).
bool Moved(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff() > 1e-9;
}

}  // namespace

Status SlamBackendOptions::Validate() const {
  SEMMAP_RETURN_IF_ERROR(verifier.Validate().WithContext("slam verifier"));
  SEMMAP_RETURN_IF_ERROR(pose_graph.Validate().WithContext("slam pose graph"));
  if (queue_capacity < 1 || queue_capacity > 100000) {
    return InvalidArgumentError("slam queue_capacity must be in 1..100000");
  }
  if (exclude_recent < 1) return InvalidArgumentError("slam exclude_recent must be >= 1");
  if (!(local_radius_m >= 0) || !(local_max_angle_deg >= 0 && local_max_angle_deg <= 180)) {
    return InvalidArgumentError("slam local_radius_m >= 0 and local_max_angle_deg in [0, 180]");
  }
  if (max_local_candidates < 0 || max_global_candidates < 0) {
    return InvalidArgumentError("slam candidate counts must be >= 0");
  }
  if (!(min_global_score >= 0 && min_global_score <= 1) ||
      !(min_global_score_ratio >= 0 && min_global_score_ratio <= 1)) {
    return InvalidArgumentError("slam global score thresholds must be in [0, 1]");
  }
  if (xi_neighbours < 1) return InvalidArgumentError("slam xi_neighbours must be >= 1");
  if (xi_view_neighbours < 0 || !(xi_view_radius_m >= 0) || !(xi_view_angle_deg >= 0)) {
    return InvalidArgumentError("slam xi_view_neighbours, radius and angle must be >= 0");
  }
  if (!(edge_sigma_floor_m >= 0) || !(edge_sigma_floor_rad >= 0)) {
    return InvalidArgumentError("slam edge sigma floors must be >= 0");
  }
  if (!(max_loop_chi2 >= 0)) return InvalidArgumentError("slam max_loop_chi2 must be >= 0");
  if (max_deferred_loops < 1) return InvalidArgumentError("slam max_deferred_loops must be >= 1");
  if (!(consistent_loop_chi2 >= 0)) {
    return InvalidArgumentError("slam consistent_loop_chi2 must be >= 0");
  }
  if (tracking_map_covisible_keyframes < 0 || tracking_map_near_keyframes < 0 ||
      tracking_map_max_points < 0 || !(tracking_map_near_radius_m >= 0) ||
      !(tracking_map_near_angle_deg >= 0 && tracking_map_near_angle_deg <= 180)) {
    return InvalidArgumentError(
        "slam tracking map: counts and radius >= 0, angle in [0, 180] degrees");
  }
  SEMMAP_RETURN_IF_ERROR(culling.Validate().WithContext("slam"));
  SEMMAP_RETURN_IF_ERROR(point_fusion.Validate().WithContext("slam"));
  return local_ba.Validate().WithContext("slam");
}

StatusOr<MapSnapshot> ReadMapSnapshot(MapStore& store, int64_t map_id,
                                      const std::set<int64_t>& skip) {
  MapSnapshot snapshot;
  SEMMAP_ASSIGN_OR_RETURN(std::vector<MapInfo> maps, store.ListMaps());
  std::string name;
  for (const MapInfo& m : maps) {
    if (m.id == map_id) name = m.name;
  }
  if (name.empty()) return NotFoundError("map id " + std::to_string(map_id) + " not found");
  SEMMAP_ASSIGN_OR_RETURN(snapshot.sessions, store.ListSessions(name));
  std::erase_if(snapshot.sessions, [&](const SessionInfo& s) { return skip.count(s.id) != 0; });
  for (const SessionInfo& s : snapshot.sessions) {
    SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> keyframes,
                            store.ListKeyframeFeatures(s.id));
    for (KeyframeRecord& kf : keyframes) {
      // Culled keyframes have no features but still chain the graph (their links).
      if (!kf.features.empty() || kf.culled) snapshot.keyframes.push_back(std::move(kf));
    }
    SEMMAP_ASSIGN_OR_RETURN(std::vector<TrajectoryPose> frames,
                            store.GetTrajectory(s.id, /*keyframes_only=*/false));
    for (TrajectoryPose& p : frames) snapshot.frames.emplace_back(s.id, p);
  }
  SEMMAP_ASSIGN_OR_RETURN(snapshot.links, store.ListLinks(map_id));
  SEMMAP_ASSIGN_OR_RETURN(snapshot.map_points, store.ListMapPoints(map_id));
  return snapshot;
}

StatusOr<std::unique_ptr<SlamBackend>> SlamBackend::Start(
    int64_t map_id, SlamBackendOptions options, std::shared_ptr<const BowVocabulary> vocabulary,
    StorageWriter* writer, SlamRestore restore, KeyframePoseListener pose_listener,
    StageConfig stage) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (writer == nullptr) return InvalidArgumentError("slam back end needs a storage writer");
  stage.name = "slam back end of map " + std::to_string(map_id);
  stage.thread_name = "slam-backend";
  stage.queue_capacity = options.queue_capacity;
  // The background tier, below decode and tracking: with the back end at the per-frame tier,
  // the fast synthetic sequence tracked at 16-17 ms p50 instead of 12-13 and streamed at 44
  // frames/s instead of 58-67, with the same ATE (local BA is skipped or shrunk when keyframes
  // come faster than it finishes; the queue stayed far from full either way).
  stage.tier = ThreadTier::kBackground;
  std::unique_ptr<SlamBackend> backend(
      new SlamBackend(map_id, options, std::move(vocabulary), writer, std::move(stage)));
  if (restore.snapshot) backend->Restore(*restore.snapshot);
  restore.snapshot = nullptr;
  backend->restore_ = std::move(restore);
  backend->pose_listener_ = std::move(pose_listener);
  SEMMAP_RETURN_IF_ERROR(backend->PipelineStage::Start());
  return backend;
}

namespace {

// Reads released keyframe features back on the storage writer's thread: after everything
// submitted before, so a keyframe whose write is still queued is found too.
KeyframeFeatureMemory::Reader ReadFeaturesThrough(StorageWriter* writer) {
  return [writer](const std::vector<std::pair<int64_t, int64_t>>& keys) {
    std::vector<StatusOr<KeyframeRecord>> read;
    const Status status = writer->RunSync([&](MapStore& store) {
      read.clear();
      for (const auto& [session_id, seq] : keys) {
        read.push_back(store.GetKeyframeFeatures(session_id, seq));
      }
      return OkStatus();
    });
    if (!status.ok()) read.assign(keys.size(), StatusOr<KeyframeRecord>(status));
    return read;
  };
}

}  // namespace

SlamBackend::SlamBackend(int64_t map_id, SlamBackendOptions options,
                         std::shared_ptr<const BowVocabulary> vocabulary, StorageWriter* writer,
                         StageConfig stage)
    : PipelineStage(std::move(stage)),
      map_id_(map_id),
      options_(options),
      vocabulary_(std::move(vocabulary)),
      writer_(writer),
      map_points_(options_.local_ba.points),
      features_memory_(options_.features_memory_bytes, ReadFeaturesThrough(writer)),
      writes_(writer, "slam back end") {}

void SlamBackend::OnStart() {
  if (!restore_.from_store.enabled) return;
  StatusOr<MapSnapshot> snapshot = MapSnapshot{};
  const Status read = ReadForRestore(restore_.from_store, *writer_, [&](MapStore& store) {
    snapshot = ReadMapSnapshot(store, map_id_, restore_.skip_sessions);
    return snapshot.status();
  });
  if (!read.ok()) {
    // The back end goes on with what the sessions send; the error reaches the next Drain.
    RecordError(read.WithContext("restoring the map's keyframes"));
    return;
  }
  Restore(*snapshot);
}

void SlamBackend::Restore(const MapSnapshot& snapshot) {
  // Live sessions may register meanwhile: sessions_ and stats_ are touched under the lock only
  // (map nodes do not move, so the cameras' addresses stay valid).
  std::map<int64_t, const CameraCalibration*> cameras;
  {
    std::lock_guard lock(mutex_);
    for (const SessionInfo& s : snapshot.sessions) {
      SessionState& state = sessions_[s.id];
      state.camera = s.camera;
      cameras[s.id] = &state.camera;
    }
  }
  uint64_t restored = 0, unreadable = 0, culled = 0;
  for (const KeyframeRecord& record : snapshot.keyframes) {
    const auto session = cameras.find(record.session_id);
    if (session == cameras.end()) continue;  // not of this map
    if (record.culled) {
      // A pose node only: out of BA, covisibility, loop search and the place database.
      GraphKeyframe kf;
      kf.session_id = record.session_id;
      kf.seq = record.seq;
      kf.T_world_keyframe = record.T_world_camera;
      kf.camera = session->second;
      graph_.Cull(graph_.Add(std::move(kf)));
      ++culled;
      continue;
    }
    StatusOr<FrameFeatures> features = DecodeFeatures(record.features_format, record.features);
    if (!features.ok()) {
      // Damage in one stored keyframe must not keep the map from loading: it is left out.
      if (unreadable++ == 0) {
        LogWarning("{}: stored keyframe seq {} of session {} left out: {}", name(), record.seq,
                   record.session_id, features.status().ToString());
      }
      continue;
    }
    GraphKeyframe kf;
    kf.session_id = record.session_id;
    kf.seq = record.seq;
    kf.T_world_keyframe = record.T_world_camera;
    kf.features = std::make_shared<const FrameFeatures>(std::move(features).value());
    kf.camera = session->second;
    AddNode(std::move(kf));
    ++restored;
  }
  {
    std::lock_guard lock(mutex_);
    stats_.restored_keyframes += restored;
    stats_.restored_culled_keyframes += culled;
    stats_.unreadable_keyframes += unreadable;
  }
  for (const LinkRecord& link : snapshot.links) {
    const std::optional<int> from = graph_.Find(link.from_session_id, link.from_seq);
    const std::optional<int> to = graph_.Find(link.to_session_id, link.to_seq);
    if (!from || !to) continue;  // a keyframe without features (e.g. KNOWN_POSES)
    GraphEdge edge;
    edge.from = *from;
    edge.to = *to;
    edge.T_from_to = link.T_from_to;
    edge.information = WithNoiseFloor(link.information);
    edge.kind =
        link.kind == LinkKind::kLoop ? PoseGraphEdgeKind::kLoop : PoseGraphEdgeKind::kOdometry;
    graph_.AddEdge(edge);
  }
  RestoreMapPoints(snapshot.map_points);
  features_memory_.Trim(graph_);  // every restored keyframe's features were read
  {
    std::lock_guard lock(mutex_);
    stats_.features_released = features_memory_.released();
  }
  // Each stored frame follows the latest kept keyframe at or before it, as it did when tracked
  // (or once its keyframe was culled).
  std::map<int64_t, std::pair<int64_t, Eigen::Isometry3d>> last_keyframe;  // by session
  for (const auto& [session_id, pose] : snapshot.frames) {
    const std::optional<int> keyframe = graph_.Find(session_id, pose.seq);
    if (keyframe && !graph_.node(*keyframe).culled)
      last_keyframe[session_id] = {pose.seq, pose.T_world_camera};
    const auto anchor = last_keyframe.find(session_id);
    if (anchor == last_keyframe.end()) continue;
    AddAnchor(session_id, {pose.seq, session_id, anchor->second.first,
                           anchor->second.second.inverse() * pose.T_world_camera});
  }
}

int SlamBackend::AddNode(GraphKeyframe keyframe) {
  std::optional<BowVector> bow;
  if (vocabulary_) {
    // A keyframe the vocabulary cannot describe (e.g. SIFT features) is matched locally only.
    StatusOr<BowVector> words = vocabulary_->Transform(keyframe.features->descriptors);
    if (words.ok()) bow = std::move(words).value();
  }
  const int index = graph_.Add(std::move(keyframe));
  features_memory_.Added(index);
  // Add only fails for a malformed vector, which Transform never makes; such a keyframe would
  // just not be found by place recognition.
  if (bow && places_.Add(index, *bow).ok()) KeepWords(index, std::move(*bow));
  return index;
}

void SlamBackend::KeepWords(int node, BowVector words) {
  bow_[node] = std::move(words);
  std::deque<int>& kept = words_kept_[graph_.node(node).session_id];
  kept.push_back(node);
  while (kept.size() > kWordsKeptPerSession) {
    bow_.erase(kept.front());
    kept.pop_front();
  }
}

const BowVector* SlamBackend::WordsOf(int node) {
  if (const auto it = bow_.find(node); it != bow_.end()) return &it->second;
  if (!vocabulary_ || !places_.Contains(node) || WithFeatures({node}).empty()) return nullptr;
  StatusOr<BowVector> words = vocabulary_->Transform(graph_.node(node).features->descriptors);
  if (!words.ok()) return nullptr;
  KeepWords(node, std::move(words).value());
  return &bow_.at(node);
}

SlamBackend::~SlamBackend() { Stop(); }  // the worker drains what is queued first

void SlamBackend::RegisterSession(int64_t session_id, const CameraCalibration& camera,
                                  CorrectionCallback on_correction,
                                  MapUpdateCallback on_map_update) {
  std::lock_guard lock(mutex_);
  // Back before a flush handed its points over (a resumed session): it has not ended.
  std::erase(ended_sessions_, session_id);
  SessionState& state = sessions_[session_id];
  state.camera = camera;
  state.on_correction = std::move(on_correction);
  state.on_map_update = std::move(on_map_update);
}

void SlamBackend::UnregisterSession(int64_t session_id) {
  std::lock_guard lock(mutex_);
  const auto it = sessions_.find(session_id);
  if (it != sessions_.end()) {
    it->second.on_correction = nullptr;
    it->second.on_map_update = nullptr;
    ended_sessions_.push_back(session_id);
  }
}

Status SlamBackend::AddKeyframe(KeyframeEvent event) {
  if (!event.features) return InvalidArgumentError("keyframe event without features");
  if (!event.point_ids.empty() && event.point_ids.size() != event.features->size()) {
    return InvalidArgumentError("keyframe event has " + std::to_string(event.point_ids.size()) +
                                " point ids for " + std::to_string(event.features->size()) +
                                " keypoints");
  }
  ++queued_keyframes_;
  Status submitted = Submit(Event(std::move(event)));
  if (!submitted.ok()) --queued_keyframes_;
  return submitted;
}

void SlamBackend::AddAnchor(int64_t session_id, const FrameAnchor& anchor) {
  std::vector<FrameAnchor>& anchors = anchors_[session_id];
  anchors_of_keyframe_[{anchor.anchor_session_id, anchor.anchor_seq}].emplace_back(session_id,
                                                                                   anchors.size());
  anchors.push_back(anchor);
}

Status SlamBackend::AddFrame(FrameAnchorEvent event) { return Submit(Event(std::move(event))); }

std::vector<int> SlamBackend::WithFeatures(const std::vector<int>& nodes) {
  const std::vector<std::pair<int, Status>> failed = features_memory_.Use(graph_, nodes);
  for (const auto& [node, status] : failed) {
    // Once per back end at warning level: a store that lost one keyframe's features likely
    // lost more, and each is left out of the step that wanted it, not a reason to stop.
    if (!features_unreadable_warned_) {
      features_unreadable_warned_ = true;
      LogWarning("{}: {}; such keyframes are left out where their features are needed", name(),
                 status.ToString());
    } else {
      LogDebug("{}: {}", name(), status.ToString());
    }
  }
  std::vector<int> resident;
  resident.reserve(nodes.size());
  for (int n : nodes) {
    if (n >= 0 && n < graph_.size() && graph_.node(n).features) resident.push_back(n);
  }
  return resident;
}

std::vector<int> SlamBackend::NewestObservers(const std::vector<int>& keyframes) const {
  std::set<int> observers;
  for (int k : keyframes) {
    for (int64_t id : map_points_.PointsOf(k)) {
      const MapPointState* point = map_points_.Find(id);
      if (point != nullptr && !point->observations.empty()) {
        observers.insert(point->observations.back().keyframe);
      }
    }
  }
  return {observers.begin(), observers.end()};
}

void SlamBackend::CountHeldBytes() {
  const size_t features = features_memory_.HeldBytes(graph_);
  stats_.features_released = features_memory_.released();
  stats_.features_read_back = features_memory_.read_back();
  stats_.features_unreadable = features_memory_.unreadable();
  size_t places = places_.HeldBytes();
  for (const auto& [node, words] : bow_) {
    places += sizeof(std::pair<const int, BowVector>) + 4 * sizeof(void*) +
              words.capacity() * sizeof(BowEntry);
  }
  stats_.features_bytes = features;
  stats_.place_index_bytes = places;
  stats_.map_point_bytes = map_points_.HeldBytes();
}

SlamBackendStats SlamBackend::stats() const {
  const StageMetrics stage = metrics();
  std::lock_guard lock(mutex_);
  SlamBackendStats s = stats_;
  s.queue_high_water = stage.queue_high_water;
  s.keyframe_ms = keyframe_ms_.Summarize();
  s.optimise_ms = optimise_ms_.Summarize();
  s.local_ba_ms = local_ba_ms_.Summarize();
  s.final_ba_ms = final_ba_ms_.Summarize();
  return s;
}

void SlamBackend::Handle(Event& event) {
  if (auto* kf = std::get_if<KeyframeEvent>(&event)) {
    HandleKeyframe(*kf);
  } else {
    HandleFrame(std::get<FrameAnchorEvent>(event));
  }
}

void SlamBackend::OnStop() {
  SubmitPending();
  writes_.Wait();
}

void SlamBackend::HandleFrame(const FrameAnchorEvent& event) {
  std::optional<int> anchor = graph_.Find(event.session_id, event.anchor_seq);
  FrameAnchor added{event.seq, event.session_id, event.anchor_seq, event.T_anchor_frame};
  if (anchor && graph_.node(*anchor).culled) {
    // Culled since the tracker chose it: the frame follows the previous kept keyframe.
    if (const std::optional<int> kept = graph_.PreviousKept(*anchor)) {
      added.T_anchor_frame = graph_.node(*kept).T_world_keyframe.inverse() *
                             graph_.node(*anchor).T_world_keyframe * event.T_anchor_frame;
      added.anchor_seq = graph_.node(*kept).seq;
      anchor = kept;
    }
  }
  if (!anchor) {  // its keyframe never reached the graph (unregistered session)
    AddAnchor(event.session_id, added);
    return;
  }
  // A frame tracked before its session applied the latest correction was stored in the old
  // frame: move it now.
  const Eigen::Isometry3d T = graph_.node(*anchor).T_world_keyframe * event.T_anchor_frame;
  if (Moved(T, event.T_world_frame)) {
    pending_.pose_updates.push_back({event.session_id, event.seq, T});
  }
  if (!options_.follow_revisits) {
    AddAnchor(event.session_id, added);
    return;
  }
  const std::vector<int> near = graph_.Near(
      T, options_.tracking_map_near_radius_m, options_.tracking_map_near_angle_deg * kPi / 180.0,
      [&](int k) { return !graph_.SameComponent(k, *anchor); });
  if (std::find(near.begin(), near.end(), *anchor) == near.end()) {
    // A revisit far from the session's latest keyframe (it made none here): the frame was
    // tracked against the mapped keyframes around it and follows the nearest when they move.
    const auto mapped = std::find_if(near.begin(), near.end(),
                                     [&](int k) { return MappedFor(event.session_id, k); });
    if (mapped != near.end()) {
      const GraphKeyframe& nearest = graph_.node(*mapped);
      added = {event.seq, nearest.session_id, nearest.seq, nearest.T_world_keyframe.inverse() * T};
    }
  }
  AddAnchor(event.session_id, added);
  FollowCamera(event.session_id, *anchor, near);
}

bool SlamBackend::MappedFor(int64_t session_id, int k) const {
  const GraphKeyframe& node = graph_.node(k);
  const auto close_in_order = [&](int other) {
    const GraphKeyframe& o = graph_.node(other);
    return o.session_id == node.session_id &&
           std::abs(o.index_in_session - node.index_in_session) <= options_.exclude_recent;
  };
  if (const std::optional<int> newest = graph_.LastOfSession(session_id);
      newest && close_in_order(*newest)) {
    return true;
  }
  const auto loops = loop_candidates_.find(session_id);
  return loops != loop_candidates_.end() &&
         std::any_of(loops->second.begin(), loops->second.end(), close_in_order);
}

void SlamBackend::FollowCamera(int64_t session_id, int anchor, const std::vector<int>& near) {
  const auto centre = tracking_map_centre_.find(session_id);
  // Only sessions whose tracker takes the map's points (they were sent some already).
  if (centre == tracking_map_centre_.end()) return;
  // Near its own keyframe the tracker has the points itself (its local map).
  if (near.empty() || near.front() == centre->second || near.front() == anchor) return;
  PublishTrackingMap(near.front(), session_id, /*refresh=*/true);
}

void SlamBackend::HandleKeyframe(KeyframeEvent& event) {
  const Clock::time_point t0 = Clock::now();
  --queued_keyframes_;
  const CameraCalibration* camera = nullptr;
  {
    std::lock_guard lock(mutex_);
    const auto it = sessions_.find(event.session_id);
    if (it == sessions_.end()) return;  // never registered: nothing to anchor it to
    camera = &it->second.camera;
  }
  GraphKeyframe kf;
  kf.session_id = event.session_id;
  kf.seq = event.seq;
  kf.features = event.features;
  kf.camera = camera;
  kf.T_world_keyframe = event.T_world_keyframe;
  std::optional<int> previous;
  if (event.previous_seq) previous = graph_.Find(event.session_id, *event.previous_seq);
  // Chain on the back end's estimate of the previous keyframe: keyframes made before the
  // tracker applied a correction still land in the corrected frame.
  if (previous)
    kf.T_world_keyframe = graph_.node(*previous).T_world_keyframe * event.T_previous_keyframe;
  const int index = AddNode(std::move(kf));
  if (pose_listener_) {
    const GraphKeyframe& added = graph_.node(index);
    pose_listener_({{added.session_id, added.seq, added.T_world_keyframe}}, false);
  }
  if (previous) {
    GraphEdge edge;
    edge.from = *previous;
    edge.to = index;
    edge.T_from_to = event.T_previous_keyframe;
    edge.information = WithNoiseFloor(event.information);
    edge.kind = PoseGraphEdgeKind::kOdometry;
    graph_.AddEdge(edge);
  }
  if (options_.local_ba.enabled && !event.point_ids.empty()) {
    const GraphKeyframe& added = graph_.node(index);
    map_points_.AddKeyframe(added.session_id, index, added.index_in_session, *added.features,
                            added.T_world_keyframe, event.point_ids);
    sessions_since_final_ba_.insert(added.session_id);
    map_points_changed_ = true;
    FusePoints(index);
    JudgeAwaitingPoints(index);
    LocalBundleAdjust(index);
    CullKeyframes(index);
  }

  std::optional<LoopClosureInfo> loop = CloseLoop(index);
  if (loop) {
    if (!LoopAgreesWithGraph(graph_.edges().back())) {
      if (!OptimiseAndCorrect(/*check_new_loop=*/true)) loop.reset();  // taken back
    } else if (++deferred_loops_ >= options_.max_deferred_loops) {
      OptimiseAndCorrect();
    }
  }
  if (loop && options_.local_ba.enabled && options_.local_ba.fuse_loop_points) {
    FuseLoopPoints(*loop);
  }
  if (loop) {
    // The map agrees with the session's tracking around the candidate now: its tracker learns
    // of those keyframes (MappedFor) at once rather than at its next keyframe.
    if (const std::optional<int> candidate =
            graph_.Find(loop->candidate_session_id, loop->candidate_seq)) {
      std::deque<int>& remembered = loop_candidates_[loop->query_session_id];
      remembered.push_back(*candidate);
      if (remembered.size() > kLoopsRemembered) remembered.pop_front();
      if (options_.follow_revisits && options_.local_ba.enabled && !event.point_ids.empty()) {
        PublishTrackingMap(index, loop->query_session_id, /*refresh=*/false);
      }
    }
  }
  features_memory_.Trim(graph_);
  SubmitPending();
  std::lock_guard lock(mutex_);
  ++stats_.keyframes;
  stats_.features_released = features_memory_.released();
  stats_.features_read_back = features_memory_.read_back();
  stats_.features_unreadable = features_memory_.unreadable();
  stats_.map_points = map_points_.size();
  stats_.map_point_observations = map_points_.num_observations();
  if (loop) stats_.loops.push_back(*loop);
  keyframe_ms_.Add(MillisecondsSince(t0));
}

std::optional<LoopClosureInfo> SlamBackend::CloseLoop(int query) {
  const GraphKeyframe& q = graph_.node(query);
  const auto query_words = bow_.find(query);
  const BowVector* bow = query_words == bow_.end() ? nullptr : &query_words->second;
  // Recent keyframes of the query's own session are odometry, not loops.
  const auto skip = [&](int i) {
    const GraphKeyframe& k = graph_.node(i);
    return i == query || (k.session_id == q.session_id &&
                          q.index_in_session - k.index_in_session < options_.exclude_recent);
  };
  // Poses are comparable only within one component (a session not yet linked to the others
  // has a frame of its own): other components are reached by place recognition alone.
  const auto skip_local = [&](int i) { return skip(i) || !graph_.SameComponent(i, query); };
  std::vector<std::pair<int, bool>> candidates;  // (node, global)
  std::set<int> seen;
  for (int i : graph_.Near(q.T_world_keyframe, options_.local_radius_m,
                           options_.local_max_angle_deg * kPi / 180.0, skip_local)) {
    if (static_cast<int>(candidates.size()) >= options_.max_local_candidates) break;
    if (seen.insert(i).second) candidates.emplace_back(i, false);
  }
  if (bow && options_.max_global_candidates > 0) {
    double reference = 0;  // how similar the query is to what it certainly overlaps with
    if (q.index_in_session > 0) {
      for (int n : graph_.SessionNeighbours(query, 1)) {
        if (const BowVector* words = WordsOf(n)) {
          reference = std::max(reference, BowVocabulary::Score(*bow, *words));
        }
      }
    }
    const double min_score =
        std::max(options_.min_global_score, options_.min_global_score_ratio * reference);
    int added = 0;
    for (const PlaceMatch& m :
         places_.Query(*bow, options_.max_global_candidates * 4,
                       [&](int64_t id) { return skip(static_cast<int>(id)); })) {
      if (added >= options_.max_global_candidates || m.score < min_score) break;
      const int i = static_cast<int>(m.entry_id);
      if (seen.insert(i).second) {
        candidates.emplace_back(i, true);
        ++added;
      }
    }
  }
  for (const auto& [candidate, global] : candidates) {
    const GraphKeyframe& c = graph_.node(candidate);
    std::vector<int> wanted{candidate};
    for (int n : graph_.SessionNeighbours(candidate, options_.xi_neighbours)) {
      if (!skip(n)) wanted.push_back(n);
    }
    // The same view as other sessions mapped it (SlamBackendOptions::xi_view_neighbours).
    const int candidate_node = candidate;  // structured bindings are not captured before C++20
    const std::vector<int> same_view =
        graph_.Near(c.T_world_keyframe, options_.xi_view_radius_m,
                    options_.xi_view_angle_deg * kPi / 180.0, [&](int i) {
                      return skip(i) || graph_.node(i).session_id == c.session_id ||
                             !graph_.SameComponent(i, candidate_node);
                    });
    for (size_t i = 0; i < same_view.size() && static_cast<int>(i) < options_.xi_view_neighbours;
         ++i) {
      wanted.push_back(same_view[i]);
    }
    const std::vector<int> resident = WithFeatures(wanted);
    if (resident.empty() || resident.front() != candidate) continue;
    std::vector<const FrameFeatures*> neighbours;
    for (size_t i = 1; i < resident.size(); ++i) {
      neighbours.push_back(graph_.node(resident[i]).features.get());
    }
    StatusOr<LoopVerification> verified =
        VerifyLoopCandidate(*q.features, *c.features, neighbours, *q.camera, options_.verifier);
    std::lock_guard lock(mutex_);
    ++stats_.candidates;
    if (!verified.ok()) {
      // Bad input (e.g. mixed descriptor types): not a loop, and not worth failing the
      // session's Drain for; counted and logged at debug level.
      ++stats_.failed_verifications;
      LogDebug("{}: loop candidate not verified: {}", name(), verified.status().ToString());
      continue;
    }
    if (!verified->accepted()) {
      if (verified->decision == LoopDecision::kXiTooHigh) {
        ++stats_.rejected_xi;
      } else {
        ++stats_.rejected_geometry;
      }
      continue;
    }
    ++stats_.loops_accepted;
    GraphEdge edge;
    edge.from = candidate;
    edge.to = query;
    edge.T_from_to = verified->T_candidate_query;
    edge.information = WithNoiseFloor(verified->information);
    edge.kind = PoseGraphEdgeKind::kLoop;
    graph_.AddEdge(edge);

    LinkRecord link;
    link.map_id = map_id_;
    link.kind = LinkKind::kLoop;
    link.from_session_id = c.session_id;
    link.from_seq = c.seq;
    link.to_session_id = q.session_id;
    link.to_seq = q.seq;
    link.T_from_to = edge.T_from_to;
    link.information = verified->information;
    pending_.links.push_back(link);

    LoopClosureInfo info;
    info.query_session_id = q.session_id;
    info.query_seq = q.seq;
    info.candidate_session_id = c.session_id;
    info.candidate_seq = c.seq;
    info.global = global;
    info.verification = *verified;
    return info;
  }
  return std::nullopt;
}

Eigen::Matrix<double, 6, 6> SlamBackend::WithNoiseFloor(
    const Eigen::Matrix<double, 6, 6>& information) const {
  Eigen::Matrix<double, 6, 1> floor;
  const double t = options_.edge_sigma_floor_m * options_.edge_sigma_floor_m;
  const double r = options_.edge_sigma_floor_rad * options_.edge_sigma_floor_rad;
  floor << t, t, t, r, r, r;
  const Eigen::Matrix<double, 6, 6> m =
      Eigen::Matrix<double, 6, 6>::Identity() + floor.asDiagonal() * information;
  Eigen::Matrix<double, 6, 6> floored = information * m.inverse();
  return 0.5 * (floored + floored.transpose());  // symmetric up to rounding
}

double SlamBackend::EdgeChi2(const GraphEdge& edge) const {
  return PoseGraphEdgeResidual(edge, graph_.node(static_cast<int>(edge.from)).T_world_keyframe,
                               graph_.node(static_cast<int>(edge.to)).T_world_keyframe)
      .squaredNorm();
}

bool SlamBackend::LoopAgreesWithGraph(const GraphEdge& loop) {
  if (options_.consistent_loop_chi2 <= 0) return false;
  if (EdgeChi2(loop) > options_.consistent_loop_chi2) return false;
  std::lock_guard lock(mutex_);
  ++stats_.loops_already_consistent;
  return true;
}

bool SlamBackend::OptimiseAndCorrect(bool check_new_loop) {
  const Clock::time_point t0 = Clock::now();
  std::vector<Eigen::Isometry3d> before(static_cast<size_t>(graph_.size()));
  for (int i = 0; i < graph_.size(); ++i)
    before[static_cast<size_t>(i)] = graph_.node(i).T_world_keyframe;
  deferred_loops_ = 0;
  StatusOr<PoseGraphResult> result = graph_.Optimise(options_.pose_graph);
  if (!result.ok()) {
    // The graph keeps its poses and the loop edge stays for the next optimisation: the map is
    // as good as before, so the sessions go on; counted (session summary) and logged.
    LogWarning("{}: pose-graph optimisation failed, poses kept: {}", name(),
               result.status().ToString());
    std::lock_guard lock(mutex_);
    ++stats_.failed_optimisations;
    return true;
  }
  if (check_new_loop) {
    const double chi2 = EdgeChi2(graph_.edges().back());
    if (options_.max_loop_chi2 > 0 && chi2 > options_.max_loop_chi2) {
      for (int i = 0; i < graph_.size(); ++i) graph_.SetPose(i, before[static_cast<size_t>(i)]);
      graph_.RemoveLastEdge();
      pending_.links.pop_back();
      std::lock_guard lock(mutex_);
      --stats_.loops_accepted;
      ++stats_.rejected_inconsistent;
      return false;
    }
  }
  PosesBefore moved;
  for (int i = 0; i < graph_.size(); ++i) moved.emplace_back(i, before[static_cast<size_t>(i)]);
  ApplyMovedPoses(moved, /*move_points=*/true);
  std::lock_guard lock(mutex_);
  ++stats_.optimisations;
  optimise_ms_.Add(MillisecondsSince(t0));
  return true;
}

void SlamBackend::JudgeAwaitingPoints(int index) {
  const int culled = map_points_.JudgeAround(index);
  if (culled == 0) return;
  std::lock_guard lock(mutex_);
  stats_.map_points_culled += static_cast<uint64_t>(culled);
}

void SlamBackend::LocalBundleAdjust(int index) {
  LocalBundleAdjustmentOptions options = options_.local_ba;
  const int waiting = queued_keyframes_.load();
  if (waiting > 1) {
    std::lock_guard lock(mutex_);
    ++stats_.local_ba_skipped;
    return;
  }
  if (waiting == 1) options.max_free_keyframes = std::max(2, options.max_free_keyframes / 2);
  const Clock::time_point t0 = Clock::now();
  StatusOr<LocalBundleAdjustmentReport> report =
      RunLocalBundleAdjustment(index, graph_, map_points_, options);
  if (!report.ok()) {
    LogWarning("{}: local bundle adjustment failed, poses kept: {}", name(),
               report.status().ToString());
    std::lock_guard lock(mutex_);
    ++stats_.local_ba_failures;
    return;
  }
  if (!report->ran) return;
  ApplyMovedPoses(report->moved_keyframes, /*move_points=*/false);
  PublishTrackingMap(index, graph_.node(index).session_id, /*refresh=*/false);
  std::lock_guard lock(mutex_);
  ++stats_.local_ba_runs;
  if (waiting == 1) ++stats_.local_ba_shrunk;
  if (report->hit_time_limit) ++stats_.local_ba_time_limited;
  stats_.ba_outliers_removed += static_cast<uint64_t>(report->outliers_removed);
  stats_.map_points_culled += static_cast<uint64_t>(report->points_culled);
  local_ba_ms_.Add(MillisecondsSince(t0));
}

std::vector<int> SlamBackend::Neighbourhood(int index) const {
  std::vector<int> keyframes{index};
  for (const auto& [k, shared] : map_points_.Covisible(index)) {
    if (static_cast<int>(keyframes.size()) > options_.tracking_map_covisible_keyframes) break;
    keyframes.push_back(k);
  }
  // Keyframes of other sessions (earlier ones, a restored map's) count once a loop has joined
  // them to this session's frame: their points are where the new keyframe is.
  const auto skip = [&](int k) {
    return !graph_.SameComponent(k, index) ||
           std::find(keyframes.begin(), keyframes.end(), k) != keyframes.end();
  };
  int near = 0;
  for (int k : graph_.Near(graph_.node(index).T_world_keyframe, options_.tracking_map_near_radius_m,
                           options_.tracking_map_near_angle_deg * kPi / 180.0, skip)) {
    if (near++ >= options_.tracking_map_near_keyframes) break;
    keyframes.push_back(k);
  }
  return keyframes;
}

void SlamBackend::FusePoints(int index) {
  if (!options_.point_fusion.enabled) return;
  const std::vector<int> around = Neighbourhood(index);
  WithFeatures(NewestObservers(around));  // the points' descriptors
  const PointFusionResult result =
      FusePointsIntoKeyframe(index, around, graph_, map_points_, options_.point_fusion);
  std::lock_guard lock(mutex_);
  stats_.map_point_observations_joined += static_cast<uint64_t>(result.observations_added);
  stats_.map_points_fused_by_projection += static_cast<uint64_t>(result.points_fused);
}

void SlamBackend::PublishTrackingMap(int index, int64_t session_id, bool refresh) {
  const auto registered = [&] {
    const auto it = sessions_.find(session_id);
    return it != sessions_.end() && it->second.on_map_update ? &it->second : nullptr;
  };
  {
    std::lock_guard lock(mutex_);
    if (registered() == nullptr || options_.tracking_map_max_points == 0) return;
  }
  tracking_map_centre_[session_id] = index;
  const std::vector<int> keyframes = Neighbourhood(index);
  WithFeatures(NewestObservers(keyframes));  // the points' descriptors
  auto update = std::make_shared<LocalMapUpdate>();
  update->refresh = refresh;
  std::set<int64_t> taken;
  for (int k : keyframes) {
    for (int64_t id : map_points_.PointsOf(k)) {
      if (static_cast<int>(update->ids.size()) >= options_.tracking_map_max_points) break;
      if (!graph_.SameComponent(k, index) || !taken.insert(id).second) continue;
      const MapPointState* point = map_points_.Find(id);
      // The descriptor and scale of its newest observation.
      const MapPointObservation& o = point->observations.back();
      if (!graph_.node(o.keyframe).features) continue;  // unreadable (WithFeatures logged it)
      const FrameFeatures& f = *graph_.node(o.keyframe).features;
      const int64_t tracker_id = map_points_.TrackerIdFor(session_id, id);
      update->ids.push_back(tracker_id);
      // The session's other names of it: points fusion merged into it.
      if (point->session_id == session_id && point->tracker_id >= 0 &&
          point->tracker_id != tracker_id) {
        update->retired_ids.push_back(point->tracker_id);
      }
      for (const auto& [session, alias] : point->aliases) {
        if ((session == session_id || session == MapPoints::kAnySession) && alias != tracker_id) {
          update->retired_ids.push_back(alias);
        }
      }
      update->positions_world.push_back(point->position_world);
      update->octaves.push_back(f.keypoints[static_cast<size_t>(o.keypoint)].octave);
      update->descriptors.push_back(f.descriptors.row(o.keypoint));
    }
  }
  if (update->ids.empty()) return;
  if (options_.follow_revisits) {  // the revisit keyframe rule's mapped views
    for (int k : keyframes) {
      const GraphKeyframe& node = graph_.node(k);
      if (!node.culled && graph_.SameComponent(k, index) && MappedFor(session_id, k)) {
        update->keyframe_poses_world.push_back(node.T_world_keyframe);
      }
    }
  }
  // Called under the lock, as corrections are: UnregisterSession waits for it to return.
  std::lock_guard lock(mutex_);
  if (SessionState* state = registered()) state->on_map_update(std::move(update));
}

void SlamBackend::ApplyMovedPoses(const PosesBefore& before, bool move_points) {
  PosesBefore moved;
  for (const auto& [i, T_old] : before) {
    if (Moved(T_old, graph_.node(i).T_world_keyframe)) moved.emplace_back(i, T_old);
  }
  if (moved.empty()) return;
  std::vector<KeyframePose> poses;                 // for the listener (map layers, objects)
  std::map<int, Eigen::Isometry3d> correction_of;  // T_new_old per moved node
  for (const auto& [i, T_old] : moved) {
    const GraphKeyframe& k = graph_.node(i);
    // A culled keyframe's place is where its frame, anchored to a kept one, is (below).
    if (!k.culled) poses.push_back({k.session_id, k.seq, k.T_world_keyframe});
    const Eigen::Isometry3d T_new_old = k.T_world_keyframe * T_old.inverse();
    if (move_points) correction_of[i] = T_new_old;
    // Every frame anchored to a moved keyframe is rewritten.
    const auto anchored = anchors_of_keyframe_.find({k.session_id, k.seq});
    if (anchored == anchors_of_keyframe_.end()) continue;
    for (const auto& [session_id, position] : anchored->second) {
      const FrameAnchor& anchor = anchors_[session_id][position];
      const Eigen::Isometry3d T = k.T_world_keyframe * anchor.T_anchor_frame;
      pending_.pose_updates.push_back({session_id, anchor.seq, T});
      if (session_id == k.session_id && anchor.seq == k.seq) continue;
      // A culled keyframe re-anchored here follows as its frame does.
      const std::optional<int> culled = graph_.Find(session_id, anchor.seq);
      if (culled && graph_.node(*culled).culled) {
        graph_.SetPose(*culled, T);
        poses.push_back({session_id, anchor.seq, T});
      }
    }
  }
  if (pose_listener_) pose_listener_(std::move(poses), true);
  if (move_points) {
    map_points_.MoveWithKeyframes(correction_of);
    map_points_changed_ = map_points_changed_ || map_points_.size() > 0;
  }
  std::lock_guard lock(mutex_);
  // Each live session's tracker follows its latest keyframe.
  for (auto& [session_id, state] : sessions_) {
    if (!state.on_correction) continue;
    const std::optional<int> last = graph_.LastOfSession(session_id);
    if (!last) continue;
    for (const auto& [i, T_old] : moved) {
      if (i == *last) state.on_correction(graph_.node(i).T_world_keyframe * T_old.inverse());
    }
  }
}

void SlamBackend::SubmitPending() {
  if (pending_.empty()) return;
  writes_.Submit(std::move(pending_));
  pending_ = WriteBatch{};
}

void SlamBackend::FuseLoopPoints(const LoopClosureInfo& loop) {
  const std::optional<int> query = graph_.Find(loop.query_session_id, loop.query_seq);
  const std::optional<int> candidate = graph_.Find(loop.candidate_session_id, loop.candidate_seq);
  if (!query || !candidate) return;
  const std::unordered_map<int, int64_t> query_points = map_points_.PointsByKeypoint(*query);
  const std::unordered_map<int, int64_t> candidate_points =
      map_points_.PointsByKeypoint(*candidate);
  uint64_t fused = 0;
  for (const auto& [query_keypoint, candidate_keypoint] : loop.verification.inlier_matches) {
    const auto q = query_points.find(query_keypoint);
    const auto c = candidate_points.find(candidate_keypoint);
    if (q == query_points.end() || c == candidate_points.end()) continue;
    if (map_points_.Fuse(/*keep=*/c->second, /*drop=*/q->second)) ++fused;
  }
  std::lock_guard lock(mutex_);
  stats_.map_points_fused += fused;
}

void SlamBackend::RestoreMapPoints(const std::vector<MapPointRecord>& records) {
  uint64_t restored = 0;
  std::vector<MapPointObservation> observations;
  for (const MapPointRecord& record : records) {
    if (!record.position_world.allFinite()) continue;
    observations.clear();
    for (const MapPointObservationRecord& o : record.observations) {
      // Keyframes left out (unreadable features, a live session's) or culled (points saved
      // before the culling was) take their observations.
      const std::optional<int> keyframe = graph_.Find(o.session_id, o.seq);
      if (!keyframe || graph_.node(*keyframe).culled || o.keypoint < 0 ||
          static_cast<size_t>(o.keypoint) >= graph_.node(*keyframe).features->size()) {
        continue;
      }
      observations.push_back(
          ObservationOf(*keyframe, o.keypoint, *graph_.node(*keyframe).features));
    }
    if (map_points_.Restore(record.session_id, record.position_world, observations) >= 0) {
      ++restored;
    }
  }
  std::lock_guard lock(mutex_);
  stats_.restored_map_points += restored;
  stats_.map_points = map_points_.size();
  stats_.map_point_observations = map_points_.num_observations();
  CountHeldBytes();
}

void SlamBackend::CullKeyframes(int newest) {
  const std::vector<int> culled =
      CullRedundantKeyframes(newest, graph_, map_points_, options_.culling);
  for (int k : culled) {
    if (places_.Contains(k) && !places_.Remove(k).ok()) {
      LogWarning("{}: culled keyframe {} stays in the place database", name(), k);
    }
    bow_.erase(k);
    ReanchorFrames(k);
    pending_.culled_keyframes.emplace_back(graph_.node(k).session_id, graph_.node(k).seq);
  }
  if (culled.empty()) return;
  std::lock_guard lock(mutex_);
  stats_.keyframes_culled += culled.size();
}

void SlamBackend::ReanchorFrames(int k) {
  const GraphKeyframe& gone = graph_.node(k);
  const std::optional<int> kept = graph_.PreviousKept(k);
  if (!kept) return;  // a session's first keyframe is never culled
  const GraphKeyframe& to = graph_.node(*kept);
  const Eigen::Isometry3d T_kept_gone = to.T_world_keyframe.inverse() * gone.T_world_keyframe;
  const auto from = anchors_of_keyframe_.find({gone.session_id, gone.seq});
  if (from == anchors_of_keyframe_.end()) return;
  std::vector<std::pair<int64_t, size_t>>& of_kept = anchors_of_keyframe_[{to.session_id, to.seq}];
  for (const auto& [session_id, position] : from->second) {
    FrameAnchor& anchor = anchors_[session_id][position];
    anchor.T_anchor_frame = T_kept_gone * anchor.T_anchor_frame;
    anchor.anchor_session_id = to.session_id;
    anchor.anchor_seq = to.seq;
    of_kept.emplace_back(session_id, position);
  }
  std::sort(of_kept.begin(), of_kept.end());
  anchors_of_keyframe_.erase(from);
}

void SlamBackend::SaveMapPoints() {
  if (!map_points_changed_) return;
  map_points_changed_ = false;
  std::vector<MapPointRecord> records;
  records.reserve(map_points_.size());
  map_points_.ForEach([&](const MapPointState& point) {
    MapPointRecord& record = records.emplace_back();
    record.point_id = point.id;
    record.session_id = point.session_id;
    record.position_world = point.position_world;
    for (const MapPointObservation& o : point.observations) {
      const GraphKeyframe& k = graph_.node(o.keyframe);
      record.observations.push_back({k.session_id, k.seq, o.keypoint});
    }
  });
  pending_.map_points.emplace_back(map_id_, std::move(records));
  std::lock_guard lock(mutex_);
  ++stats_.map_point_saves;
}

void SlamBackend::FinalBundleAdjust() {
  const std::set<int64_t> sessions = std::exchange(sessions_since_final_ba_, {});
  const Clock::time_point t0 = Clock::now();
  StatusOr<LocalBundleAdjustmentReport> report =
      RunSessionBundleAdjustment(sessions, graph_, map_points_, options_.local_ba,
                                 options_.local_ba.final_ba_max_solve_seconds);
  if (!report.ok()) {
    LogWarning("{}: final bundle adjustment failed, poses kept: {}", name(),
               report.status().ToString());
    std::lock_guard lock(mutex_);
    ++stats_.local_ba_failures;
    return;
  }
  if (!report->ran) return;
  ApplyMovedPoses(report->moved_keyframes, /*move_points=*/false);
  LogInfo(
      "{}: final bundle adjustment: {} keyframes ({} fixed), {} points, {} observations "
      "({} outliers removed), {} loop constraints, {:.0f} ms{}",
      name(), report->free_keyframes + report->fixed_keyframes, report->fixed_keyframes,
      report->points, report->observations, report->outliers_removed, report->loop_constraints,
      report->solve_ms, report->hit_time_limit ? ", stopped at its time bound" : "");
  std::lock_guard lock(mutex_);
  ++stats_.final_ba_runs;
  stats_.ba_outliers_removed += static_cast<uint64_t>(report->outliers_removed);
  final_ba_ms_.Add(MillisecondsSince(t0));
}

void SlamBackend::EndSessions() {
  std::vector<int64_t> ended;
  {
    std::lock_guard lock(mutex_);
    ended = std::exchange(ended_sessions_, {});
  }
  for (int64_t session_id : ended) {
    map_points_.EndSession(session_id);
    // Its events are all handled (Drain follows UnregisterSession): no keyframe of it will
    // ask for its tracking map or loop candidates again.
    tracking_map_centre_.erase(session_id);
    loop_candidates_.erase(session_id);
  }
}

Status SlamBackend::OnFlush() {
  if (deferred_loops_ > 0) OptimiseAndCorrect();  // a finished session gets its final poses
  EndSessions();
  if (options_.local_ba.enabled && options_.local_ba.final_ba &&
      !sessions_since_final_ba_.empty()) {
    FinalBundleAdjust();
  }
  SaveMapPoints();
  SubmitPending();
  {
    std::lock_guard lock(mutex_);
    CountHeldBytes();
  }
  return writes_.WaitAndTakeError();
}

}  // namespace semmap
