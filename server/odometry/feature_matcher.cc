#include "server/odometry/feature_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/features2d.hpp>
#include <string>

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
  const bool binary = query.type() == CV_8UC1;
  try {
    cv::BFMatcher matcher(binary ? cv::NORM_HAMMING : cv::NORM_L2);
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
    return Select(query_best, train_best, binary ? options.max_hamming : options.max_l2, options);
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
    grid[static_cast<size_t>(static_cast<int>(p.y / cell) * cols + static_cast<int>(p.x / cell))]
        .push_back(static_cast<int>(j));
  }

  const float r2 = cell * cell;
  std::vector<Best> query_best(static_cast<size_t>(query.rows));
  std::vector<Best> train_best_dist(static_cast<size_t>(train.rows));
  for (int i = 0; i < query.rows; ++i) {
    const std::optional<cv::Point2f>& p = predicted[static_cast<size_t>(i)];
    if (!p || !std::isfinite(p->x) || !std::isfinite(p->y)) continue;
    const int gx = static_cast<int>(std::floor(p->x / cell));
    const int gy = static_cast<int>(std::floor(p->y / cell));
    for (int y = std::max(0, gy - 1); y <= std::min(rows - 1, gy + 1); ++y) {
      for (int x = std::max(0, gx - 1); x <= std::min(cols - 1, gx + 1); ++x) {
        for (int j : grid[static_cast<size_t>(y * cols + x)]) {
          const cv::Point2f d = train_keypoints[static_cast<size_t>(j)].pt - *p;
          if (d.x * d.x + d.y * d.y > r2) continue;
          float dist;
          if (binary) {
            dist = static_cast<float>(
                cv::hal::normHamming(query.ptr<uchar>(i), train.ptr<uchar>(j), query.cols));
          } else {
            dist = std::sqrt(
                cv::hal::normL2Sqr_(query.ptr<float>(i), train.ptr<float>(j), query.cols));
          }
          query_best[static_cast<size_t>(i)].Offer(j, dist);
          train_best_dist[static_cast<size_t>(j)].Offer(i, dist);
        }
      }
    }
  }
  std::vector<int> train_best(static_cast<size_t>(train.rows), -1);
  for (size_t j = 0; j < train_best.size(); ++j) train_best[j] = train_best_dist[j].index;
  return Select(query_best, train_best, binary ? options.max_hamming : options.max_l2, options);
}

}  // namespace semmap
