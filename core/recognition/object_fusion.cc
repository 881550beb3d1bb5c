#include "core/recognition/object_fusion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>
#include <utility>

namespace semmap {
namespace {

bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

// Strongest first; every field takes part so that only identical observations tie.
bool Stronger(const WorldObjectObservation& a, const WorldObjectObservation& b) {
  const auto key = [](const WorldObjectObservation& o) {
    return std::make_tuple(-o.inliers, -o.matches, o.stamp_ns, o.session_id, o.p_world.x(),
                           o.p_world.y(), o.p_world.z(), o.extent_world.x(), o.extent_world.y(),
                           o.extent_world.z(), o.label);
  };
  return key(a) < key(b);
}

double Median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  const double upper = v[mid];
  if (v.size() % 2 == 1) return upper;
  const double lower = *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lower + upper);
}

Eigen::Vector3d MedianOf(const std::vector<const WorldObjectObservation*>& members, bool extent) {
  Eigen::Vector3d out;
  std::vector<double> v(members.size());
  for (int a = 0; a < 3; ++a) {
    for (size_t i = 0; i < members.size(); ++i) {
      v[i] = extent ? members[i]->extent_world[a] : members[i]->p_world[a];
    }
    out[a] = Median(v);
  }
  return out;
}

// Index of the nearest of `centres` within `radius` of p (lowest index on ties), or -1.
int Nearest(const std::vector<Eigen::Vector3d>& centres, const Eigen::Vector3d& p, double radius) {
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (size_t c = 0; c < centres.size(); ++c) {
    const double d = (centres[c] - p).norm();
    if (d <= radius && d < best_d) {
      best_d = d;
      best = static_cast<int>(c);
    }
  }
  return best;
}

// Clusters one (map, type) group, sorted strongest first; returns cluster index per member.
std::vector<int> Cluster(const std::vector<const WorldObjectObservation*>& group, double radius) {
  std::vector<Eigen::Vector3d> seeds;
  std::vector<int> cluster(group.size(), -1);
  for (size_t i = 0; i < group.size(); ++i) {
    int c = Nearest(seeds, group[i]->p_world, radius);
    if (c < 0) {
      c = static_cast<int>(seeds.size());
      seeds.push_back(group[i]->p_world);
    }
    cluster[i] = c;
  }
  // One pass towards the nearest cluster median.
  std::vector<std::vector<const WorldObjectObservation*>> members(seeds.size());
  for (size_t i = 0; i < group.size(); ++i) {
    members[static_cast<size_t>(cluster[i])].push_back(group[i]);
  }
  std::vector<Eigen::Vector3d> medians;
  medians.reserve(members.size());
  for (const auto& m : members) medians.push_back(MedianOf(m, false));
  for (size_t i = 0; i < group.size(); ++i) {
    const int c = Nearest(medians, group[i]->p_world, radius);
    if (c >= 0) cluster[i] = c;
  }
  return cluster;
}

}  // namespace

WorldObjectObservation ObservationInWorld(const ObjectObservation& o,
                                          const Eigen::Isometry3d& T_world_keyframe) {
  WorldObjectObservation w;
  w.map_id = o.map_id;
  w.type_id = o.type_id;
  w.label = o.label;
  w.session_id = o.session_id;
  w.stamp_ns = o.stamp_ns;
  w.matches = o.matches;
  w.inliers = o.inliers;
  w.p_world = T_world_keyframe * o.p_keyframe;
  w.extent_world = T_world_keyframe.linear().cwiseAbs() * o.extent;
  return w;
}

Status ObjectFusionOptions::Validate() const {
  if (!std::isfinite(merge_distance_m) || merge_distance_m <= 0) {
    return InvalidArgumentError("fusion merge_distance_m must be positive");
  }
  if (!std::isfinite(full_weight_inliers) || full_weight_inliers <= 0) {
    return InvalidArgumentError("fusion full_weight_inliers must be positive");
  }
  if (!std::isfinite(confidence_scale) || confidence_scale <= 0) {
    return InvalidArgumentError("fusion confidence_scale must be positive");
  }
  if (min_observations < 1) return InvalidArgumentError("fusion min_observations must be >= 1");
  return OkStatus();
}

double InstanceConfidence(const std::vector<int>& inliers, const ObjectFusionOptions& options) {
  double w = 0;
  for (int n : inliers) w += std::clamp(n / options.full_weight_inliers, 0.0, 1.0);
  return 1.0 - std::exp(-w / options.confidence_scale);
}

StatusOr<std::vector<ObjectInstance>> FuseObservations(
    const std::vector<WorldObjectObservation>& observations, const ObjectFusionOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  std::map<std::pair<int64_t, int64_t>, std::vector<const WorldObjectObservation*>> groups;
  for (const WorldObjectObservation& o : observations) {
    if (!Finite(o.p_world) || !Finite(o.extent_world)) continue;
    groups[{o.map_id, o.type_id}].push_back(&o);
  }
  std::vector<ObjectInstance> out;
  for (auto& [key, group] : groups) {
    std::sort(group.begin(), group.end(),
              [](const WorldObjectObservation* a, const WorldObjectObservation* b) {
                return Stronger(*a, *b);
              });
    const std::vector<int> cluster = Cluster(group, options.merge_distance_m);
    const int clusters =
        cluster.empty() ? 0 : *std::max_element(cluster.begin(), cluster.end()) + 1;
    std::vector<std::vector<const WorldObjectObservation*>> members(static_cast<size_t>(clusters));
    for (size_t i = 0; i < group.size(); ++i) {
      members[static_cast<size_t>(cluster[i])].push_back(group[i]);
    }
    for (const auto& m : members) {
      if (m.empty() || static_cast<int>(m.size()) < options.min_observations) continue;
      ObjectInstance inst;
      inst.map_id = key.first;
      inst.type_id = key.second;
      inst.label = m.front()->label;  // the strongest observation's
      inst.position = MedianOf(m, false);
      inst.extent = MedianOf(m, true);
      inst.observations = static_cast<int>(m.size());
      std::vector<int> inliers;
      inst.first_seen_ns = std::numeric_limits<int64_t>::max();
      inst.last_seen_ns = std::numeric_limits<int64_t>::min();
      for (const WorldObjectObservation* o : m) {
        inliers.push_back(o->inliers);
        inst.session_ids.push_back(o->session_id);
        inst.first_seen_ns = std::min(inst.first_seen_ns, o->stamp_ns);
        inst.last_seen_ns = std::max(inst.last_seen_ns, o->stamp_ns);
      }
      std::sort(inst.session_ids.begin(), inst.session_ids.end());
      inst.session_ids.erase(std::unique(inst.session_ids.begin(), inst.session_ids.end()),
                             inst.session_ids.end());
      inst.confidence = InstanceConfidence(inliers, options);
      out.push_back(std::move(inst));
    }
  }
  std::sort(out.begin(), out.end(), [](const ObjectInstance& a, const ObjectInstance& b) {
    return std::make_tuple(a.map_id, a.label, a.type_id, a.position.x(), a.position.y(),
                           a.position.z()) < std::make_tuple(b.map_id, b.label, b.type_id,
                                                             b.position.x(), b.position.y(),
                                                             b.position.z());
  });
  return out;
}

}  // namespace semmap
