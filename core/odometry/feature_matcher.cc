#include "core/odometry/feature_matcher.h"

#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/features2d.hpp>
#include <string>

#include "common/hamming.h"

namespace semmap {
namespace {

Status CheckDescriptors(const cv::Mat& query, const cv::Mat& train) {
  if (query.empty() || train.empty()) return OkStatus();
  if (query.type() != train.type() || query.cols != train.cols) {
    return InvalidArgumentError("descriptor types or widths differ");
  }
  if (query.type() != CV_8UC1 && query.type() != CV_32FC1) {
    return InvalidArgumentError("descriptors must be CV_8UC1 (binary) or CV_32FC1");
  }
  return OkStatus();
}

struct Best {
  int index = -1;
  float distance = std::numeric_limits<float>::max();
  float second = std::numeric_limits<float>::max();
  void Offer(int i, float d) {
    if (d < distance) {
      second = distance;
      distance = d;
      index = i;
    } else if (d < second) {
      second = d;
    }
  }
};

// Applies the ratio test, the absolute limit and (optionally) the cross check to per-query
// best candidates; `train_best[j]` is the query index closest to train j.
std::vector<cv::DMatch> Select(const std::vector<Best>& query_best,
                               const std::vector<int>& train_best, double max_distance,
                               const FeatureMatcherOptions& options) {
  std::vector<cv::DMatch> out;
  for (size_t i = 0; i < query_best.size(); ++i) {
    const Best& b = query_best[i];
    if (b.index < 0 || b.distance > max_distance) continue;
    if (options.ratio < 1.0 && b.second < std::numeric_limits<float>::max() &&
        !(b.distance < options.ratio * b.second)) {
      continue;
    }
    if (options.cross_check && train_best[static_cast<size_t>(b.index)] != static_cast<int>(i)) {
      continue;
    }
    out.emplace_back(static_cast<int>(i), b.index, b.distance);
  }
  return out;
}

// Binary descriptors: one pass over the query x train Hamming matrix, in a POPCNT clone
// (OpenCV's Hamming in Debian's build does not use POPCNT), computing each distance once where
// the former cv::BFMatcher passes (knnMatch k=2, then match train->query for the cross check)
// computed it twice; 5-6x less CPU. The results are the same: OpenCV's batchDistance scans
// candidates in index order and replaces only on a strictly smaller distance, so at equal
// distances the lowest index is the best and an equal later one becomes the second best.
struct HammingBest {
  int index = -1;
  int distance = INT_MAX;
  int second = INT_MAX;
};

// The nearest query of a train row.
struct TrainBest {
  int distance = INT_MAX;
  int index = -1;
};

// Best::Offer on ints. Branches rather than conditional moves: after the first rows an offer
// rarely changes anything (about ln(rows) times a row), so the branches predict well and the
// common case is one compare.
[[gnu::always_inline]] inline void Offer(int d, int j, HammingBest& b) {
  if (d < b.second) {
    if (d < b.distance) {
      b.second = b.distance;
      b.distance = d;
      b.index = j;
    } else {
      b.second = d;
    }
  }
}

// Distance of a query row held as kWords words to the train row at `t`.
template <int kWords>
[[gnu::always_inline]] inline int RowDistance(const uint64_t* qw, const uint8_t* t) {
  int d = 0;
  for (int k = 0; k < kWords; ++k) {
    uint64_t w;
    std::memcpy(&w, t + 8 * k, 8);  // rows need not be 8-byte aligned
    d += std::popcount(qw[k] ^ w);
  }
  return d;
}

// kWords > 0: rows of kWords * 8 bytes, the query row copied to locals (a uint8_t row could
// alias the stores to train_best, which would force reloads); kWords == 0: any width, through
// HammingDistance. Query rows ascend, so `<` keeps the lowest query at equal distances.
template <int kWords>
[[gnu::always_inline]] inline void ScanRows(const cv::Mat& query, const cv::Mat& train,
                                            HammingBest* query_best, TrainBest* train_best) {
  const int bytes = query.cols;
  const int train_rows = train.rows;  // locals: not reloaded after each store
  const size_t train_step = train.step;
  for (int i = 0; i < query.rows; ++i) {
    const uint8_t* const q = query.ptr<uint8_t>(i);
    uint64_t qw[kWords > 0 ? kWords : 1];
    if constexpr (kWords > 0) std::memcpy(qw, q, sizeof(qw));
    HammingBest b;
    const uint8_t* t = train.data;
    for (int j = 0; j < train_rows; ++j, t += train_step) {
      int d;
      if constexpr (kWords > 0) {
        d = RowDistance<kWords>(qw, t);
      } else {
        d = HammingDistance(q, t, bytes);
      }
      Offer(d, j, b);
      if (d < train_best[j].distance) train_best[j] = {d, i};
    }
    query_best[i] = b;
  }
}

// `train_best` holds TrainBest{} per train row on entry.
SEMMAP_POPCNT_CLONES void ScanHamming(const cv::Mat& query, const cv::Mat& train,
                                      HammingBest* query_best, TrainBest* train_best) {
  switch (query.cols) {
    case 32:  // ORB, BRIEF-32
      ScanRows<4>(query, train, query_best, train_best);
      break;
    case 64:  // BRISK, BRIEF-64
      ScanRows<8>(query, train, query_best, train_best);
      break;
    default:
      ScanRows<0>(query, train, query_best, train_best);
  }
}

// Distance of query row i to train row j for guided matching; inlined into GuidedScan's clones.
[[gnu::always_inline]] inline float GuidedDistance(const cv::Mat& query, int i,
                                                   const cv::Mat& train, int j) {
  if (query.depth() == CV_8U) {
    const uint8_t* a = query.ptr<uint8_t>(i);
    const uint8_t* b = train.ptr<uint8_t>(j);
    // A constant width unrolls the loop (ORB).
    return static_cast<float>(query.cols == 32 ? HammingDistance(a, b, 32)
                                               : HammingDistance(a, b, query.cols));
  }
  return std::sqrt(cv::hal::normL2Sqr_(query.ptr<float>(i), train.ptr<float>(j), query.cols));
}

// MatchGuided's candidate search: query i against the train keypoints of `grid` (cells of
// `cell` px, cols x rows) within `cell` px of predicted[i]. Candidates are offered in the same
// order as before the POPCNT clone, so ties resolve as they did.
SEMMAP_POPCNT_CLONES void GuidedScan(const cv::Mat& query,
                                     const std::vector<std::optional<cv::Point2f>>& predicted,
                                     const cv::Mat& train,
                                     const std::vector<cv::KeyPoint>& train_keypoints,
                                     const std::vector<std::vector<int>>& grid, int cols, int rows,
                                     float cell, std::vector<Best>& query_best,
                                     std::vector<Best>& train_best_dist) {
  const float r2 = cell * cell;
  for (int i = 0; i < query.rows; ++i) {
    const std::optional<cv::Point2f>& p = predicted[static_cast<size_t>(i)];
    if (!p || !std::isfinite(p->x) || !std::isfinite(p->y)) continue;
    const int gx = static_cast<int>(std::floor(p->x / cell));
    const int gy = static_cast<int>(std::floor(p->y / cell));
    for (int y = std::max(0, gy - 1); y <= std::min(rows - 1, gy + 1); ++y) {
      for (int x = std::max(0, gx - 1); x <= std::min(cols - 1, gx + 1); ++x) {
        for (int j :
             grid[static_cast<size_t>(y) * static_cast<size_t>(cols) + static_cast<size_t>(x)]) {
          const cv::Point2f d = train_keypoints[static_cast<size_t>(j)].pt - *p;
          if (d.x * d.x + d.y * d.y > r2) continue;
          const float dist = GuidedDistance(query, i, train, j);
          query_best[static_cast<size_t>(i)].Offer(j, dist);
          train_best_dist[static_cast<size_t>(j)].Offer(i, dist);
        }
      }
    }
  }
}

std::vector<cv::DMatch> MatchBinary(const cv::Mat& query, const cv::Mat& train,
                                    const FeatureMatcherOptions& options) {
  std::vector<HammingBest> scan(static_cast<size_t>(query.rows));
  std::vector<TrainBest> train_scan(static_cast<size_t>(train.rows));
  ScanHamming(query, train, scan.data(), train_scan.data());
  std::vector<Best> query_best(scan.size());
  for (size_t i = 0; i < scan.size(); ++i) {
    Best& b = query_best[i];
    b.index = scan[i].index;
    b.distance = static_cast<float>(scan[i].distance);
    // No second candidate (one train row): FLT_MAX, as when knnMatch returned one neighbour.
    if (scan[i].second != INT_MAX) b.second = static_cast<float>(scan[i].second);
  }
  std::vector<int> train_best(train_scan.size(), -1);
  for (size_t j = 0; j < train_scan.size(); ++j) train_best[j] = train_scan[j].index;
  return Select(query_best, train_best, options.max_hamming, options);
}

}  // namespace

Status FeatureMatcherOptions::Validate() const {
  if (!std::isfinite(ratio) || ratio <= 0 || ratio > 1) {
    return InvalidArgumentError("matcher ratio must be in (0, 1]");
  }
  if (!std::isfinite(max_hamming) || max_hamming <= 0 || !(max_l2 > 0)) {
    return InvalidArgumentError("matcher distance limits must be positive");
  }
  if (!std::isfinite(guided_radius_px) || guided_radius_px <= 0) {
    return InvalidArgumentError("matcher guided_radius_px must be positive");
  }
  return OkStatus();
}

StatusOr<std::vector<cv::DMatch>> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                                   const FeatureMatcherOptions& options) {
  SEMMAP_RETURN_IF_ERROR(CheckDescriptors(query, train));
  if (query.empty() || train.empty()) return std::vector<cv::DMatch>{};
  if (query.type() == CV_8UC1) return MatchBinary(query, train, options);
  try {
    cv::BFMatcher matcher(cv::NORM_L2);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(query, train, knn, 2);
    std::vector<Best> query_best(static_cast<size_t>(query.rows));
    for (const std::vector<cv::DMatch>& m : knn) {
      if (m.empty()) continue;
      Best& b = query_best[static_cast<size_t>(m[0].queryIdx)];
      for (const cv::DMatch& d : m) b.Offer(d.trainIdx, d.distance);
    }
    std::vector<int> train_best(static_cast<size_t>(train.rows), -1);
    if (options.cross_check) {
      std::vector<cv::DMatch> reverse;
      matcher.match(train, query, reverse);
      for (const cv::DMatch& d : reverse) train_best[static_cast<size_t>(d.queryIdx)] = d.trainIdx;
    }
    return Select(query_best, train_best, options.max_l2, options);
  } catch (const cv::Exception& e) {
    return InternalError(std::string("descriptor matching: ") + e.what());
  }
}

StatusOr<std::vector<cv::DMatch>> MatchGuided(
    const cv::Mat& query, const std::vector<std::optional<cv::Point2f>>& predicted,
    const cv::Mat& train, const std::vector<cv::KeyPoint>& train_keypoints,
    const FeatureMatcherOptions& options) {
  SEMMAP_RETURN_IF_ERROR(CheckDescriptors(query, train));
  if (predicted.size() != static_cast<size_t>(query.rows) ||
      train_keypoints.size() != static_cast<size_t>(train.rows)) {
    return InvalidArgumentError(
        "guided matching: predictions or keypoints do not match the "
        "descriptor rows");
  }
  if (query.empty() || train.empty()) return std::vector<cv::DMatch>{};
  const bool binary = query.type() == CV_8UC1;

  // Bucket the train keypoints into cells of the search radius: a window touches 3x3 cells.
  const float cell = static_cast<float>(options.guided_radius_px);
  float max_x = 0, max_y = 0;
  for (const cv::KeyPoint& k : train_keypoints) {
    max_x = std::max(max_x, k.pt.x);
    max_y = std::max(max_y, k.pt.y);
  }
  const int cols = static_cast<int>(max_x / cell) + 1;
  const int rows = static_cast<int>(max_y / cell) + 1;
  std::vector<std::vector<int>> grid(static_cast<size_t>(cols * rows));
  for (size_t j = 0; j < train_keypoints.size(); ++j) {
    const cv::Point2f& p = train_keypoints[j].pt;
    if (!(p.x >= 0 && p.y >= 0)) continue;
    const auto row = static_cast<size_t>(p.y / cell), col = static_cast<size_t>(p.x / cell);
    grid[row * static_cast<size_t>(cols) + col].push_back(static_cast<int>(j));
  }

  std::vector<Best> query_best(static_cast<size_t>(query.rows));
  std::vector<Best> train_best_dist(static_cast<size_t>(train.rows));
  GuidedScan(query, predicted, train, train_keypoints, grid, cols, rows, cell, query_best,
             train_best_dist);
  std::vector<int> train_best(static_cast<size_t>(train.rows), -1);
  for (size_t j = 0; j < train_best.size(); ++j) train_best[j] = train_best_dist[j].index;
  return Select(query_best, train_best, binary ? options.max_hamming : options.max_l2, options);
}

}  // namespace semmap
