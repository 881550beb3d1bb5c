#include "core/mapping/internal/octree_batch_update.h"

#include <algorithm>
#include <array>
#include <bit>

namespace semmap::internal {
namespace {

constexpr unsigned kTreeDepth = 16;  // OctoMap's fixed depth: leaves at depth 16

uint64_t Pack(const octomap::OcTreeKey& key) {
  return uint64_t{key.k[0]} | uint64_t{key.k[1]} << 16 | uint64_t{key.k[2]} << 32;
}

octomap::OcTreeKey Unpack(uint64_t packed) {
  return octomap::OcTreeKey(static_cast<octomap::key_type>(packed & 0xFFFF),
                            static_cast<octomap::key_type>((packed >> 16) & 0xFFFF),
                            static_cast<octomap::key_type>((packed >> 32) & 0xFFFF));
}

// A set of packed keys with open addressing: the rays of one scan pass through the same voxels
// many times (near the camera, every ray), so most inserts find the key already there.
class PackedKeySet {
 public:
  explicit PackedKeySet(size_t expected) {
    size_t capacity = 1024;
    while (capacity < 2 * expected) capacity *= 2;
    Resize(capacity);
  }

  void Insert(uint64_t packed) {
    if (2 * (size_ + 1) > slots_.size()) Resize(2 * slots_.size());
    for (size_t i = Slot(packed);; i = (i + 1) & mask_) {
      if (slots_[i] == packed) return;
      if (slots_[i] == kEmpty) {
        slots_[i] = packed;
        ++size_;
        return;
      }
    }
  }

  template <typename Visit>
  void ForEach(Visit&& visit) const {
    for (uint64_t packed : slots_) {
      if (packed != kEmpty) visit(packed);
    }
  }

  size_t size() const { return size_; }

 private:
  static constexpr uint64_t kEmpty = ~uint64_t{0};  // packed keys use 48 bits

  size_t Slot(uint64_t packed) const {
    return static_cast<size_t>((packed * 0x9E3779B97F4A7C15ULL) >> shift_);
  }

  void Resize(size_t capacity) {
    std::vector<uint64_t> old = std::move(slots_);
    slots_.assign(capacity, kEmpty);
    mask_ = capacity - 1;
    shift_ = 64 - static_cast<unsigned>(std::countr_zero(capacity));
    size_ = 0;
    for (uint64_t packed : old) {
      if (packed != kEmpty) Insert(packed);
    }
  }

  std::vector<uint64_t> slots_;
  size_t mask_ = 0;
  unsigned shift_ = 64;
  size_t size_ = 0;
};

// The key whose Morton() is `code`.
octomap::OcTreeKey KeyOfMorton(uint64_t code) {
  auto compact = [](uint64_t x) {  // every third bit -> 16 bits
    x &= 0x249249249249ULL;
    x = (x | x >> 2) & 0x0C30C30C30C3ULL;
    x = (x | x >> 4) & 0x00F00F00F00FULL;
    x = (x | x >> 8) & 0x0000FF0000FFULL;
    x = (x | x >> 16) & 0xFFFFULL;
    return static_cast<octomap::key_type>(x);
  };
  return octomap::OcTreeKey(compact(code), compact(code >> 1), compact(code >> 2));
}

// Sorts 48-bit codes with byte-wise LSD radix passes, skipping the bytes every code shares
// (one scan's voxels lie in a few metres, so the high bytes mostly are): a fraction of a
// comparison sort's time for the tens of thousands of voxels a scan's rays pass through.
void RadixSortCodes(std::vector<uint64_t>& codes) {
  if (codes.size() < 2) return;
  std::vector<uint64_t> buffer(codes.size());
  for (unsigned shift = 0; shift < 48; shift += 8) {
    std::array<size_t, 257> offsets{};
    for (uint64_t code : codes) ++offsets[((code >> shift) & 0xFF) + 1];
    if (std::find(offsets.begin(), offsets.end(), codes.size()) != offsets.end()) continue;
    for (size_t d = 1; d < offsets.size(); ++d) offsets[d] += offsets[d - 1];
    for (uint64_t code : codes) buffer[offsets[(code >> shift) & 0xFF]++] = code;
    codes.swap(buffer);
  }
}

// The descent of ApplyCellUpdates, mirroring OccupancyOcTreeBase::updateNode's steps per node.
class BatchUpdater {
 public:
  explicit BatchUpdater(octomap::ColorOcTree& tree)
      : tree_(tree),
        hit_(tree.getProbHitLog()),
        miss_(tree.getProbMissLog()),
        min_(tree.getClampingThresMinLog()),
        max_(tree.getClampingThresMaxLog()) {}

  // Updates the subtree of `node` (at `depth`) with [begin, end), all under it; true when any
  // of them changed something (then `node` was pruned or its occupancy recomputed, as each
  // update through it does; otherwise it is left alone, as updateNode's early abort does).
  bool Update(octomap::ColorOcTreeNode* node, bool just_created, unsigned depth,
              const CellUpdate* begin, const CellUpdate* end) {
    if (depth == kTreeDepth) {  // a leaf voxel: its one update (keys are unique)
      if (!just_created && Unchanged(*node, begin->occupied)) return false;
      tree_.updateNodeLogOdds(node, LogOdds(begin->occupied));
      return true;
    }
    if (!just_created && !tree_.nodeHasChildren(node)) {
      // A pruned leaf: updateNode's search() ends here for every key below, and an update it
      // would not change is skipped. The others expand it; its children copy its value, so
      // they skip the same ones.
      if (std::all_of(begin, end,
                      [&](const CellUpdate& u) { return Unchanged(*node, u.occupied); })) {
        return false;
      }
      tree_.expandNode(node);
    }
    const unsigned shift = 3 * (kTreeDepth - 1 - depth);
    bool touched = false;
    for (const CellUpdate* first = begin; first != end;) {
      const auto child = static_cast<unsigned>((first->code >> shift) & 7);
      const CellUpdate* last = first + 1;
      while (last != end && ((last->code >> shift) & 7) == child) ++last;
      bool created = false;
      if (!tree_.nodeChildExists(node, child)) {
        tree_.createNodeChild(node, child);
        created = true;
      }
      touched |= Update(tree_.getNodeChild(node, child), created, depth + 1, first, last);
      first = last;
    }
    if (touched && !tree_.pruneNode(node)) node->updateOccupancyChildren();
    return touched;
  }

 private:
  float LogOdds(bool occupied) const { return occupied ? hit_ : miss_; }

  // updateNode's early abort: the node is already clamped in the update's direction.
  bool Unchanged(const octomap::ColorOcTreeNode& node, bool occupied) const {
    const float update = LogOdds(occupied);
    const float value = node.getLogOdds();
    return (update >= 0 && value >= max_) || (update <= 0 && value <= min_);
  }

  octomap::ColorOcTree& tree_;
  const float hit_, miss_, min_, max_;
};

}  // namespace

uint64_t Morton(const octomap::OcTreeKey& key) {
  auto spread = [](uint64_t x) {  // 16 bits -> every third bit
    x = (x | x << 16) & 0x0000FF0000FFULL;
    x = (x | x << 8) & 0x00F00F00F00FULL;
    x = (x | x << 4) & 0x0C30C30C30C3ULL;
    x = (x | x << 2) & 0x249249249249ULL;
    return x;
  };
  return spread(key.k[0]) | spread(key.k[1]) << 1 | spread(key.k[2]) << 2;
}

std::vector<CellUpdate> ComputeScanUpdates(const octomap::ColorOcTree& tree,
                                           const octomap::Pointcloud& scan,
                                           const octomap::point3d& origin, double max_range_m) {
  // Mirrors OccupancyOcTreeBase::computeUpdate (no bounding box): the same float arithmetic and
  // the tree's own ray casting, so the same voxels.
  octomap::KeyRay ray;
  PackedKeySet free_cells(16 * scan.size());
  std::vector<CellUpdate> occupied;
  occupied.reserve(scan.size());
  for (const octomap::point3d& p : scan) {
    octomap::point3d ray_end = p;
    const bool within_range = max_range_m < 0.0 || (p - origin).norm() <= max_range_m;
    if (!within_range) {
      const octomap::point3d direction = (p - origin).normalized();
      ray_end = origin + direction * static_cast<float>(max_range_m);
    }
    if (tree.computeRayKeys(origin, ray_end, ray)) {
      for (const octomap::OcTreeKey& key : ray) free_cells.Insert(Pack(key));
    }
    octomap::OcTreeKey key;
    if (within_range && tree.coordToKeyChecked(p, key)) {
      occupied.push_back({Morton(key), key, true});
    }
  }
  const auto by_code = [](const CellUpdate& a, const CellUpdate& b) { return a.code < b.code; };
  std::sort(occupied.begin(), occupied.end(), by_code);
  occupied.erase(
      std::unique(occupied.begin(), occupied.end(),
                  [](const CellUpdate& a, const CellUpdate& b) { return a.code == b.code; }),
      occupied.end());
  // The free voxels outnumber the occupied ones several times: their codes alone are sorted.
  std::vector<uint64_t> free_codes;
  free_codes.reserve(free_cells.size());
  free_cells.ForEach([&](uint64_t packed) { free_codes.push_back(Morton(Unpack(packed))); });
  RadixSortCodes(free_codes);
  // Merged in code order; a voxel both passed through and ended in is occupied.
  std::vector<CellUpdate> out;
  out.reserve(free_codes.size() + occupied.size());
  auto free_code = free_codes.begin();
  const auto append_free_below = [&](uint64_t limit) {
    for (; free_code != free_codes.end() && *free_code < limit; ++free_code) {
      out.push_back({*free_code, KeyOfMorton(*free_code), false});
    }
  };
  for (const CellUpdate& o : occupied) {
    append_free_below(o.code);
    if (free_code != free_codes.end() && *free_code == o.code) ++free_code;
    out.push_back(o);
  }
  append_free_below(~uint64_t{0});
  return out;
}

void ApplyCellUpdates(octomap::ColorOcTree& tree, const std::vector<CellUpdate>& updates) {
  if (updates.empty()) return;
  const CellUpdate* begin = updates.data();
  const CellUpdate* end = begin + updates.size();
  if (tree.getRoot() == nullptr) {
    // OctoMap creates the root (a protected member) in updateNode: the first update goes that
    // way, and order does not matter.
    tree.updateNode(begin->key, begin->occupied, /*lazy_eval=*/false);
    ++begin;
    if (begin == end) return;
  }
  BatchUpdater(tree).Update(tree.getRoot(), /*just_created=*/false, 0, begin, end);
}

}  // namespace semmap::internal
