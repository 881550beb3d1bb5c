// The back end's map points: 3D points in the world frame, each observed by several keyframes.
// Trackers name them: a keyframe keypoint with depth that matched no point of the tracker's
// local map starts a point (placed by its depth), and later keyframes' inlier matches to that
// point become its observations. Bundle adjustment (bundle_adjustment.h) refines their
// positions together with the keyframe poses; observations BA rejects are removed, and points
// that too few keyframes ever confirm are culled (ORB-SLAM2's recent-point culling).
// Covisibility (keyframes sharing points) chooses each local BA window. Single-threaded: the
// back end's worker owns it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/status.h"
#include "core/sensor/frame_features.h"

namespace semmap {

struct MapPointsOptions {
  // A point observed by fewer keyframes than this once `cull_age_keyframes` keyframes of its
  // session have followed the one that created it is removed (a point only its creator saw
  // is bad depth, a moving object or repeated texture).
  int min_observations = 2;
  int cull_age_keyframes = 3;

  Status Validate() const;
};

struct MapPointObservation {
  int keyframe = 0;  // graph node index
  int keypoint = 0;  // index into that keyframe's features
  // What bundle adjustment measures, copied from the keyframe's features when the observation
  // is made: BA then never needs the features, which need not be in memory
  // (keyframe_feature_memory.h).
  float u = 0, v = 0;       // the keypoint, pixels
  float inverse_depth = 0;  // 1 / its depth, 0 when it has none
  int octave = 0;           // its pyramid level (the pixel sigma's scale)
};

// Keypoint `keypoint` of `features` (valid index) observed by graph node `keyframe`.
MapPointObservation ObservationOf(int keyframe, int keypoint, const FrameFeatures& features);

struct MapPointState {
  int64_t id = 0;
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  std::vector<MapPointObservation> observations;  // at most one per keyframe
  int64_t session_id = 0;
  int64_t tracker_id = 0;  // the session tracker's id for it
  // Other (session, tracker id) pairs that name it: points fused into it. A fused point's
  // foreign name (kForeignTrackerIdBase + its id, which any session may know it by) is kept
  // under session kAnySession.
  std::vector<std::pair<int64_t, int64_t>> aliases;
  int created_in_session = 0;  // index_in_session of the keyframe that created it
};

// Keyframes whose poses and points a local bundle adjustment solves for (free), and keyframes
// that also see those points but stay where they are (fixed), as graph node indices.
struct BundleAdjustmentWindow {
  std::vector<int> free_keyframes;   // ascending
  std::vector<int> fixed_keyframes;  // ascending
  std::vector<int64_t> points;       // observed by a free keyframe
};

class MapPoints {
 public:
  explicit MapPoints(MapPointsOptions options = {}) : options_(options) {}

  // Keyframe `keyframe` (graph node, the `index_in_session`-th of its session) at
  // T_world_keyframe. `tracker_point_ids` (empty, or one per keypoint): the session tracker's
  // id of the point each keypoint observes, -1 for none. A known id gains the observation; an
  // unknown id starts a point at T_world_keyframe * points_camera[k] when the keypoint has
  // depth (else it is ignored). A second keypoint of the keyframe naming the same point is
  // ignored. Returns the number of observations added.
  int AddKeyframe(int64_t session_id, int keyframe, int index_in_session,
                  const FrameFeatures& features, const Eigen::Isometry3d& T_world_keyframe,
                  const std::vector<int64_t>& tracker_point_ids);

  // The keyframes sharing points with `keyframe`, with the number shared, most first.
  std::vector<std::pair<int, int>> Covisible(int keyframe) const;

  // `keyframe`, its max_free - 1 most covisible keyframes (free), the points the free ones
  // observe, and up to max_fixed other keyframes observing those points (fixed), those
  // observing most of them first.
  BundleAdjustmentWindow LocalWindow(int keyframe, int max_free, int max_fixed) const;

  const MapPointState* Find(int64_t id) const;
  const std::vector<int64_t>& PointsOf(int keyframe) const;  // empty for an unknown keyframe
  void SetPosition(int64_t id, const Eigen::Vector3d& position_world);
  // A correction of keyframe poses (T_new_old by graph node): each point moves rigidly with
  // its oldest observing keyframe, when that one is in the map.
  void MoveWithKeyframes(const std::map<int, Eigen::Isometry3d>& T_new_old);
  // The point each keypoint of `keyframe` observes (keypoint -> point id).
  std::unordered_map<int, int64_t> PointsByKeypoint(int keyframe) const;
  // Merges point `drop` into `keep` (the same 3D point reached twice, e.g. both sides of a
  // loop): keep gains drop's observations of keyframes it is not observed by, and drop's
  // tracker id names keep from now on. False (nothing changed) when either is unknown or they
  // are the same point.
  bool Fuse(int64_t keep, int64_t drop);
  // The observation (ObservationOf) of point `id` (point fusion found it there). False
  // (nothing changed) for an unknown point or one its keyframe already observes.
  bool AddObservation(int64_t id, const MapPointObservation& observation);
  // A point read back from the store (a restarted server), created by session `session_id`,
  // observed by `observations` (ObservationOf: graph nodes, any order; one per keyframe is
  // kept). It has no
  // tracker id until a session's tracker is given it (TrackerIdFor) and is not culled as a
  // recent point; one with fewer than min_observations waits for later looks (EndSession).
  // Returns its id; -1 (nothing added) without an observation.
  int64_t Restore(int64_t session_id, const Eigen::Vector3d& position_world,
                  std::vector<MapPointObservation> observations);
  // The id session `session_id`'s tracker knows point `id` by: the tracker id it created the
  // point under, or an alias. A point it never named (another session's, a restored one) goes
  // by its foreign name kForeignTrackerIdBase + id, a range trackers never issue, so keypoints
  // its keyframes match to that id become observations of this point. Foreign names are not
  // stored per session (a map revisited every day would grow by every point each visit sees).
  // -1 for an unknown point.
  int64_t TrackerIdFor(int64_t session_id, int64_t id) const;
  static constexpr int64_t kForeignTrackerIdBase = int64_t{1} << 62;
  static constexpr int64_t kAnySession = -1;
  void ForEach(const std::function<void(const MapPointState&)>& visit) const;
  // Removes every observation of `keyframe` (a culled keyframe); points left without one are
  // removed.
  void RemoveKeyframe(int keyframe);
  // Removes the observation; a point left without observations is removed.
  void RemoveObservation(int64_t id, int keyframe);
  // Culls the session's points that are old enough and still observed too rarely (options);
  // `newest_in_session`: index_in_session of the session's newest keyframe. Returns how many.
  int Cull(int64_t session_id, int newest_in_session);
  // The session has ended before judging its youngest points (those of its last keyframes):
  // they wait for other sessions' keyframes instead. Each later keyframe sharing points with a
  // waiting point's creating keyframe (JudgeAround) is a look at that place; after
  // cull_age_keyframes looks its waiting points are judged like recent ones. A place no later
  // session comes back to keeps them (its next visitor will track against them), while a place
  // revisited again and again does not keep every visit's unconfirmed points.
  void EndSession(int64_t session_id);
  // `keyframe` (just added, its points and fused observations in place) looks at the places it
  // shares points with; judges the waiting points of those looked at often enough. Returns how
  // many points were removed.
  int JudgeAround(int keyframe);

  size_t size() const { return points_.size(); }
  size_t num_observations() const { return num_observations_; }
  // Approximate heap bytes of the points, their observations and the lookup tables.
  size_t HeldBytes() const;

 private:
  void Erase(int64_t id);
  // Seen by fewer keyframes than min_observations: what culling removes once judged.
  bool Unconfirmed(const MapPointState& point) const {
    return static_cast<int>(point.observations.size()) < options_.min_observations;
  }
  // Queues the point under the keyframe at its place until enough looks there (EndSession).
  void AwaitJudgement(const MapPointState& point);
  // The point session `session_id`'s tracker id names (its own, an alias, a foreign name), if
  // it is in the map.
  std::optional<int64_t> Resolve(int64_t session_id, int64_t tracker_id) const;

  MapPointsOptions options_;
  std::unordered_map<int64_t, MapPointState> points_;
  std::map<std::pair<int64_t, int64_t>, int64_t> by_tracker_id_;  // (session, tracker id) -> id
  std::vector<std::vector<int64_t>> points_of_keyframe_;          // by graph node
  // Points that may still be culled, by session (removed once they pass the age test).
  std::map<int64_t, std::vector<int64_t>> recent_;
  // An ended session's points not yet judged, by the keyframe that created them (EndSession).
  struct AwaitingJudgement {
    int looks = 0;
    std::vector<int64_t> points;
  };
  std::map<int, AwaitingJudgement> awaiting_;
  int64_t next_id_ = 0;
  size_t num_observations_ = 0;
};

}  // namespace semmap
