// Descriptor matching between two frames: Lowe's ratio test and a mutual (cross) check, over
// all descriptors or guided by predicted positions of the query keypoints in the train image.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "common/status.h"

namespace semmap {

struct FeatureMatcherOptions {
  double ratio = 0.8;       // best < ratio * second best (Lowe); 1 disables the test
  bool cross_check = true;  // keep a match only when each side is the other's best
  // Absolute distance limits: Hamming bits for binary descriptors, L2 for float ones.
  double max_hamming = 64;
  double max_l2 = 1e9;
  // Guided matching: train keypoints within this many pixels of the prediction.
  double guided_radius_px = 12.0;

  Status Validate() const;
};

// Matches `query` rows against `train` rows (both CV_8U, compared by Hamming distance, or both
// CV_32F, by L2). DMatch::queryIdx / trainIdx index the rows. INVALID_ARGUMENT for mismatched
// descriptor types or widths; INTERNAL when OpenCV fails. Empty inputs give no matches.
StatusOr<std::vector<cv::DMatch>> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                                   const FeatureMatcherOptions& options);

// Guided matching: query i is compared only with train keypoints within guided_radius_px of
// predicted[i] (nullopt: no prediction, no match). Ratio test against the second best inside
// the window, and the cross check among the guided candidates.
StatusOr<std::vector<cv::DMatch>> MatchGuided(
    const cv::Mat& query, const std::vector<std::optional<cv::Point2f>>& predicted,
    const cv::Mat& train, const std::vector<cv::KeyPoint>& train_keypoints,
    const FeatureMatcherOptions& options);

}  // namespace semmap
