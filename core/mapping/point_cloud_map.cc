#include "core/mapping/point_cloud_map.h"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <string_view>

namespace semmap {
namespace {

static_assert(std::endian::native == std::endian::little,
              "binary PLY/PCD exports assume a little-endian host");

using PclCloud = pcl::PointCloud<pcl::PointXYZRGB>;

// PCL's VoxelGrid refuses (and passes the input through unfiltered) when the grid's leaf
// count exceeds INT32_MAX; stay well below that per filtered piece.
constexpr int64_t kMaxLeavesPerPiece = std::numeric_limits<int32_t>::max() / 2;

bool IsFinite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

// Filters one piece with PCL and appends the leaf centroids to `out`.
void FilterPiece(const PclCloud::Ptr& piece, float leaf, std::vector<CloudPoint>& out) {
  pcl::VoxelGrid<pcl::PointXYZRGB> grid;
  grid.setInputCloud(piece);
  grid.setLeafSize(leaf, leaf, leaf);
  grid.setDownsampleAllData(true);  // average colours too
  PclCloud filtered;
  grid.filter(filtered);
  out.reserve(out.size() + filtered.size());
  for (const pcl::PointXYZRGB& p : filtered) {
    out.push_back(CloudPoint{p.x, p.y, p.z, p.r, p.g, p.b});
  }
}

void AppendFloat(std::string& out, float v) {
  char buffer[32];
  const std::to_chars_result r = std::to_chars(buffer, buffer + sizeof(buffer), v);
  out.append(buffer, r.ptr);
}

template <typename T>
void AppendInteger(std::string& out, T v) {
  char buffer[24];
  const std::to_chars_result r = std::to_chars(buffer, buffer + sizeof(buffer), v);
  out.append(buffer, r.ptr);
}

template <typename T>
void AppendRaw(std::string& out, T v) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  out.append(bytes, sizeof(T));
}

// The point's position for both formats: binary floats, or ASCII "x y z" with a trailing space.
void AppendPosition(std::string& out, const CloudPoint& p, bool binary) {
  if (binary) {
    AppendRaw(out, p.x);
    AppendRaw(out, p.y);
    AppendRaw(out, p.z);
    return;
  }
  for (float v : {p.x, p.y, p.z}) {
    AppendFloat(out, v);
    out += ' ';
  }
}

uint32_t PackRgb(const CloudPoint& p) {
  return uint32_t{255} << 24 | uint32_t{p.r} << 16 | uint32_t{p.g} << 8 | uint32_t{p.b};
}

}  // namespace

Status PointCloudMapOptions::Validate() const {
  if (!std::isfinite(leaf_size_m) || leaf_size_m < 0.001 || leaf_size_m > 1.0) {
    return InvalidArgumentError("point cloud leaf size must be in [0.001, 1] m, got " +
                                std::to_string(leaf_size_m));
  }
  if (max_points_per_piece < 1000) {
    return InvalidArgumentError("point cloud pieces must hold at least 1000 points");
  }
  return OkStatus();
}

StatusOr<PointCloudMap> PointCloudMap::Build(
    const std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>>& keyframes,
    const PointCloudMapOptions& options, const CancelCheck& cancel) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancel));
  for (size_t i = 0; i < keyframes.size(); ++i) {
    const auto& [cloud, T_world_keyframe] = keyframes[i];
    if (cloud == nullptr)
      return InvalidArgumentError("keyframe " + std::to_string(i) + ": null cloud");
    if (cloud->colours.size() != cloud->points.size()) {
      return InvalidArgumentError("keyframe " + std::to_string(i) + ": " +
                                  std::to_string(cloud->points.size()) + " points but " +
                                  std::to_string(cloud->colours.size()) + " colours");
    }
    if (!IsFinite(T_world_keyframe)) {
      return InvalidArgumentError("keyframe " + std::to_string(i) + ": non-finite pose");
    }
  }

  try {
    // World points are made on the fly, twice or more: once for their bounds, then once per
    // slab (below); only one slab's points are held at a time, so a map of many keyframes does
    // not hold all of its points again as a PCL cloud (32 bytes each) while it is filtered.
    auto for_each_world_point = [&](const auto& visit) {
      for (const auto& [cloud, T_world_keyframe] : keyframes) {
        const Eigen::Isometry3f T = T_world_keyframe.template cast<float>();
        for (size_t j = 0; j < cloud->size(); ++j) {
          const Eigen::Vector3f p = T * cloud->points[j];
          if (p.allFinite()) visit(p, cloud->colours[j]);
        }
      }
    };
    auto to_pcl = [](const Eigen::Vector3f& p, const std::array<uint8_t, 3>& bgr) {
      pcl::PointXYZRGB q(bgr[2], bgr[1], bgr[0]);
      q.x = p.x();
      q.y = p.y();
      q.z = p.z();
      return q;
    };
    Eigen::AlignedBox3f box;
    size_t finite = 0;
    for_each_world_point([&](const Eigen::Vector3f& p, const std::array<uint8_t, 3>&) {
      box.extend(p);
      ++finite;
    });
    std::vector<CloudPoint> points;
    if (finite == 0) return PointCloudMap(std::move(points), options);

    const float leaf = static_cast<float>(options.leaf_size_m);
    const float inverse_leaf = 1.0f / leaf;
    // Leaf counts per axis, in double so absurd extents cannot overflow the arithmetic.
    const Eigen::Array3d extent =
        ((box.max() - box.min()).cast<double>().array() / options.leaf_size_m).floor() + 2.0;
    const double leaves = extent.prod();
    if (leaves <= static_cast<double>(kMaxLeavesPerPiece) &&
        finite <= options.max_points_per_piece) {
      auto world = std::make_shared<PclCloud>();
      world->reserve(finite);
      for_each_world_point([&](const Eigen::Vector3f& p, const std::array<uint8_t, 3>& bgr) {
        world->push_back(to_pcl(p, bgr));
      });
      world->is_dense = true;
      FilterPiece(world, leaf, points);
      return PointCloudMap(std::move(points), options);
    }
    // Slabs along x on leaf boundaries: every leaf falls wholly into one slab, so the result
    // equals one big filter's. Each slab stays below PCL's leaf limit; there are at least as
    // many as pieces of max_points_per_piece points, and each pass over the points collects a run
    // of slabs holding about that many (as evenly as the points are spread along x).
    const double yz = extent.y() * extent.z();
    if (yz * 2.0 > static_cast<double>(kMaxLeavesPerPiece) || extent.x() > 1e15) {
      return InvalidArgumentError("point cloud extent too large for a " +
                                  std::to_string(options.leaf_size_m) + " m leaf");
    }
    const auto pieces_by_points = static_cast<int64_t>((finite + options.max_points_per_piece - 1) /
                                                       options.max_points_per_piece);
    const int64_t by_leaves =
        std::max<int64_t>(1, static_cast<int64_t>(kMaxLeavesPerPiece / yz) - 2);
    const int64_t by_points =
        std::max<int64_t>(1, static_cast<int64_t>(extent.x()) / pieces_by_points);
    const int64_t slab_leaves = std::min(by_leaves, by_points);
    const int64_t first = PclLeafIndex(box.min().x(), inverse_leaf);
    const int64_t slabs = (PclLeafIndex(box.max().x(), inverse_leaf) - first) / slab_leaves + 1;
    const int64_t passes = std::clamp<int64_t>(pieces_by_points, 1, slabs);
    const int64_t per_pass = (slabs + passes - 1) / passes;
    for (int64_t begin = 0; begin < slabs; begin += per_pass) {
      SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancel));
      std::map<int64_t, PclCloud::Ptr> pieces;
      for_each_world_point([&](const Eigen::Vector3f& p, const std::array<uint8_t, 3>& bgr) {
        const int64_t slab = (PclLeafIndex(p.x(), inverse_leaf) - first) / slab_leaves;
        if (slab < begin || slab >= begin + per_pass) return;
        PclCloud::Ptr& piece = pieces[slab];
        if (!piece) {
          piece = std::make_shared<PclCloud>();
          piece->is_dense = true;
        }
        piece->push_back(to_pcl(p, bgr));
      });
      for (auto& [slab, piece] : pieces) {
        FilterPiece(piece, leaf, points);
        piece.reset();
      }
    }
    return PointCloudMap(std::move(points), options);
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory building the point cloud map");
  } catch (const std::exception& e) {
    return InternalError(std::string("PCL: ") + e.what());
  }
}

Eigen::AlignedBox3d PointCloudMap::Bounds() const {
  Eigen::AlignedBox3d box;
  for (const CloudPoint& p : points_) box.extend(Eigen::Vector3d(p.x, p.y, p.z));
  return box;
}

StatusOr<std::string> PointCloudMap::ToPly(bool binary) const {
  try {
    std::string out;
    out.reserve(256 + points_.size() * (binary ? 15 : 48));
    out += "ply\nformat ";
    out += binary ? "binary_little_endian" : "ascii";
    out += " 1.0\ncomment semmap point cloud map\nelement vertex ";
    AppendInteger(out, points_.size());
    out +=
        "\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
    for (const CloudPoint& p : points_) {
      AppendPosition(out, p, binary);
      if (binary) {
        AppendRaw(out, p.r);
        AppendRaw(out, p.g);
        AppendRaw(out, p.b);
      } else {
        AppendInteger(out, unsigned{p.r});
        out += ' ';
        AppendInteger(out, unsigned{p.g});
        out += ' ';
        AppendInteger(out, unsigned{p.b});
        out += '\n';
      }
    }
    return out;
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory writing PLY");
  }
}

StatusOr<std::string> PointCloudMap::ToPcd(bool binary) const {
  try {
    std::string out;
    out.reserve(256 + points_.size() * (binary ? 16 : 48));
    out +=
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\n"
        "SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH ";
    AppendInteger(out, points_.size());
    out += "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS ";
    AppendInteger(out, points_.size());
    out += binary ? "\nDATA binary\n" : "\nDATA ascii\n";
    for (const CloudPoint& p : points_) {
      AppendPosition(out, p, binary);
      if (binary) {
        AppendRaw(out, PackRgb(p));
      } else {
        AppendInteger(out, PackRgb(p));
        out += '\n';
      }
    }
    return out;
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory writing PCD");
  }
}

}  // namespace semmap
