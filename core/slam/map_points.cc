#include "core/slam/map_points.h"

#include <algorithm>

namespace semmap {

Status MapPointsOptions::Validate() const {
  if (min_observations < 1) return InvalidArgumentError("map points min_observations must be >= 1");
  if (cull_age_keyframes < 1) {
    return InvalidArgumentError("map points cull_age_keyframes must be >= 1");
  }
  return OkStatus();
}

MapPointObservation ObservationOf(int keyframe, int keypoint, const FrameFeatures& features) {
  const auto k = static_cast<size_t>(keypoint);
  MapPointObservation o;
  o.keyframe = keyframe;
  o.keypoint = keypoint;
  o.u = features.keypoints[k].pt.x;
  o.v = features.keypoints[k].pt.y;
  o.octave = features.keypoints[k].octave;
  if (features.has_depth[k] && features.points_camera[k].z() > 0) {
    o.inverse_depth = static_cast<float>(1 / features.points_camera[k].z());
  }
  return o;
}

int MapPoints::AddKeyframe(int64_t session_id, int keyframe, int index_in_session,
                           const FrameFeatures& features, const Eigen::Isometry3d& T_world_keyframe,
                           const std::vector<int64_t>& tracker_point_ids) {
  if (keyframe < 0) return 0;
  if (points_of_keyframe_.size() <= static_cast<size_t>(keyframe)) {
    points_of_keyframe_.resize(static_cast<size_t>(keyframe) + 1);
  }
  std::vector<int64_t>& seen = points_of_keyframe_[static_cast<size_t>(keyframe)];
  const size_t n = std::min(tracker_point_ids.size(), features.size());
  int added = 0;
  for (size_t k = 0; k < n; ++k) {
    const int64_t tracker_id = tracker_point_ids[k];
    if (tracker_id < 0) continue;
    const std::optional<int64_t> known = Resolve(session_id, tracker_id);
    MapPointState* point = nullptr;
    if (known) {
      point = &points_.at(*known);
      // One observation per keyframe: a second keypoint naming the point is a duplicate match.
      if (!point->observations.empty() && point->observations.back().keyframe == keyframe) {
        continue;
      }
    } else {
      if (!features.has_depth[k]) continue;  // nothing to place it by
      const int64_t id = next_id_++;
      MapPointState& created = points_[id];
      created.id = id;
      created.position_world = T_world_keyframe * features.points_camera[k];
      created.session_id = session_id;
      created.tracker_id = tracker_id;
      created.created_in_session = index_in_session;
      by_tracker_id_.emplace(std::make_pair(session_id, tracker_id), id);
      recent_[session_id].push_back(id);
      point = &created;
    }
    point->observations.push_back(ObservationOf(keyframe, static_cast<int>(k), features));
    seen.push_back(point->id);
    ++num_observations_;
    ++added;
  }
  return added;
}

std::vector<std::pair<int, int>> MapPoints::Covisible(int keyframe) const {
  std::map<int, int> shared;
  for (int64_t id : PointsOf(keyframe)) {
    for (const MapPointObservation& o : points_.at(id).observations) {
      if (o.keyframe != keyframe) ++shared[o.keyframe];
    }
  }
  std::vector<std::pair<int, int>> result(shared.begin(), shared.end());
  std::stable_sort(result.begin(), result.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  return result;
}

BundleAdjustmentWindow MapPoints::LocalWindow(int keyframe, int max_free, int max_fixed) const {
  BundleAdjustmentWindow window;
  if (max_free < 1) return window;
  window.free_keyframes.push_back(keyframe);
  for (const auto& [other, count] : Covisible(keyframe)) {
    if (static_cast<int>(window.free_keyframes.size()) >= max_free) break;
    window.free_keyframes.push_back(other);
  }
  std::sort(window.free_keyframes.begin(), window.free_keyframes.end());
  const auto is_free = [&](int k) {
    return std::binary_search(window.free_keyframes.begin(), window.free_keyframes.end(), k);
  };
  std::map<int, int> outside;  // keyframe -> observations of window points
  for (int k : window.free_keyframes) {
    for (int64_t id : PointsOf(k)) window.points.push_back(id);
  }
  std::sort(window.points.begin(), window.points.end());
  window.points.erase(std::unique(window.points.begin(), window.points.end()), window.points.end());
  for (int64_t id : window.points) {
    for (const MapPointObservation& o : points_.at(id).observations) {
      if (!is_free(o.keyframe)) ++outside[o.keyframe];
    }
  }
  std::vector<std::pair<int, int>> ranked(outside.begin(), outside.end());
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  for (const auto& [k, count] : ranked) {
    if (static_cast<int>(window.fixed_keyframes.size()) >= max_fixed) break;
    window.fixed_keyframes.push_back(k);
  }
  std::sort(window.fixed_keyframes.begin(), window.fixed_keyframes.end());
  return window;
}

const MapPointState* MapPoints::Find(int64_t id) const {
  const auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

const std::vector<int64_t>& MapPoints::PointsOf(int keyframe) const {
  static const std::vector<int64_t> kNone;
  if (keyframe < 0 || static_cast<size_t>(keyframe) >= points_of_keyframe_.size()) return kNone;
  return points_of_keyframe_[static_cast<size_t>(keyframe)];
}

void MapPoints::SetPosition(int64_t id, const Eigen::Vector3d& position_world) {
  const auto it = points_.find(id);
  if (it != points_.end()) it->second.position_world = position_world;
}

void MapPoints::MoveWithKeyframes(const std::map<int, Eigen::Isometry3d>& T_new_old) {
  if (T_new_old.empty()) return;
  for (auto& [id, point] : points_) {
    if (point.observations.empty()) continue;
    const auto T = T_new_old.find(point.observations.front().keyframe);
    if (T != T_new_old.end()) point.position_world = T->second * point.position_world;
  }
}

std::unordered_map<int, int64_t> MapPoints::PointsByKeypoint(int keyframe) const {
  std::unordered_map<int, int64_t> out;
  for (int64_t id : PointsOf(keyframe)) {
    for (const MapPointObservation& o : points_.at(id).observations) {
      if (o.keyframe == keyframe) out.emplace(o.keypoint, id);
    }
  }
  return out;
}

bool MapPoints::Fuse(int64_t keep, int64_t drop) {
  if (keep == drop) return false;
  const auto k = points_.find(keep), d = points_.find(drop);
  if (k == points_.end() || d == points_.end()) return false;
  MapPointState& kept = k->second;
  for (const MapPointObservation& o : d->second.observations) {
    auto& of_keyframe = points_of_keyframe_[static_cast<size_t>(o.keyframe)];
    of_keyframe.erase(std::remove(of_keyframe.begin(), of_keyframe.end(), drop), of_keyframe.end());
    const bool seen =
        std::any_of(kept.observations.begin(), kept.observations.end(),
                    [&](const MapPointObservation& x) { return x.keyframe == o.keyframe; });
    if (seen) {
      --num_observations_;
      continue;
    }
    kept.observations.push_back(o);
    of_keyframe.push_back(keep);
  }
  // Every tracker id of the dropped point now names the kept one, its foreign name included.
  std::vector<std::pair<int64_t, int64_t>> names = d->second.aliases;
  names.emplace_back(d->second.session_id, d->second.tracker_id);
  names.emplace_back(kAnySession, kForeignTrackerIdBase + drop);
  for (const auto& name : names) {
    by_tracker_id_[name] = keep;
    kept.aliases.push_back(name);
  }
  points_.erase(d);
  return true;
}

bool MapPoints::AddObservation(int64_t id, const MapPointObservation& observation) {
  const int keyframe = observation.keyframe;
  const auto it = points_.find(id);
  if (it == points_.end() || keyframe < 0 || observation.keypoint < 0) return false;
  std::vector<MapPointObservation>& observations = it->second.observations;
  if (std::any_of(observations.begin(), observations.end(),
                  [&](const MapPointObservation& o) { return o.keyframe == keyframe; })) {
    return false;
  }
  // Kept in keyframe order: the newest observation stays last (its descriptor is the point's).
  const auto at =
      std::upper_bound(observations.begin(), observations.end(), keyframe,
                       [](int k, const MapPointObservation& o) { return k < o.keyframe; });
  observations.insert(at, observation);
  if (points_of_keyframe_.size() <= static_cast<size_t>(keyframe)) {
    points_of_keyframe_.resize(static_cast<size_t>(keyframe) + 1);
  }
  points_of_keyframe_[static_cast<size_t>(keyframe)].push_back(id);
  ++num_observations_;
  return true;
}

int64_t MapPoints::Restore(int64_t session_id, const Eigen::Vector3d& position_world,
                           std::vector<MapPointObservation> observations) {
  std::sort(observations.begin(), observations.end(),
            [](const MapPointObservation& a, const MapPointObservation& b) {
              return a.keyframe < b.keyframe;
            });
  observations.erase(std::unique(observations.begin(), observations.end(),
                                 [](const MapPointObservation& a, const MapPointObservation& b) {
                                   return a.keyframe == b.keyframe;
                                 }),
                     observations.end());
  observations.erase(std::remove_if(observations.begin(), observations.end(),
                                    [](const MapPointObservation& o) { return o.keyframe < 0; }),
                     observations.end());
  if (observations.empty()) return -1;
  const int64_t id = next_id_++;
  MapPointState& point = points_[id];
  point.id = id;
  point.position_world = position_world;
  point.session_id = session_id;
  point.tracker_id = -1;  // no tracker names it yet
  for (const MapPointObservation& o : observations) {
    if (points_of_keyframe_.size() <= static_cast<size_t>(o.keyframe)) {
      points_of_keyframe_.resize(static_cast<size_t>(o.keyframe) + 1);
    }
    points_of_keyframe_[static_cast<size_t>(o.keyframe)].push_back(id);
  }
  num_observations_ += observations.size();
  point.observations = std::move(observations);
  // Stored unconfirmed (its session ended before judging it): later looks judge it, as they
  // would have had the map stayed in memory.
  if (Unconfirmed(point)) AwaitJudgement(point);
  return id;
}

int64_t MapPoints::TrackerIdFor(int64_t session_id, int64_t id) const {
  const auto it = points_.find(id);
  if (it == points_.end()) return -1;
  const MapPointState& point = it->second;
  if (point.session_id == session_id && point.tracker_id >= 0) return point.tracker_id;
  for (const auto& [session, tracker_id] : point.aliases) {
    if (session == session_id) return tracker_id;
  }
  return kForeignTrackerIdBase + id;
}

std::optional<int64_t> MapPoints::Resolve(int64_t session_id, int64_t tracker_id) const {
  if (const auto named = by_tracker_id_.find({session_id, tracker_id});
      named != by_tracker_id_.end()) {
    return named->second;
  }
  if (tracker_id < kForeignTrackerIdBase) return std::nullopt;
  if (points_.count(tracker_id - kForeignTrackerIdBase) != 0) {
    return tracker_id - kForeignTrackerIdBase;
  }
  // The foreign name of a point fused into another.
  if (const auto fused = by_tracker_id_.find({kAnySession, tracker_id});
      fused != by_tracker_id_.end()) {
    return fused->second;
  }
  return std::nullopt;
}

void MapPoints::ForEach(const std::function<void(const MapPointState&)>& visit) const {
  for (const auto& [id, point] : points_) visit(point);
}

void MapPoints::RemoveKeyframe(int keyframe) {
  if (keyframe < 0 || static_cast<size_t>(keyframe) >= points_of_keyframe_.size()) return;
  awaiting_.erase(keyframe);  // no keyframe will share points with it: never looked at again
  // A copy: RemoveObservation edits the keyframe's list.
  const std::vector<int64_t> seen = points_of_keyframe_[static_cast<size_t>(keyframe)];
  for (int64_t id : seen) RemoveObservation(id, keyframe);
}

void MapPoints::RemoveObservation(int64_t id, int keyframe) {
  const auto it = points_.find(id);
  if (it == points_.end()) return;
  auto& observations = it->second.observations;
  const auto o = std::find_if(observations.begin(), observations.end(),
                              [&](const MapPointObservation& x) { return x.keyframe == keyframe; });
  if (o == observations.end()) return;
  observations.erase(o);
  --num_observations_;
  auto& of_keyframe = points_of_keyframe_[static_cast<size_t>(keyframe)];
  of_keyframe.erase(std::remove(of_keyframe.begin(), of_keyframe.end(), id), of_keyframe.end());
  if (observations.empty()) Erase(id);
}

int MapPoints::Cull(int64_t session_id, int newest_in_session) {
  const auto recent = recent_.find(session_id);
  if (recent == recent_.end()) return 0;
  int culled = 0;
  std::vector<int64_t> still_recent;
  for (int64_t id : recent->second) {
    const auto it = points_.find(id);
    if (it == points_.end()) continue;  // already gone
    if (newest_in_session - it->second.created_in_session < options_.cull_age_keyframes) {
      still_recent.push_back(id);
      continue;
    }
    if (Unconfirmed(it->second)) {
      Erase(id);
      ++culled;
    }
  }
  recent->second = std::move(still_recent);
  return culled;
}

void MapPoints::EndSession(int64_t session_id) {
  const auto recent = recent_.find(session_id);
  if (recent == recent_.end()) return;
  for (int64_t id : recent->second) {
    const auto it = points_.find(id);
    if (it != points_.end()) AwaitJudgement(it->second);
  }
  recent_.erase(recent);
}

void MapPoints::AwaitJudgement(const MapPointState& point) {
  if (point.observations.empty()) return;
  // Its oldest observation: the creator's (observations stay in keyframe order), unless BA
  // removed that one; either way a keyframe at the point's place.
  awaiting_[point.observations.front().keyframe].points.push_back(point.id);
}

int MapPoints::JudgeAround(int keyframe) {
  if (awaiting_.empty()) return 0;
  std::vector<int> looked_at;
  for (int64_t id : PointsOf(keyframe)) {
    for (const MapPointObservation& o : points_.at(id).observations) {
      if (o.keyframe != keyframe && awaiting_.count(o.keyframe) != 0)
        looked_at.push_back(o.keyframe);
    }
  }
  std::sort(looked_at.begin(), looked_at.end());
  looked_at.erase(std::unique(looked_at.begin(), looked_at.end()), looked_at.end());
  int culled = 0;
  for (int place : looked_at) {
    const auto waiting = awaiting_.find(place);
    if (++waiting->second.looks < options_.cull_age_keyframes) continue;
    for (int64_t id : waiting->second.points) {
      const auto it = points_.find(id);
      if (it != points_.end() && Unconfirmed(it->second)) {
        Erase(id);
        ++culled;
      }
    }
    awaiting_.erase(waiting);
  }
  return culled;
}

void MapPoints::Erase(int64_t id) {
  const auto it = points_.find(id);
  if (it == points_.end()) return;
  for (const MapPointObservation& o : it->second.observations) {
    auto& of_keyframe = points_of_keyframe_[static_cast<size_t>(o.keyframe)];
    of_keyframe.erase(std::remove(of_keyframe.begin(), of_keyframe.end(), id), of_keyframe.end());
    --num_observations_;
  }
  by_tracker_id_.erase({it->second.session_id, it->second.tracker_id});
  for (const auto& alias : it->second.aliases) by_tracker_id_.erase(alias);
  points_.erase(it);
}

size_t MapPoints::HeldBytes() const {
  // A tree or hash node: its value plus about three pointers and the allocator's rounding.
  constexpr size_t kNodeOverhead = 4 * sizeof(void*);
  size_t bytes =
      points_.bucket_count() * sizeof(void*) +
      points_.size() * (sizeof(std::pair<const int64_t, MapPointState>) + kNodeOverhead) +
      by_tracker_id_.size() *
          (sizeof(std::pair<const std::pair<int64_t, int64_t>, int64_t>) + kNodeOverhead) +
      points_of_keyframe_.capacity() * sizeof(std::vector<int64_t>);
  for (const auto& [id, point] : points_) {
    bytes += point.observations.capacity() * sizeof(MapPointObservation) +
             point.aliases.capacity() * sizeof(std::pair<int64_t, int64_t>);
  }
  for (const std::vector<int64_t>& ids : points_of_keyframe_) {
    bytes += ids.capacity() * sizeof(int64_t);
  }
  for (const auto& [session, ids] : recent_) {
    bytes += sizeof(std::pair<const int64_t, std::vector<int64_t>>) + kNodeOverhead +
             ids.capacity() * sizeof(int64_t);
  }
  for (const auto& [keyframe, waiting] : awaiting_) {
    bytes += sizeof(std::pair<const int, AwaitingJudgement>) + kNodeOverhead +
             waiting.points.capacity() * sizeof(int64_t);
  }
  return bytes;
}

}  // namespace semmap
