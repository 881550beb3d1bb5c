// The mapping / loop-closing back end of one map. Tracking threads hand it keyframes and frame
// anchors through a bounded queue; its own worker thread adds keyframes to the graph, looks for
// loop candidates (local: keyframes near the new one's pose; global: place recognition over a
// bag of binary words), verifies them geometrically and by the neighbour ratio xi, optimises
// the pose graph when a loop is accepted, and writes links and corrected poses through the
// storage writer. Sessions learn about corrections through a callback and apply them on their
// next frame, so the back end never blocks tracking on its own work.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <variant>
#include <vector>

#include "common/camera.h"
#include "common/latency_stats.h"
#include "common/pipeline_stage.h"
#include "common/status.h"
#include "core/odometry/local_map.h"
#include "core/sensor/frame_features.h"
#include "core/slam/bow_vocabulary.h"
#include "core/slam/keyframe_culling.h"
#include "core/slam/keyframe_feature_memory.h"
#include "core/slam/keyframe_graph.h"
#include "core/slam/local_bundle_adjustment.h"
#include "core/slam/loop_verifier.h"
#include "core/slam/map_points.h"
#include "core/slam/place_database.h"
#include "core/slam/point_fusion.h"
#include "core/slam/pose_graph.h"
#include "storage/map_store_opener.h"
#include "storage/pending_writes.h"
#include "storage/storage_writer.h"

namespace semmap {

struct SlamBackendOptions {
  LoopVerifierOptions verifier;
  PoseGraphOptions pose_graph;
  // After each keyframe that names its map points (KeyframeEvent::point_ids). When keyframes
  // queue up behind it, the window shrinks to half (one waiting) or the run is skipped (more).
  LocalBundleAdjustmentOptions local_ba;
  // After each local BA, among the new keyframe's covisible ones (needs local_ba).
  KeyframeCullingOptions culling;
  // Before each local BA: the points of the keyframes around the new one (those of the
  // tracking map below) are searched in it by projection, joined or fused (needs local_ba).
  PointFusionOptions point_fusion;
  // The points sent back to a session's tracker after each local BA (and, with follow_revisits,
  // after each accepted loop and as a refresh as a revisiting camera passes mapped keyframes):
  // those observed by the centre keyframe's most covisible keyframes and by the keyframes near
  // its pose (a revisited place), at most tracking_map_max_points. 0 keyframes: nothing is sent.
  int tracking_map_covisible_keyframes = 15;
  int tracking_map_near_keyframes = 10;
  double tracking_map_near_radius_m = 1.0;
  double tracking_map_near_angle_deg = 45;
  int tracking_map_max_points = 4000;
  // The back end's half of the revisit keyframe rule (KeyframePolicyOptions::skip_mapped_views;
  // semmapd's --keyframe-skip-mapped sets both): a frame far from its session's latest keyframe
  // follows the nearest loop-verified mapped keyframe (its anchor), the tracker gets the points
  // around that keyframe as the camera passes it (a refresh: FollowCamera), and the map at once
  // after each accepted loop; each tracking map names its mapped keyframes' poses.
  bool follow_revisits = true;
  size_t queue_capacity = 512;  // events (keyframes and frame anchors) waiting for the worker
  // Keyframe features kept in memory (keyframe_feature_memory.h): beyond this the least recently
  // used are released and read back from the store when needed. 32 MiB holds ~400 keyframes of
  // 1000 ORB features; 0 keeps every keyframe's.
  size_t features_memory_bytes = size_t{32} << 20;
  // Keyframes this close in a session's order are its odometry neighbours, never loop
  // candidates (they are matched by tracking already).
  int exclude_recent = 8;
  // Local candidates: keyframes within this distance and viewing-angle difference.
  double local_radius_m = 0.6;
  double local_max_angle_deg = 40;
  int max_local_candidates = 2;
  // Global candidates: best place-recognition scores, kept when at least min_score and at
  // least min_score_ratio times the score of the query against its previous keyframe.
  int max_global_candidates = 3;
  double min_global_score = 0.02;
  double min_global_score_ratio = 0.6;
  int xi_neighbours = 2;  // the candidate's session neighbours (each side) for N_n
  // ... and up to this many other sessions' keyframes within xi_view_radius_m and
  // xi_view_angle_deg of the candidate: where earlier sessions mapped the same view, a query
  // that repeats it closely (a route driven again, a recording streamed again) matches the
  // candidate far better than the candidate's own neighbours a keyframe step away, which
  // read as a spike (xi >> 1) and rejected every loop of a map's later visits. 0: session
  // neighbours only.
  int xi_view_neighbours = 2;
  double xi_view_radius_m = 0.1;
  double xi_view_angle_deg = 10;
  // Noise floor added to every edge's covariance in the graph (metres, radians): tracking and
  // loop solves report the precision of one PnP, not the model errors around it (depth bias,
  // rolling shutter, calibration), and would make edges of a few millimetres' disagreement
  // look like outliers. Stored links keep the raw information.
  double edge_sigma_floor_m = 0.002;
  double edge_sigma_floor_rad = 0.002;
  // A loop whose whitened residual at the current poses is below this chi-square (6 degrees
  // of freedom; 12.59 = 95 %) already agrees with the graph: it is kept as an edge, but the
  // graph is not optimised for it at once (revisiting a well-mapped place costs no optimisation
  // per keyframe); such loops are optimised in batches of max_deferred_loops and whenever a
  // session ends (Drain). 0: optimise after every loop.
  double consistent_loop_chi2 = 12.59;
  int max_deferred_loops = 10;
  // A new loop that still disagrees with the optimised graph by more than this chi-square (its
  // whitened residual after the optimisation it caused) contradicts the odometry: it is taken
  // back (edge, link and poses). True loops measured 0.0-3.9 after their optimisation (synthetic
  // laps, a second session joining a map). 0 keeps every verified loop.
  double max_loop_chi2 = 50;

  Status Validate() const;
};

// A new keyframe from a session's tracker. Poses are in the tracker's frame at the time; the
// back end re-anchors them on its own estimate of the previous keyframe.
struct KeyframeEvent {
  int64_t session_id = 0;
  int64_t seq = 0;
  Eigen::Isometry3d T_world_keyframe = Eigen::Isometry3d::Identity();
  std::shared_ptr<const FrameFeatures> features;
  // Per keypoint, the session tracker's id of the map point it observes, -1 for none; empty
  // when the tracker keeps no map (then the keyframe takes no part in bundle adjustment).
  std::vector<int64_t> point_ids;
  // The odometry measurement from the session's previous keyframe (absent for its first).
  std::optional<int64_t> previous_seq;
  Eigen::Isometry3d T_previous_keyframe = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

// Every frame's pose relative to the keyframe it was tracked from, so stored poses follow that
// keyframe when the graph moves it (on a revisit, far from the session's latest keyframe, the
// back end anchors it to the nearest mapped keyframe instead). `T_world_frame` is what the
// session stored.
struct FrameAnchorEvent {
  int64_t session_id = 0;
  int64_t seq = 0;
  int64_t anchor_seq = 0;
  Eigen::Isometry3d T_anchor_frame = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_frame = Eigen::Isometry3d::Identity();
};

// What a map already holds when its back end starts (after a server restart): the sessions,
// their keyframes with features, every frame's stored pose and the links. Restored keyframes
// take part in loop closure like new ones, so a new session can close loops with old ones.
struct MapSnapshot {
  std::vector<SessionInfo> sessions;
  std::vector<KeyframeRecord> keyframes;  // with features; those without are not restored
  std::vector<std::pair<int64_t, TrajectoryPose>> frames;  // (session_id, pose)
  std::vector<LinkRecord> links;
  std::vector<MapPointRecord> map_points;
};

// Reads a map's snapshot from the store, leaving out the sessions in `skip` (live ones: their
// keyframes reach the back end as events).
StatusOr<MapSnapshot> ReadMapSnapshot(MapStore& store, int64_t map_id,
                                      const std::set<int64_t>& skip = {});

// What a back end starts from: nothing (a new map), a snapshot the caller read, or the store
// (`from_store`: read on the back end's own thread, ahead of every event, so neither the
// caller nor the storage writer waits for it), leaving out `skip_sessions`.
struct SlamRestore {
  const MapSnapshot* snapshot = nullptr;
  StoreRestore from_store;
  std::set<int64_t> skip_sessions;
};

struct LoopClosureInfo {
  int64_t query_session_id = 0, query_seq = 0;
  int64_t candidate_session_id = 0, candidate_seq = 0;
  bool global = false;  // found by place recognition (else by pose proximity)
  LoopVerification verification;
};

struct SlamBackendStats {
  uint64_t keyframes = 0;
  uint64_t restored_keyframes = 0;
  uint64_t restored_culled_keyframes = 0;  // pose nodes only (WriteBatch::culled_keyframes)
  uint64_t unreadable_keyframes = 0;       // stored features that did not decode: left out
  uint64_t restored_map_points = 0;
  uint64_t map_point_saves = 0;  // snapshots of the map points written to the store
  uint64_t candidates = 0;
  uint64_t loops_accepted = 0;
  uint64_t rejected_geometry = 0;
  uint64_t rejected_xi = 0;
  uint64_t optimisations = 0;
  uint64_t failed_optimisations = 0;      // the solver failed: poses kept, the error surfaced
  uint64_t failed_verifications = 0;      // a candidate the verifier could not judge (bad input)
  uint64_t loops_already_consistent = 0;  // accepted, but needed no optimisation
  uint64_t rejected_inconsistent = 0;     // verified, but contradicted by the optimised graph
  uint64_t local_ba_runs = 0;
  uint64_t local_ba_failures = 0;      // solver failed: poses and points kept
  uint64_t local_ba_time_limited = 0;  // a solve stopped at its time bound
  uint64_t local_ba_shrunk = 0;        // keyframes waiting: half the window
  uint64_t local_ba_skipped = 0;       // keyframes waiting: no run
  uint64_t final_ba_runs = 0;
  uint64_t keyframes_culled = 0;  // redundant: left the graph's search, BA and place database
  uint64_t ba_outliers_removed = 0;
  uint64_t map_points_culled = 0;
  uint64_t map_points_fused = 0;  // across accepted loops
  // Point fusion (point_fusion.h) at each keyframe: keypoints that joined a neighbour's point,
  // and duplicate points merged.
  uint64_t map_point_observations_joined = 0;
  uint64_t map_points_fused_by_projection = 0;
  size_t map_points = 0;
  size_t map_point_observations = 0;
  // Approximate heap bytes the back end holds, counted after a restore and at each Drain (a
  // walk over every keyframe and point: not on the per-keyframe path): the keyframes' features
  // (descriptors, keypoints, 3D points; culled keyframes none), the place database, the map
  // points with their observations. What grows with a map's keyframes.
  size_t features_bytes = 0;
  // Keyframe features released beyond features_memory_bytes, read back from the store, and
  // not readable there when needed (the keyframe was then left out of that step).
  uint64_t features_released = 0;
  uint64_t features_read_back = 0;
  uint64_t features_unreadable = 0;
  size_t place_index_bytes = 0;
  size_t map_point_bytes = 0;
  size_t queue_high_water = 0;
  LatencySummary keyframe_ms;  // worker time per keyframe (BA, candidates, verification)
  LatencySummary local_ba_ms;
  LatencySummary final_ba_ms;
  LatencySummary optimise_ms;
  std::vector<LoopClosureInfo> loops;
};

// A pipeline stage (common/pipeline_stage.h): Stop and metrics() come from there; Drain is its
// Flush.
class SlamBackend final : public PipelineStage<std::variant<KeyframeEvent, FrameAnchorEvent>> {
 public:
  // The session's tracker moves to the corrected frame: T_corrected_world * T_world_x.
  using CorrectionCallback = std::function<void(const Eigen::Isometry3d& T_corrected_world)>;
  // The refined map points around the session's newest keyframe (after each local BA), for
  // its tracker to match against (RgbdTracker::ApplyMapUpdate).
  using MapUpdateCallback = std::function<void(std::shared_ptr<const LocalMapUpdate> update)>;
  // Where keyframes are, for layers built from them (map layers): a new keyframe's pose when
  // it joins the graph (correction false), and every moved keyframe's after an optimisation
  // (correction true). Runs on the back end's thread; may block briefly (bounded queue).
  using KeyframePoseListener =
      std::function<void(std::vector<KeyframePose> poses, bool correction)>;

  // `vocabulary` may be null: then only local (pose-proximity) candidates are searched.
  // `writer` must outlive the back end.
  // `restore` says what the map already holds (keyframes whose features do not decode are left
  // out, logged and counted). `pose_listener` may be empty. RESOURCE_EXHAUSTED when the thread
  // cannot start. `stage`: as for ObjectMapper::Start.
  static StatusOr<std::unique_ptr<SlamBackend>> Start(
      int64_t map_id, SlamBackendOptions options, std::shared_ptr<const BowVocabulary> vocabulary,
      StorageWriter* writer, SlamRestore restore = {}, KeyframePoseListener pose_listener = nullptr,
      StageConfig stage = {});
  ~SlamBackend() override;  // drains queued events, then joins the worker

  // Call before the session's first event. The callbacks run on the back end's thread and
  // must not block; on_map_update may be empty.
  void RegisterSession(int64_t session_id, const CameraCalibration& camera,
                       CorrectionCallback on_correction, MapUpdateCallback on_map_update = nullptr);
  // No more corrections reach the session (its keyframes stay in the graph).
  void UnregisterSession(int64_t session_id);

  // Block only while the queue is full; UNAVAILABLE after Stop().
  Status AddKeyframe(KeyframeEvent event);
  Status AddFrame(FrameAnchorEvent event);
  // Waits until every event added so far is processed and its writes are committed; returns
  // the first error since the last Drain (storage, a failed optimisation).
  Status Drain() { return Flush(); }

  SlamBackendStats stats() const;
  int64_t map_id() const { return map_id_; }

 private:
  using Event = std::variant<KeyframeEvent, FrameAnchorEvent>;
  struct SessionState {
    CameraCalibration camera;
    CorrectionCallback on_correction;  // empty once unregistered
    MapUpdateCallback on_map_update;   // likewise
  };
  // A frame (of the session whose anchors_ entry holds it) and the keyframe it follows, which
  // may be another session's (a revisit).
  struct FrameAnchor {
    int64_t seq = 0;
    int64_t anchor_session_id = 0;
    int64_t anchor_seq = 0;
    Eigen::Isometry3d T_anchor_frame = Eigen::Isometry3d::Identity();
  };
  // Graph nodes and their poses before an update.
  using PosesBefore = std::vector<std::pair<int, Eigen::Isometry3d>>;

  SlamBackend(int64_t map_id, SlamBackendOptions options,
              std::shared_ptr<const BowVocabulary> vocabulary, StorageWriter* writer,
              StageConfig stage);
  // The stage's hooks (its thread).
  void OnStart() override;
  void Handle(Event& event) override;
  Status OnFlush() override;
  // Ends the sessions unregistered since the last flush in the back end's own state: their
  // young map points go to later sessions' judgement (MapPoints::EndSession), their
  // tracking-map centre and loop candidates are forgotten.
  void EndSessions();
  // Judges ended sessions' waiting points the new keyframe `index` looks at
  // (MapPoints::JudgeAround).
  void JudgeAwaitingPoints(int index);
  void OnStop() override;
  void Restore(const MapSnapshot& snapshot);
  // Graph node and place-database entry of a keyframe (no loop search).
  int AddNode(GraphKeyframe keyframe);
  // Keeps a node's place-recognition words (bow_) among its session's newest few; older ones
  // are dropped (the place database has them indexed).
  void KeepWords(int node, BowVector words);
  // A node's words: kept, or made again from its features; null when it has none (no
  // vocabulary, not in the place database, features unreadable).
  const BowVector* WordsOf(int node);
  void HandleKeyframe(KeyframeEvent& event);
  void HandleFrame(const FrameAnchorEvent& event);
  // Loop candidates for node `query`, verified; the first accepted one becomes a loop edge.
  std::optional<LoopClosureInfo> CloseLoop(int query);
  bool LoopAgreesWithGraph(const GraphEdge& loop);  // counts the ones that do
  // (Sigma + floor)^-1 for Sigma = information^-1, computed without inverting a possibly
  // singular information: I (Id + F I)^-1.
  Eigen::Matrix<double, 6, 6> WithNoiseFloor(const Eigen::Matrix<double, 6, 6>& information) const;
  // With check_new_loop, the latest edge is a loop that is taken back (false) when the
  // optimised graph still contradicts it (max_loop_chi2).
  bool OptimiseAndCorrect(bool check_new_loop = false);
  void LocalBundleAdjust(int index);
  void FinalBundleAdjust();  // options_.local_ba.final_ba
  void RestoreMapPoints(const std::vector<MapPointRecord>& records);
  void CullKeyframes(int newest);
  // The frames anchored to culled keyframe `k` follow the session's previous kept keyframe.
  void ReanchorFrames(int k);
  void SaveMapPoints();  // when changed: every point of the map, replacing the stored ones
  // Fuses the map points the loop's inlier matches show to be the same on both sides, so
  // bundle adjustment sees the loop through shared points.
  void FuseLoopPoints(const LoopClosureInfo& loop);
  // Sends the session of keyframe `index` the points its tracker should match against.
  // Keyframe `index`, its most covisible keyframes and the keyframes near its pose (of its
  // component): the tracking map's keyframes and point fusion's neighbours.
  std::vector<int> Neighbourhood(int index) const;
  void FusePoints(int index);  // PointFusionOptions, before the local BA
  // Sends `session_id` the points around keyframe `centre` (LocalMapUpdate; `refresh` as
  // there) and remembers `centre` as the session's tracking-map centre.
  void PublishTrackingMap(int centre, int64_t session_id, bool refresh);
  // A frame of a session that makes no keyframes while it moves on through mapped ones (a
  // revisit): when the mapped keyframe nearest to it is neither its tracking map's centre nor
  // the keyframe it was tracked from, the tracker gets the points around that keyframe (a
  // refresh).
  // Whether keyframe `k` counts as a view session `session_id`'s map already has
  // (LocalMapUpdate::keyframe_poses_world): one of the session's own latest keyframes (within
  // exclude_recent of its newest, in its order), or within exclude_recent of the candidate of
  // one of its accepted loops in that one's session. A keyframe only near by pose does not
  // count: until a loop is verified there, the map's pose of it may be off by the drift.
  bool MappedFor(int64_t session_id, int k) const;
  // `near`: the mapped keyframes near the frame, nearest first (KeyframeGraph::Near).
  void FollowCamera(int64_t session_id, int anchor, const std::vector<int>& near);
  // Publishes the moves of the nodes in `before` that moved: the layers' listener, stored
  // poses of their frames, the sessions whose latest keyframe moved; with move_points, the
  // map points follow the keyframe that created them (a pose-graph correction; BA solves
  // points itself).
  void ApplyMovedPoses(const PosesBefore& before, bool move_points);
  void AddAnchor(int64_t session_id, const FrameAnchor& anchor);
  double EdgeChi2(const GraphEdge& edge) const;
  void SubmitPending();  // submits the pending batch

  // Fills stats_'s held-bytes figures (the caller holds mutex_; O(keyframes)).
  void CountHeldBytes();
  // Makes the features of `nodes` resident (features_memory_); returns those that are (the
  // others are logged and left out).
  std::vector<int> WithFeatures(const std::vector<int>& nodes);
  // The keyframes whose features give the descriptors of the points `keyframes` observe (each
  // point's newest observation).
  std::vector<int> NewestObservers(const std::vector<int>& keyframes) const;

  const int64_t map_id_;
  const SlamBackendOptions options_;
  const std::shared_ptr<const BowVocabulary> vocabulary_;
  StorageWriter* const writer_;
  KeyframePoseListener pose_listener_;  // set before the worker starts
  SlamRestore restore_;                 // read by OnStart

  // Worker-thread state.
  KeyframeGraph graph_;
  PlaceDatabase places_;
  // Words by node index, for the score of a query against its session's previous keyframe:
  // only each session's newest kWordsKeptPerSession keyframes keep theirs (~11 kB each).
  static constexpr size_t kWordsKeptPerSession = 3;
  std::map<int, BowVector> bow_;
  std::map<int64_t, std::deque<int>> words_kept_;  // by session, oldest first
  WriteBatch pending_;
  std::map<int64_t, std::vector<FrameAnchor>> anchors_;  // by session, in seq order
  // The frames anchored to each (session, keyframe seq): (frame's session, position in
  // anchors_[that session]).
  std::map<std::pair<int64_t, int64_t>, std::vector<std::pair<int64_t, size_t>>>
      anchors_of_keyframe_;
  MapPoints map_points_;
  KeyframeFeatureMemory features_memory_;
  std::map<int64_t, int> tracking_map_centre_;  // by session: the keyframe it was last sent
  // By session: the candidates of its latest accepted loops (at most kLoopsRemembered), where
  // the map is known to agree with its tracking (MappedFor).
  static constexpr size_t kLoopsRemembered = 8;
  std::map<int64_t, std::deque<int>> loop_candidates_;
  std::atomic<int> queued_keyframes_{0};  // added, not yet handled
  // Sessions that added keyframes with points since the last final BA: the next one adjusts
  // them (RunSessionBundleAdjustment).
  std::set<int64_t> sessions_since_final_ba_;
  bool map_points_changed_ = false;  // since they were last written to the store
  int deferred_loops_ = 0;           // consistent loops added since the last optimisation
  bool features_unreadable_warned_ = false;

  PendingWrites writes_;      // the worker's batches, and the errors Drain reports
  mutable std::mutex mutex_;  // sessions_, ended_sessions_, stats_
  // Entries are never erased: graph keyframes point at their session's camera.
  std::map<int64_t, SessionState> sessions_;
  // Unregistered since the last flush: the flush hands their young map points over
  // (MapPoints::EndSession).
  std::vector<int64_t> ended_sessions_;
  SlamBackendStats stats_;
  LatencyStats keyframe_ms_{"backend_keyframe"};
  LatencyStats optimise_ms_{"optimise"};
  LatencyStats local_ba_ms_{"local_ba"};
  LatencyStats final_ba_ms_{"final_ba"};
};

}  // namespace semmap
