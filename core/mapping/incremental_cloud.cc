#include "core/mapping/incremental_cloud.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <new>
#include <string>
#include <utility>
#include <vector>

namespace semmap {
namespace {

constexpr int64_t kIndexBias = IncrementalCloud::kIndexReach;  // keys hold index + bias
constexpr uint64_t kIndexMask = (uint64_t{1} << 21) - 1;
constexpr double kOffsetUnits = 65536.0;  // offset quanta per leaf
constexpr uint32_t kMaxCount = 1u << 24;  // 255 * kMaxCount still fits a uint32 sum

// Leaf indices packed 21 bits per axis, z highest: sorted keys run along x, then y, then z.
uint64_t Pack(int64_t ix, int64_t iy, int64_t iz) {
  return static_cast<uint64_t>(ix + kIndexBias) | static_cast<uint64_t>(iy + kIndexBias) << 21 |
         static_cast<uint64_t>(iz + kIndexBias) << 42;
}

int64_t Unpack(uint64_t key, unsigned shift) {
  return static_cast<int64_t>((key >> shift) & kIndexMask) - kIndexBias;
}

}  // namespace

size_t IncrementalCloud::Home(uint64_t key) const {
  // Fibonacci hashing: the product's top bits, as many as the table needs.
  const int bits = std::countr_zero(slots_.size());
  return static_cast<size_t>((key * 0x9E3779B97F4A7C15ULL) >> (64 - bits));
}

size_t IncrementalCloud::Find(uint64_t key) const {
  if (slots_.empty()) return kNotFound;
  const size_t mask = slots_.size() - 1;
  for (size_t i = Home(key);; i = (i + 1) & mask) {
    if (slots_[i].key == key) return i;
    if (slots_[i].key == kEmpty) return kNotFound;
  }
}

size_t IncrementalCloud::FindOrInsert(uint64_t key) {
  if (8 * (size_ + 1) > 7 * slots_.size()) Grow();
  const size_t mask = slots_.size() - 1;
  for (size_t i = Home(key);; i = (i + 1) & mask) {
    if (slots_[i].key == key) return i;
    if (slots_[i].key == kEmpty) {
      slots_[i] = Slot{key};
      ++size_;
      return i;  // the caller counts its first point in
    }
  }
}

void IncrementalCloud::Erase(size_t index) {
  const size_t mask = slots_.size() - 1;
  size_t hole = index;
  slots_[hole].key = kEmpty;
  --size_;
  // Later entries of the same probe run move back into the hole when their home allows it.
  for (size_t i = (hole + 1) & mask; slots_[i].key != kEmpty; i = (i + 1) & mask) {
    const size_t home = Home(slots_[i].key);
    if (((i - home) & mask) >= ((i - hole) & mask)) {
      slots_[hole] = slots_[i];
      slots_[i].key = kEmpty;
      hole = i;
    }
  }
}

void IncrementalCloud::Grow() {
  std::vector<Slot> old = std::move(slots_);
  slots_.assign(old.empty() ? 1024 : 2 * old.size(), Slot{kEmpty});
  size_ = 0;
  for (const Slot& s : old) {
    if (s.key != kEmpty) slots_[FindOrInsert(s.key)] = s;
  }
}

StatusOr<IncrementalCloud> IncrementalCloud::Create(const PointCloudMapOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  return IncrementalCloud(options);
}

template <typename Visit>
Status IncrementalCloud::ForEachPoint(const KeyframeCloud& cloud,
                                      const Eigen::Isometry3d& T_world_keyframe,
                                      uint64_t* out_of_range, Visit&& visit) {
  if (cloud.colours.size() != cloud.points.size()) {
    return InvalidArgumentError("cloud has " + std::to_string(cloud.points.size()) +
                                " points but " + std::to_string(cloud.colours.size()) + " colours");
  }
  if (!T_world_keyframe.matrix().allFinite()) {
    return InvalidArgumentError("keyframe pose is not finite");
  }
  // The world points and leaf indices as PointCloudMap::Build and PCL compute them (float).
  const Eigen::Isometry3f T = T_world_keyframe.cast<float>();
  const float inverse_leaf = 1.0f / static_cast<float>(options_.leaf_size_m);
  const double leaf = options_.leaf_size_m;
  const double units_per_m = kOffsetUnits / leaf;
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const Eigen::Vector3f p = T * cloud.points[i];
    if (!p.allFinite()) continue;
    int64_t index[3];
    bool in_range = true;
    for (int a = 0; a < 3; ++a) {
      // floor(s) is in [-bias, bias) exactly when s is (bias is an integer).
      const float scaled = p[a] * inverse_leaf;
      in_range = in_range && scaled >= -static_cast<float>(kIndexBias) &&
                 scaled < static_cast<float>(kIndexBias);
      index[a] = in_range ? PclLeafIndex(p[a], inverse_leaf) : 0;
    }
    if (!in_range) {
      ++*out_of_range;
      continue;
    }
    std::array<int64_t, 3> offset;
    for (int a = 0; a < 3; ++a) {
      const double centre = (static_cast<double>(index[a]) + 0.5) * leaf;
      offset[a] = std::llrint((static_cast<double>(p[a]) - centre) * units_per_m);
    }
    const std::array<uint8_t, 3>& bgr = cloud.colours[i];
    visit(Pack(index[0], index[1], index[2]), offset, bgr[2], bgr[1], bgr[0]);
  }
  return OkStatus();
}

Status IncrementalCloud::Add(const KeyframeCloud& cloud,
                             const Eigen::Isometry3d& T_world_keyframe) {
  try {
    return ForEachPoint(
        cloud, T_world_keyframe, &points_out_of_range_,
        [&](uint64_t key, const std::array<int64_t, 3>& offset, uint8_t r, uint8_t g, uint8_t b) {
          Slot& s = slots_[FindOrInsert(key)];
          if (s.count == kMaxCount) {
            ++points_saturated_;
            return;
          }
          s.x += offset[0];
          s.y += offset[1];
          s.z += offset[2];
          s.r += r;
          s.g += g;
          s.b += b;
          ++s.count;
        });
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("point cloud layer: out of memory");
  }
}

Status IncrementalCloud::Remove(const KeyframeCloud& cloud,
                                const Eigen::Isometry3d& T_world_keyframe) {
  bool consistent = true;
  uint64_t out_of_range = 0;  // counted when added
  SEMMAP_RETURN_IF_ERROR(ForEachPoint(
      cloud, T_world_keyframe, &out_of_range,
      [&](uint64_t key, const std::array<int64_t, 3>& offset, uint8_t r, uint8_t g, uint8_t b) {
        const size_t found = Find(key);
        if (found == kNotFound) {
          consistent = false;
          return;
        }
        Slot& s = slots_[found];
        if (s.r < r || s.g < g || s.b < b) {
          consistent = false;
          return;
        }
        if (s.count == 1) {
          Erase(found);  // exactly gone, no residue
          return;
        }
        --s.count;
        s.x -= offset[0];
        s.y -= offset[1];
        s.z -= offset[2];
        s.r -= r;
        s.g -= g;
        s.b -= b;
      }));
  if (!consistent) {
    return FailedPreconditionError(
        "point cloud layer: a keyframe removed at a pose it was not added at");
  }
  return OkStatus();
}

void IncrementalCloud::Clear() {
  std::vector<Slot>().swap(slots_);  // give the memory back too
  size_ = 0;
  points_out_of_range_ = 0;
  points_saturated_ = 0;
}

PointCloudMap IncrementalCloud::Snapshot() const {
  const double leaf = options_.leaf_size_m;
  const float inverse_leaf = 1.0f / static_cast<float>(leaf);
  std::vector<CloudPoint> points;
  points.reserve(size_);
  for (const Slot& s : slots_) {
    if (s.key == kEmpty) continue;
    const uint64_t key = s.key;
    const double scale = leaf / (kOffsetUnits * static_cast<double>(s.count));
    const auto at = [&](unsigned shift, int64_t sum) {
      const int64_t index = Unpack(key, shift);
      const double centre = (static_cast<double>(index) + 0.5) * leaf;
      auto v = static_cast<float>(centre + static_cast<double>(sum) * scale);
      // A mean within a quantum of the leaf's edge may round into the next leaf (as the float
      // index sees it): step it back towards the centre, as a mean of the points never leaves.
      const auto toward = static_cast<float>(centre);
      while (PclLeafIndex(v, inverse_leaf) != index) {
        v = std::nextafter(v, toward);
      }
      return v;
    };
    CloudPoint p;
    p.x = at(0, s.x);
    p.y = at(21, s.y);
    p.z = at(42, s.z);
    p.r = static_cast<uint8_t>(s.r / s.count);
    p.g = static_cast<uint8_t>(s.g / s.count);
    p.b = static_cast<uint8_t>(s.b / s.count);
    points.push_back(p);
  }
  return PointCloudMap::FromPoints(std::move(points), options_);
}

}  // namespace semmap
