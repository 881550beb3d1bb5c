#include "core/mapping/occupancy_map.h"

#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <functional>
#include <limits>
#include <new>
#include <optional>
#include <sstream>
#include <system_error>
#include <thread>
#include <unordered_map>
#include <vector>

#include "common/checked_math.h"
#include "common/thread_annotations.h"
#include "common/thread_priority.h"
#include "core/mapping/internal/octree_batch_update.h"

namespace semmap {
namespace {

// OctoMap's fixed tree depth (16 levels, leaves at depth 16).
constexpr int kTreeDepth = 16;
// Log-odds beyond this are not from any sane clamping policy (p = 1 - 4e-18): damage.
constexpr float kMaxAbsLogOdds = 40.0F;

// Serialised node records (OcTreeBaseImpl::writeNodesRecurs): the node's writeData(), then
// one child-bit byte. OcTreeNode writes its float log-odds; ColorOcTreeNode adds r, g, b.
constexpr size_t kColourBytes = 3;
static_assert(sizeof(octomap::ColorOcTreeNode::Color) == kColourBytes);
constexpr size_t kOcTreeNodeBytes = sizeof(float) + 1;
constexpr size_t kColorNodeBytes = sizeof(float) + kColourBytes + 1;

bool Finite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

// The key of a world point; false outside the tree's +-2^15 voxels. OctoMap's own
// coordToKeyChecked converts the scaled coordinate to int first, which is undefined for a
// point beyond the int range (1e30 m), so such points are rejected here.
bool KeyOf(const octomap::ColorOcTree& tree, const Eigen::Vector3d& p, octomap::OcTreeKey& key) {
  const double half_extent = tree.getResolution() * 32768.0;
  if (!p.allFinite() || p.cwiseAbs().maxCoeff() >= half_extent) return false;
  return tree.coordToKeyChecked(p.x(), p.y(), p.z(), key);
}

// OctoMap prints the header's "res" with the stream's precision (6 digits by default), so a
// 0.0333333333 m map would read back with another resolution: the fewest digits (at least 6,
// OctoMap's own "0.05") that read back as the same double.
int RoundTripPrecision(double v) {
  for (int digits = 6; digits < std::numeric_limits<double>::max_digits10; ++digits) {
    char text[40];
    std::snprintf(text, sizeof(text), "%.*g", digits, v);
    if (std::strtod(text, nullptr) == v) return digits;
  }
  return std::numeric_limits<double>::max_digits10;
}

// Walks an .ot node stream exactly as OcTreeBaseImpl::readNodesRecurs would read it, with
// bounds: every read inside the data, no children below the leaf depth, finite values.
class NodeStreamChecker {
 public:
  NodeStreamChecker(std::string_view data, size_t node_bytes)
      : data_(data), node_bytes_(node_bytes) {}

  Status Check(size_t expected_nodes) {
    if (expected_nodes == 0) {
      if (!data_.empty()) return DataLossError("octree stream: data after an empty tree");
      return OkStatus();
    }
    // Checked: a header size of 2^61 nodes times 8 bytes wraps to 0.
    const std::optional<uint64_t> data_bytes = CheckedMul(expected_nodes, node_bytes_);
    if (!data_bytes || *data_bytes != data_.size()) {
      return DataLossError("octree stream: " + std::to_string(data_.size()) + " data bytes for " +
                           std::to_string(expected_nodes) + " nodes");
    }
    SEMMAP_RETURN_IF_ERROR(Node(0));
    if (pos_ != data_.size() || nodes_ != expected_nodes) {
      return DataLossError("octree stream: node structure does not match the node count");
    }
    return OkStatus();
  }

 private:
  Status Node(int depth) {
    if (data_.size() - pos_ < node_bytes_) return DataLossError("octree stream: truncated");
    float value = 0;
    std::memcpy(&value, data_.data() + pos_, sizeof(value));
    const auto children = static_cast<unsigned char>(data_[pos_ + node_bytes_ - 1]);
    pos_ += node_bytes_;
    ++nodes_;
    if (!std::isfinite(value) || std::fabs(value) > kMaxAbsLogOdds) {
      return DataLossError("octree stream: implausible log-odds value");
    }
    if (children != 0 && depth >= kTreeDepth) {
      return DataLossError("octree stream: children below the leaf depth");
    }
    for (int i = 0; i < 8; ++i) {
      if ((children >> i) & 1U) SEMMAP_RETURN_IF_ERROR(Node(depth + 1));
    }
    return OkStatus();
  }

  std::string_view data_;
  size_t node_bytes_;
  size_t pos_ = 0;
  size_t nodes_ = 0;
};

// Records are fixed-size and in the same (depth-first) order in both layouts, so converting
// between OcTree and ColorOcTree streams is a record-by-record copy.
std::string OcTreeToColorStream(std::string_view data) {
  std::string out;
  out.reserve(data.size() / kOcTreeNodeBytes * kColorNodeBytes);
  for (size_t pos = 0; pos + kOcTreeNodeBytes <= data.size(); pos += kOcTreeNodeBytes) {
    out.append(data.substr(pos, sizeof(float)));
    out.append(kColourBytes, '\xff');  // ColorOcTreeNode's "no colour" (white)
    out.push_back(data[pos + sizeof(float)]);
  }
  return out;
}

std::string ColorToOcTreeStream(std::string_view data) {
  std::string out;
  out.reserve(data.size() / kColorNodeBytes * kOcTreeNodeBytes);
  for (size_t pos = 0; pos + kColorNodeBytes <= data.size(); pos += kColorNodeBytes) {
    out.append(data.substr(pos, sizeof(float)));
    out.push_back(data[pos + kColorNodeBytes - 1]);
  }
  return out;
}

enum class OtType { kOcTree, kColorOcTree };

struct OtHeader {
  OtType type = OtType::kColorOcTree;
  size_t size = 0;
  double resolution = 0;
  size_t data_offset = 0;
};

// The text header AbstractOcTree::write() produces: the file-header line, comment lines,
// "id", "size", "res", then a "data" line followed by the node stream.
StatusOr<OtHeader> ParseOtHeader(std::string_view ot) {
  // AbstractOcTree::fileHeader (protected in OctoMap).
  constexpr std::string_view kMagic = "# Octomap OcTree file";
  if (ot.substr(0, kMagic.size()) != kMagic) {
    return InvalidArgumentError("not an OctoMap .ot file (bad file header)");
  }
  constexpr size_t kMaxHeaderBytes = 4096;
  OtHeader header;
  std::string id;
  bool have_id = false, have_size = false, have_res = false;
  size_t pos = 0;
  for (;;) {
    const size_t eol = ot.find('\n', pos);
    if (eol == std::string_view::npos || eol > kMaxHeaderBytes) {
      return DataLossError(".ot header: no 'data' line");
    }
    std::string line(ot.substr(pos, eol - pos));
    pos = eol + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (line == "data") break;
    std::istringstream fields(line);
    std::string key;
    fields >> key;
    if (key == "id") {
      have_id = static_cast<bool>(fields >> id);
    } else if (key == "size") {
      long long n = -1;
      have_size = static_cast<bool>(fields >> n) && n >= 0;
      header.size = have_size ? static_cast<size_t>(n) : 0;
    } else if (key == "res") {
      have_res = static_cast<bool>(fields >> header.resolution);
    } else {
      return DataLossError(".ot header: unexpected line '" + line.substr(0, 40) + "'");
    }
    std::string rest;
    if (fields >> rest) return DataLossError(".ot header: trailing text in '" + key + "' line");
  }
  if (!have_id || !have_size || !have_res) {
    return DataLossError(".ot header: missing or malformed id, size or res");
  }
  if (id == "ColorOcTree") {
    header.type = OtType::kColorOcTree;
  } else if (id == "OcTree") {
    header.type = OtType::kOcTree;
  } else {
    return InvalidArgumentError(".ot tree type '" + id +
                                "' is not supported (ColorOcTree, OcTree)");
  }
  header.data_offset = pos;
  return header;
}

// A keyframe point's end voxel and colour. Sorted by code, a voxel's points are adjacent and
// the voxels come in the order UpdateInnerColours() needs (one sort, no per-voxel allocation).
struct EndPoint {
  uint64_t code;  // internal::Morton(key)
  octomap::OcTreeKey key;
  std::array<uint8_t, 3> rgb;
};

// Gives the inner nodes above the recoloured voxels (`nodes`: their codes and keys, sorted)
// their children's mean colour, bottom-up. ColorOcTree::updateInnerOccupancy() does this (and
// inner occupancy, which non-lazy insertion already keeps current) for the whole tree: a quarter
// of the insertion time at 30 keyframes, and growing with the map. Only these paths got new
// colours. (Pruning free space can also drop a coloured child's colour from a parent's mean,
// ColorOcTree::pruneNode keeping child 0's "no colour"; such parents keep their earlier mean.
// Inner colours are for viewers: this class reads leaves.)
void UpdateInnerColours(octomap::ColorOcTree& tree,
                        std::vector<std::pair<uint64_t, octomap::OcTreeKey>> nodes) {
  for (int depth = kTreeDepth - 1; depth >= 1; --depth) {
    size_t parents = 0;  // one entry per parent at `depth` (any child's key addresses it)
    for (size_t i = 0; i < nodes.size(); ++i) {
      const uint64_t code = nodes[i].first >> 3;
      if (parents > 0 && nodes[parents - 1].first == code) continue;
      nodes[parents++] = {code, nodes[i].second};
    }
    nodes.resize(parents);
    for (const auto& [code, key] : nodes) {
      // search() ends early at a pruned leaf, which has no children to average.
      octomap::ColorOcTreeNode* node = tree.search(key, static_cast<unsigned>(depth));
      if (node != nullptr && tree.nodeHasChildren(node)) node->updateColorChildren();
    }
  }
  // search(key, 0) means full depth, not the root.
  octomap::ColorOcTreeNode* root = tree.getRoot();
  if (root != nullptr && tree.nodeHasChildren(root)) root->updateColorChildren();
}

// One keyframe's insertion worked out without touching the tree's nodes: the voxels its rays
// pass through (free) and end in (occupied), as OccupancyOcTreeBase::insertPointCloud computes
// them, and its end voxels' colours. Only the tree's resolution is read, so a rebuild prepares
// the next keyframes on another thread, with a tree of its own, while this one is applied.
struct PreparedScan {
  std::vector<internal::CellUpdate> updates;   // sorted by code
  std::vector<EndPoint> ends;                  // sorted by code: a voxel's points adjacent
  std::shared_ptr<const KeyframeCloud> cloud;  // what a build prepared it from
};

Status PrepareScan(const octomap::ColorOcTree& key_tree, const OccupancyMapOptions& options,
                   const KeyframeCloud& cloud, const Eigen::Isometry3d& T_world_keyframe,
                   PreparedScan* out) {
  if (!Finite(T_world_keyframe)) return InvalidArgumentError("keyframe pose is not finite");
  if (cloud.colours.size() != cloud.points.size()) {
    return InvalidArgumentError("keyframe cloud has " + std::to_string(cloud.points.size()) +
                                " points but " + std::to_string(cloud.colours.size()) + " colours");
  }
  // OctoMap keys cover +-2^15 voxels around the origin; keep every ray inside.
  const double half_extent = options.resolution_m * 32768.0 * 0.99 - options.max_range_m;
  if (T_world_keyframe.translation().cwiseAbs().maxCoeff() > half_extent) {
    return OutOfRangeError("keyframe pose is outside the occupancy map's extent");
  }
  try {
    octomap::Pointcloud scan;  // every point: rays to them when not discretized
    // Each end voxel gets the mean colour of the keyframe's points in it, once: one tree
    // search per voxel rather than per point, and not an order-dependent running average.
    out->ends.reserve(cloud.points.size());
    const Eigen::Matrix3f R = T_world_keyframe.linear().cast<float>();
    const Eigen::Vector3f t = T_world_keyframe.translation().cast<float>();
    for (size_t i = 0; i < cloud.points.size(); ++i) {
      const Eigen::Vector3f& p = cloud.points[i];
      if (!p.allFinite() || p.squaredNorm() > options.max_range_m * options.max_range_m) {
        continue;
      }
      const Eigen::Vector3f w = R * p + t;
      const octomap::point3d q(w.x(), w.y(), w.z());
      if (!options.discretize) scan.push_back(q);
      // The same float point OctoMap keys (computeDiscreteUpdate), so the same end voxel.
      octomap::OcTreeKey key;
      if (!key_tree.coordToKeyChecked(q, key)) continue;
      const std::array<uint8_t, 3>& bgr = cloud.colours[i];
      out->ends.push_back({internal::Morton(key), key, {bgr[2], bgr[1], bgr[0]}});
    }
    std::sort(out->ends.begin(), out->ends.end(),
              [](const EndPoint& a, const EndPoint& b) { return a.code < b.code; });
    const octomap::point3d origin(t.x(), t.y(), t.z());
    if (options.discretize) {
      // computeDiscreteUpdate: one ray per distinct end voxel, to its centre.
      octomap::Pointcloud centres;
      for (size_t i = 0; i < out->ends.size(); ++i) {
        if (i > 0 && out->ends[i].code == out->ends[i - 1].code) continue;
        centres.push_back(key_tree.keyToCoord(out->ends[i].key));
      }
      out->updates = internal::ComputeScanUpdates(key_tree, centres, origin, options.max_range_m);
    } else {
      out->updates = internal::ComputeScanUpdates(key_tree, scan, origin, options.max_range_m);
    }
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("occupancy map insertion: out of memory");
  } catch (const std::exception& e) {
    return InternalError(std::string("occupancy map insertion: ") + e.what());
  }
  return OkStatus();
}

// Applies a prepared keyframe: its free and occupied updates (the tree insertPointCloud leaves,
// inner nodes kept current), then the end voxels' colours and their ancestors'.
Status ApplyScan(octomap::ColorOcTree& tree, const PreparedScan& scan) {
  try {
    internal::ApplyCellUpdates(tree, scan.updates);
    const std::vector<EndPoint>& ends = scan.ends;
    std::vector<std::pair<uint64_t, octomap::OcTreeKey>> voxels;
    voxels.reserve(ends.size());
    for (size_t begin = 0, end = 0; begin < ends.size(); begin = end) {
      std::array<uint32_t, 3> sum{};
      for (end = begin; end < ends.size() && ends[end].code == ends[begin].code; ++end) {
        for (size_t c = 0; c < 3; ++c) sum[c] += ends[end].rgb[c];
      }
      const auto n = static_cast<uint32_t>(end - begin);
      auto mean = [&](size_t c) { return static_cast<uint8_t>((sum[c] + n / 2) / n); };
      tree.averageNodeColor(ends[begin].key, mean(0), mean(1), mean(2));
      voxels.emplace_back(ends[begin].code, ends[begin].key);
    }
    UpdateInnerColours(tree, std::move(voxels));
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("occupancy map insertion: out of memory");
  } catch (const std::exception& e) {
    return InternalError(std::string("occupancy map insertion: ") + e.what());
  }
  return OkStatus();
}

// Prepares keyframes [0, n) in order on a thread of its own, at most kAhead ahead of the
// consumer (each prepared scan holds a few MB of keys). Stopped and joined on destruction.
class ScanPrefetcher {
 public:
  using Prepare = std::function<Status(const octomap::ColorOcTree&, size_t, PreparedScan*)>;

  ScanPrefetcher(size_t n, double resolution_m, Prepare prepare)
      : n_(n), resolution_m_(resolution_m), prepare_(std::move(prepare)) {
    thread_ = std::thread([this] { Run(); });
  }
  ScanPrefetcher(const ScanPrefetcher&) = delete;
  ScanPrefetcher& operator=(const ScanPrefetcher&) = delete;
  ~ScanPrefetcher() {
    {
      MutexLock lock(mutex_);
      stop_ = true;
      changed_.notify_all();
    }
    thread_.join();
  }

  // The next keyframe's scan, in order; its preparation's error when it failed.
  Status Next(PreparedScan* scan) {
    MutexLock lock(mutex_);
    while (ready_.empty()) changed_.wait(lock);
    Slot slot = std::move(ready_.front());
    ready_.pop_front();
    changed_.notify_all();
    *scan = std::move(slot.scan);
    return slot.status;
  }

 private:
  static constexpr size_t kAhead = 2;
  struct Slot {
    Status status;
    PreparedScan scan;
  };

  void Run() {
    NameCurrentThread("layer-rays");
    std::optional<octomap::ColorOcTree> key_tree;
    for (size_t i = 0; i < n_; ++i) {
      Slot slot;
      try {
        if (!key_tree) key_tree.emplace(resolution_m_);
        slot.status = prepare_(*key_tree, i, &slot.scan);
      } catch (const std::bad_alloc&) {
        slot.status = ResourceExhaustedError("occupancy map build: out of memory");
      }
      const bool failed = !slot.status.ok();
      MutexLock lock(mutex_);
      while (!stop_ && ready_.size() >= kAhead) changed_.wait(lock);
      if (stop_) return;
      ready_.push_back(std::move(slot));
      changed_.notify_all();
      if (failed) return;  // the consumer stops at this one
    }
  }

  const size_t n_;
  const double resolution_m_;
  const Prepare prepare_;
  Mutex mutex_;
  std::condition_variable_any changed_;  // waits on a MutexLock
  std::deque<Slot> ready_ SEMMAP_GUARDED_BY(mutex_);
  bool stop_ SEMMAP_GUARDED_BY(mutex_) = false;
  std::thread thread_;  // last: started once the members above exist
};

std::array<uint8_t, 3> Rgb(const octomap::ColorOcTreeNode& node) {
  const octomap::ColorOcTreeNode::Color c = node.getColor();
  return {c.r, c.g, c.b};
}

}  // namespace

Status OccupancyMapOptions::Validate() const {
  if (!std::isfinite(resolution_m) || resolution_m < 0.001 || resolution_m > 1.0) {
    return InvalidArgumentError("occupancy map resolution must be in [0.001, 1] m");
  }
  if (!std::isfinite(max_range_m) || max_range_m <= 0 || max_range_m > 50.0) {
    return InvalidArgumentError("occupancy map max range must be in (0, 50] m");
  }
  if (pixel_step < 1 || pixel_step > 64) {
    return InvalidArgumentError("occupancy map pixel step must be in [1, 64]");
  }
  if (!std::isfinite(keyframe_voxel_m) ||
      (keyframe_voxel_m != 0 && (keyframe_voxel_m < 0.001 || keyframe_voxel_m > resolution_m))) {
    return InvalidArgumentError(
        "keyframe voxel must be 0 (off) or in [0.001 m, the occupancy resolution]");
  }
  return OkStatus();
}

namespace {

// One mean point and colour per voxel-edge cube, in the order the cubes were first hit. The
// points come from one depth image within max range, so cube indices fit in 21 bits each.
KeyframeCloud VoxelMeans(const KeyframeCloud& cloud, double voxel) {
  struct Sum {
    Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
    std::array<uint32_t, 3> bgr{};
    uint32_t count = 0;
  };
  std::unordered_map<uint64_t, uint32_t> slot;
  slot.reserve(cloud.size());
  std::vector<Sum> sums;
  const double inverse = 1.0 / voxel;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    uint64_t key = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const auto index = static_cast<int64_t>(std::floor(p[axis] * inverse)) + (int64_t{1} << 20);
      key = (key << 21) | (static_cast<uint64_t>(index) & ((uint64_t{1} << 21) - 1));
    }
    const auto [it, added] = slot.try_emplace(key, static_cast<uint32_t>(sums.size()));
    if (added) sums.emplace_back();
    Sum& sum = sums[it->second];
    sum.xyz += p.cast<double>();
    for (int c = 0; c < 3; ++c) sum.bgr[c] += cloud.colours[i][c];
    ++sum.count;
  }
  KeyframeCloud out;
  out.points.reserve(sums.size());
  out.colours.reserve(sums.size());
  for (const Sum& sum : sums) {
    out.points.emplace_back((sum.xyz / sum.count).cast<float>());
    std::array<uint8_t, 3> bgr{};
    for (int c = 0; c < 3; ++c) {
      bgr[c] = static_cast<uint8_t>((sum.bgr[c] + sum.count / 2) / sum.count);
    }
    out.colours.push_back(bgr);
  }
  return out;
}

}  // namespace

StatusOr<KeyframeCloud> MakeKeyframeCloud(const DecodedDepth& depth, const cv::Mat& bgr,
                                          const CameraCalibration& camera,
                                          const OccupancyMapOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera));
  if (depth.raw.empty() || depth.raw.type() != CV_16UC1) {
    return InvalidArgumentError("keyframe depth must be a non-empty CV_16UC1 image");
  }
  if (!std::isfinite(depth.depth_scale) || depth.depth_scale <= 0) {
    return InvalidArgumentError("keyframe depth scale must be positive");
  }
  if (depth.raw.cols != camera.width || depth.raw.rows != camera.height) {
    return InvalidArgumentError("keyframe depth size does not match the calibration");
  }
  if (bgr.size() != depth.raw.size() || (bgr.type() != CV_8UC3 && bgr.type() != CV_8UC1)) {
    return InvalidArgumentError("keyframe colour must be CV_8UC3 or CV_8UC1 of the depth's size");
  }
  const bool distorted = camera.HasDistortion();
  const double k1 = camera.distortion[0], k2 = camera.distortion[1], p1 = camera.distortion[2],
               p2 = camera.distortion[3], k3 = camera.distortion[4];
  const int step = options.pixel_step;
  const double max_range2 = options.max_range_m * options.max_range_m;
  KeyframeCloud cloud;
  const size_t capacity = static_cast<size_t>((camera.width + step - 1) / step) *
                          static_cast<size_t>((camera.height + step - 1) / step);
  cloud.points.reserve(capacity);
  cloud.colours.reserve(capacity);
  for (int v = step / 2; v < depth.raw.rows; v += step) {
    const auto* depth_row = depth.raw.ptr<uint16_t>(v);
    const uint8_t* colour_row = bgr.ptr<uint8_t>(v);
    for (int u = step / 2; u < depth.raw.cols; u += step) {
      const uint16_t raw = depth_row[u];
      if (raw == 0) continue;
      double x = (u - camera.cx) / camera.fx;
      double y = (v - camera.cy) / camera.fy;
      if (distorted) {  // invert the OpenCV model by fixed-point iteration, as cv::undistort
        const double xd = x, yd = y;
        for (int i = 0; i < 10; ++i) {
          const double r2 = x * x + y * y;
          const double radial = 1 + ((k3 * r2 + k2) * r2 + k1) * r2;
          if (!(radial > 0)) break;
          const double dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
          const double dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
          x = (xd - dx) / radial;
          y = (yd - dy) / radial;
        }
      }
      const double z = raw / depth.depth_scale;
      if (z * z * (x * x + y * y + 1) > max_range2) continue;
      cloud.points.emplace_back(static_cast<float>(x * z), static_cast<float>(y * z),
                                static_cast<float>(z));
      if (bgr.type() == CV_8UC3) {
        const uint8_t* c = colour_row + 3 * u;
        cloud.colours.push_back({c[0], c[1], c[2]});
      } else {
        cloud.colours.push_back({colour_row[u], colour_row[u], colour_row[u]});
      }
    }
  }
  if (options.keyframe_voxel_m > 0) return VoxelMeans(cloud, options.keyframe_voxel_m);
  return cloud;
}

OccupancyMap::OccupancyMap(std::unique_ptr<octomap::ColorOcTree> tree,
                           const OccupancyMapOptions& options)
    : tree_(std::move(tree)), options_(options) {}
OccupancyMap::OccupancyMap(OccupancyMap&&) noexcept = default;
OccupancyMap& OccupancyMap::operator=(OccupancyMap&&) noexcept = default;
OccupancyMap::~OccupancyMap() = default;

StatusOr<OccupancyMap> OccupancyMap::Create(const OccupancyMapOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  try {
    return OccupancyMap(std::make_unique<octomap::ColorOcTree>(options.resolution_m), options);
  } catch (const std::exception& e) {
    return ResourceExhaustedError(std::string("occupancy map: ") + e.what());
  }
}

StatusOr<OccupancyMap> OccupancyMap::Build(
    const std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>>& keyframes,
    const OccupancyMapOptions& options, const CancelCheck& cancel) {
  for (size_t i = 0; i < keyframes.size(); ++i) {
    if (keyframes[i].first == nullptr) {
      return InvalidArgumentError("occupancy map build: keyframe " + std::to_string(i) +
                                  " has no cloud");
    }
  }
  return Build(
      keyframes.size(),
      [&](size_t i)
          -> StatusOr<std::pair<std::shared_ptr<const KeyframeCloud>, Eigen::Isometry3d>> {
        // Borrowed, not owned: the caller's clouds outlive the build.
        return std::make_pair(
            std::shared_ptr<const KeyframeCloud>(std::shared_ptr<void>(), keyframes[i].first),
            keyframes[i].second);
      },
      options, cancel);
}

StatusOr<OccupancyMap> OccupancyMap::Build(size_t count, const KeyframeSource& keyframe,
                                           const OccupancyMapOptions& options,
                                           const CancelCheck& cancel,
                                           const KeyframeInserted& inserted) {
  SEMMAP_ASSIGN_OR_RETURN(OccupancyMap map, Create(options));
  // The rays of the next keyframes are cast on a second thread while this one's updates go
  // into the tree (with the batched update, ray casting is most of an insertion): the same
  // updates in the same order as inserting one after another, so the same tree.
  std::optional<ScanPrefetcher> prefetcher;
  try {
    prefetcher.emplace(count, options.resolution_m,
                       [&](const octomap::ColorOcTree& key_tree, size_t i, PreparedScan* scan) {
                         SEMMAP_ASSIGN_OR_RETURN(auto source, keyframe(i));
                         if (source.first == nullptr) {
                           return InvalidArgumentError("occupancy map build: no cloud");
                         }
                         scan->cloud = std::move(source.first);
                         return PrepareScan(key_tree, options, *scan->cloud, source.second, scan);
                       });
  } catch (const std::system_error& e) {
    return ResourceExhaustedError(std::string("occupancy map build: no thread: ") + e.what());
  }
  for (size_t i = 0; i < count; ++i) {
    SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancel));
    PreparedScan scan;
    SEMMAP_RETURN_IF_ERROR(prefetcher->Next(&scan).WithContext("keyframe " + std::to_string(i)));
    SEMMAP_RETURN_IF_ERROR(
        ApplyScan(*map.tree_, scan).WithContext("keyframe " + std::to_string(i)));
    if (inserted) inserted(i, scan.cloud);
  }
  return map;
}

Status OccupancyMap::Insert(const KeyframeCloud& cloud, const Eigen::Isometry3d& T_world_keyframe) {
  PreparedScan scan;
  SEMMAP_RETURN_IF_ERROR(PrepareScan(*tree_, options_, cloud, T_world_keyframe, &scan));
  return ApplyScan(*tree_, scan);
}

VoxelState OccupancyMap::Occupancy(const Eigen::Vector3d& p_world) const {
  octomap::OcTreeKey key;
  if (!KeyOf(*tree_, p_world, key)) return VoxelState::kUnknown;
  const octomap::ColorOcTreeNode* node = tree_->search(key);
  if (node == nullptr) return VoxelState::kUnknown;
  return tree_->isNodeOccupied(node) ? VoxelState::kOccupied : VoxelState::kFree;
}

std::optional<std::array<uint8_t, 3>> OccupancyMap::ColourAt(const Eigen::Vector3d& p_world) const {
  octomap::OcTreeKey key;
  if (!KeyOf(*tree_, p_world, key)) return std::nullopt;
  // search() ends at a leaf (possibly a pruned, larger one) or finds nothing.
  const octomap::ColorOcTreeNode* node = tree_->search(key);
  if (node == nullptr || !tree_->isNodeOccupied(node)) return std::nullopt;
  return Rgb(*node);
}

size_t OccupancyMap::size() const { return tree_->size(); }

size_t OccupancyMap::MemoryBytes() const { return tree_->memoryUsage(); }

double OccupancyMap::KnownVolume() const {
  double volume = 0;
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    const double size = it.getSize();
    volume += size * size * size;
  }
  return volume;
}

Eigen::AlignedBox3d OccupancyMap::Bounds() const {
  Eigen::AlignedBox3d box;  // empty
  if (tree_->size() == 0) return box;
  const octomap::ColorOcTree& tree = *tree_;
  double x0 = 0, y0 = 0, z0 = 0, x1 = 0, y1 = 0, z1 = 0;
  tree.getMetricMin(x0, y0, z0);
  tree.getMetricMax(x1, y1, z1);
  box.extend(Eigen::Vector3d(x0, y0, z0));
  box.extend(Eigen::Vector3d(x1, y1, z1));
  return box;
}

std::vector<OccupancyMap::Voxel> OccupancyMap::OccupiedVoxels() const {
  std::vector<Voxel> voxels;
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    if (!tree_->isNodeOccupied(*it)) continue;
    const octomap::point3d c = it.getCoordinate();
    voxels.push_back(
        {Eigen::Vector3d(c.x(), c.y(), c.z()), it.getSize(), it->getLogOdds(), Rgb(*it)});
  }
  return voxels;
}

StatusOr<std::string> OccupancyMap::SerializeOt() const {
  try {
    std::ostringstream out;
    out.precision(RoundTripPrecision(tree_->getResolution()));
    if (!tree_->write(out) || !out) return InternalError("occupancy map: .ot write failed");
    return std::move(out).str();
  } catch (const std::exception& e) {
    return InternalError(std::string("occupancy map .ot write: ") + e.what());
  }
}

StatusOr<std::string> OccupancyMap::SerializeBt() const {
  try {
    // .bt has no colour: export an OcTree (id "OcTree", what .bt readers expect) with the
    // same nodes, built from the colour-stripped node stream. writeBinary() makes the copy
    // max-likelihood and prunes it.
    octomap::OcTree copy(tree_->getResolution());
    if (tree_->getRoot() != nullptr) {
      std::ostringstream colour_data;
      tree_->writeData(colour_data);
      std::istringstream in(ColorToOcTreeStream(colour_data.str()));
      copy.readData(in);
      if (copy.size() != tree_->size()) return InternalError("occupancy map: .bt copy failed");
    }
    std::ostringstream out;
    out.precision(RoundTripPrecision(copy.getResolution()));
    if (!copy.writeBinary(out) || !out) return InternalError("occupancy map: .bt write failed");
    return std::move(out).str();
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("occupancy map .bt write: out of memory");
  } catch (const std::exception& e) {
    return InternalError(std::string("occupancy map .bt write: ") + e.what());
  }
}

StatusOr<OccupancyMap> OccupancyMap::DeserializeOt(std::string_view ot,
                                                   OccupancyMapOptions options) {
  SEMMAP_ASSIGN_OR_RETURN(const OtHeader header, ParseOtHeader(ot));
  options.resolution_m = header.resolution;
  if (!std::isfinite(header.resolution) || header.resolution <= 0) {
    return DataLossError(".ot header: bad resolution");
  }
  SEMMAP_RETURN_IF_ERROR(options.Validate().WithContext(".ot"));
  const std::string_view data = ot.substr(header.data_offset);
  const bool colour = header.type == OtType::kColorOcTree;
  SEMMAP_RETURN_IF_ERROR(
      NodeStreamChecker(data, colour ? kColorNodeBytes : kOcTreeNodeBytes).Check(header.size));
  try {
    auto tree = std::make_unique<octomap::ColorOcTree>(header.resolution);
    if (header.size > 0) {
      std::istringstream in{colour ? std::string(data) : OcTreeToColorStream(data)};
      tree->readData(in);
      if (in.bad()) return DataLossError(".ot data: read failed");
    }
    if (tree->size() != header.size) {
      return DataLossError(".ot data: " + std::to_string(tree->size()) +
                           " nodes read, header says " + std::to_string(header.size));
    }
    return OccupancyMap(std::move(tree), options);
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError(".ot read: out of memory");
  } catch (const std::exception& e) {
    return DataLossError(std::string(".ot read: ") + e.what());
  }
}

}  // namespace semmap
