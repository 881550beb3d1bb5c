// Compares two coloured clouds made on one leaf grid (PointCloudMap, IncrementalCloud) leaf by
// leaf: the cloud layer is built incrementally in double, PCL's voxel grid sums in float, so the
// same keyframes give the same leaves with means a few float steps apart. Header-only (gtest).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <tuple>
#include <vector>

#include "core/mapping/cloud_point.h"
#include "core/mapping/point_cloud_map.h"

namespace semmap::testing {

// Points by the leaf they fall in (PCL's float index); two points in one leaf fail the test.
inline std::map<std::tuple<int64_t, int64_t, int64_t>, CloudPoint> PointsByLeaf(
    const std::vector<CloudPoint>& points, double leaf_m) {
  std::map<std::tuple<int64_t, int64_t, int64_t>, CloudPoint> out;
  const float inverse = 1.0f / static_cast<float>(leaf_m);
  for (const CloudPoint& p : points) {
    const std::tuple<int64_t, int64_t, int64_t> index{
        PclLeafIndex(p.x, inverse), PclLeafIndex(p.y, inverse), PclLeafIndex(p.z, inverse)};
    EXPECT_TRUE(out.emplace(index, p).second) << "two points in one leaf";
  }
  return out;
}

// The same leaves; positions within `tolerance_m`, colours within `colour_tolerance` per channel.
inline void ExpectSameCloud(const std::vector<CloudPoint>& a, const std::vector<CloudPoint>& b,
                            double leaf_m, double tolerance_m, int colour_tolerance) {
  ASSERT_EQ(a.size(), b.size());
  const auto by_leaf_a = PointsByLeaf(a, leaf_m), by_leaf_b = PointsByLeaf(b, leaf_m);
  double worst = 0;
  int worst_colour = 0;
  for (const auto& [index, p] : by_leaf_a) {
    const auto q = by_leaf_b.find(index);
    ASSERT_NE(q, by_leaf_b.end()) << "a leaf only the first cloud has";
    worst = std::max({worst, std::abs(static_cast<double>(p.x - q->second.x)),
                      std::abs(static_cast<double>(p.y - q->second.y)),
                      std::abs(static_cast<double>(p.z - q->second.z))});
    worst_colour = std::max({worst_colour, std::abs(p.r - q->second.r), std::abs(p.g - q->second.g),
                             std::abs(p.b - q->second.b)});
  }
  EXPECT_LE(worst, tolerance_m);
  EXPECT_LE(worst_colour, colour_tolerance);
}

}  // namespace semmap::testing
