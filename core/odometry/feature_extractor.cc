#include "core/odometry/feature_extractor.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>

#include "core/odometry/internal/orb_keypoints.h"

namespace semmap {

Status FeatureExtractorOptions::Validate() const {
  if (max_features < 10 || max_features > 100000) {
    return InvalidArgumentError("features max_features must be in [10, 100000] (got " +
                                std::to_string(max_features) + ")");
  }
  if (grid_cols < 1 || grid_rows < 1 || grid_cols * grid_rows > max_features) {
    return InvalidArgumentError(
        "features grid must be at least 1x1 with no more cells than "
        "max_features");
  }
  if (!std::isfinite(oversample) || oversample < 1.0 || oversample > 10.0) {
    return InvalidArgumentError("features oversample must be in [1, 10]");
  }
  if (orb_levels < 1 || orb_levels > 16) {
    return InvalidArgumentError("features orb_levels must be in [1, 16]");
  }
  if (!std::isfinite(orb_scale_factor) || orb_scale_factor <= 1.0 || orb_scale_factor > 2.0) {
    return InvalidArgumentError("features orb_scale_factor must be in (1, 2]");
  }
  if (orb_fast_threshold < 1 || orb_fast_threshold > 255) {
    return InvalidArgumentError("features orb_fast_threshold must be in [1, 255]");
  }
  if (orb_min_fast_threshold < 0 || orb_min_fast_threshold > orb_fast_threshold) {
    return InvalidArgumentError(
        "features orb_min_fast_threshold must be in [0, orb_fast_threshold]");
  }
  if (!std::isfinite(min_depth_m) || !std::isfinite(max_depth_m) || min_depth_m <= 0 ||
      max_depth_m <= min_depth_m) {
    return InvalidArgumentError("features depth range must satisfy 0 < min_depth_m < max_depth_m");
  }
  return OkStatus();
}

namespace {

int CellOf(const cv::Point2f& p, int width, int height, int cols, int rows) {
  const int cx = std::clamp(static_cast<int>(p.x * cols / width), 0, cols - 1);
  const int cy = std::clamp(static_cast<int>(p.y * rows / height), 0, rows - 1);
  return cy * cols + cx;
}

}  // namespace

std::vector<cv::KeyPoint> BucketKeypoints(std::vector<cv::KeyPoint> keypoints, int width,
                                          int height, int cols, int rows, int budget) {
  if (budget <= 0 || keypoints.empty()) return {};
  if (static_cast<int>(keypoints.size()) <= budget) return keypoints;
  const int cells = cols * rows;
  // Strongest first overall; stable so equal responses keep detection order (deterministic).
  std::stable_sort(
      keypoints.begin(), keypoints.end(),
      [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
  const int share = std::max(1, budget / cells);
  std::vector<int> taken_in_cell(static_cast<size_t>(cells), 0);
  std::vector<bool> taken(keypoints.size(), false);
  std::vector<cv::KeyPoint> out;
  out.reserve(static_cast<size_t>(budget));
  for (size_t i = 0; i < keypoints.size() && static_cast<int>(out.size()) < budget; ++i) {
    int& n = taken_in_cell[static_cast<size_t>(CellOf(keypoints[i].pt, width, height, cols, rows))];
    if (n < share) {
      ++n;
      taken[i] = true;
      out.push_back(keypoints[i]);
    }
  }
  // Cells without enough texture leave budget over: give it to the strongest of the rest.
  for (size_t i = 0; i < keypoints.size() && static_cast<int>(out.size()) < budget; ++i) {
    if (!taken[i]) out.push_back(keypoints[i]);
  }
  return out;
}

void FillSparseCells(std::vector<cv::KeyPoint>* keypoints, std::vector<cv::KeyPoint> weak,
                     int width, int height, int cols, int rows, int share) {
  const size_t cells = static_cast<size_t>(cols) * static_cast<size_t>(rows);
  std::vector<std::vector<cv::Point2f>> in_cell(cells);
  for (const cv::KeyPoint& k : *keypoints) {
    in_cell[static_cast<size_t>(CellOf(k.pt, width, height, cols, rows))].push_back(k.pt);
  }
  std::stable_sort(weak.begin(), weak.end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    return a.response > b.response;
  });
  for (const cv::KeyPoint& k : weak) {
    std::vector<cv::Point2f>& here =
        in_cell[static_cast<size_t>(CellOf(k.pt, width, height, cols, rows))];
    if (static_cast<int>(here.size()) >= share) continue;
    const bool duplicate = std::any_of(here.begin(), here.end(), [&](const cv::Point2f& p) {
      const cv::Point2f d = p - k.pt;
      return d.dot(d) < 4.0f;
    });
    if (duplicate) continue;
    here.push_back(k.pt);
    keypoints->push_back(k);
  }
}

StatusOr<FeatureExtractor> FeatureExtractor::Create(const FeatureExtractorOptions& options,
                                                    const CameraCalibration& camera) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera));
  const int candidates = static_cast<int>(std::ceil(options.max_features * options.oversample));
  try {
    cv::Ptr<cv::Feature2D> detector;
    switch (options.type) {
      case FeatureType::kOrb:
        // Only describes what internal::DetectOrbKeypoints finds, one pyramid level at a time
        // (internal::DescribeOrbKeypoints): hence one level, the other settings the extractor's.
        detector = cv::ORB::create(candidates, static_cast<float>(options.orb_scale_factor),
                                   /*nlevels=*/1, internal::kOrbEdge, /*firstLevel=*/0,
                                   /*WTA_K=*/2, cv::ORB::HARRIS_SCORE, internal::kOrbPatchSize,
                                   options.orb_fast_threshold);
        break;
      case FeatureType::kSift:
        detector = cv::SIFT::create(candidates);
        break;
      case FeatureType::kAkaze:
        detector = cv::AKAZE::create();
        break;
    }
    if (detector.empty()) return InternalError("could not create the feature detector");
    return FeatureExtractor(options, camera, std::move(detector), candidates);
  } catch (const cv::Exception& e) {
    return InternalError(std::string("creating the feature detector: ") + e.what());
  }
}

std::vector<cv::KeyPoint> FeatureExtractor::DetectOther(const cv::Mat& grey) const {
  std::vector<cv::KeyPoint> candidates;
  detector_->detect(grey, candidates);
  return candidates;
}

std::vector<cv::KeyPoint> FeatureExtractor::DetectOrb(const internal::OrbPyramid& pyramid) const {
  const cv::Mat& grey = pyramid.levels[0];
  const std::vector<int> budgets =
      internal::OrbLevelBudgets(candidates_, options_.orb_levels, options_.orb_scale_factor);
  const int min_threshold = options_.orb_min_fast_threshold;
  const bool weak_pass = min_threshold > 0 && min_threshold < options_.orb_fast_threshold;
  std::vector<cv::KeyPoint> passed_over;  // level coordinates
  std::vector<cv::KeyPoint> candidates = internal::DetectOrbKeypoints(
      pyramid, options_.orb_fast_threshold, budgets, {}, weak_pass ? &passed_over : nullptr);
  if (!weak_pass) return candidates;
  // Cells with fewer candidates than their share of max_features get more, and only there:
  // - where the threshold found enough corners but the level budgets kept stronger ones
  //   elsewhere (texture fainter than the rest of the image), the best of those corners;
  // - where it did not (plain walls, dim or blurred patches), the weaker corners a second
  //   detection at the lower threshold finds there. Searching the whole image again would
  //   double detection's cost, and so would searching textured cells again: on noisy images
  //   the lower threshold finds thousands of corners there.
  const int cols = options_.grid_cols, rows = options_.grid_rows;
  const int share = std::max(1, options_.max_features / (cols * rows));
  std::vector<int> count(static_cast<size_t>(cols * rows), 0);
  for (const cv::KeyPoint& k : candidates) {
    ++count[static_cast<size_t>(CellOf(k.pt, grey.cols, grey.rows, cols, rows))];
  }
  std::vector<std::vector<cv::KeyPoint>> passed_in_cell(static_cast<size_t>(cols * rows));
  for (const cv::KeyPoint& k : passed_over) {
    const size_t cell = static_cast<size_t>(
        CellOf(internal::AtLevelZero(pyramid, k).pt, grey.cols, grey.rows, cols, rows));
    if (count[cell] < share) passed_in_cell[cell].push_back(k);
  }
  std::vector<cv::Rect2f> plain;
  std::vector<cv::KeyPoint> weak;
  const float cell_w = static_cast<float>(grey.cols) / static_cast<float>(cols);
  const float cell_h = static_cast<float>(grey.rows) / static_cast<float>(rows);
  for (int cy = 0, cell = 0; cy < rows; ++cy) {
    for (int cx = 0; cx < cols; ++cx, ++cell) {
      const size_t c = static_cast<size_t>(cell);
      const int missing = share - count[c];
      if (missing <= 0) continue;
      std::vector<cv::KeyPoint>& passed = passed_in_cell[c];
      if (static_cast<int>(passed.size()) < missing) {
        plain.emplace_back(static_cast<float>(cx) * cell_w, static_cast<float>(cy) * cell_h, cell_w,
                           cell_h);
        continue;
      }
      // Twice what is missing by FAST score, ranked by Harris as the kept corners were.
      const size_t offer = std::min(passed.size(), 2 * static_cast<size_t>(missing));
      std::partial_sort(
          passed.begin(), passed.begin() + static_cast<ptrdiff_t>(offer), passed.end(),
          [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
      for (size_t i = 0; i < offer; ++i) {
        cv::KeyPoint k = passed[i];
        k.response =
            internal::HarrisResponse(pyramid.levels[static_cast<size_t>(k.octave)],
                                     cv::Point(static_cast<int>(k.pt.x), static_cast<int>(k.pt.y)));
        weak.push_back(internal::AtLevelZero(pyramid, k));
      }
    }
  }
  if (!plain.empty()) {
    std::vector<cv::KeyPoint> found =
        internal::DetectOrbKeypoints(pyramid, min_threshold, budgets, plain);
    weak.insert(weak.end(), found.begin(), found.end());
  }
  if (weak.empty()) return candidates;
  internal::KeepWithinLevelBudgets(candidates, budgets, &weak);
  FillSparseCells(&candidates, std::move(weak), grey.cols, grey.rows, cols, rows, share);
  return candidates;
}

StatusOr<FrameFeatures> FeatureExtractor::Extract(const cv::Mat& image, const cv::Mat& depth_raw,
                                                  double depth_scale) const {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    return InvalidArgumentError("feature extraction needs an 8-bit grey or BGR image");
  }
  if (image.cols != camera_.width || image.rows != camera_.height) {
    return InvalidArgumentError(
        "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
        ", the camera " + std::to_string(camera_.width) + "x" + std::to_string(camera_.height));
  }
  const bool with_depth = !depth_raw.empty();
  if (with_depth) {
    if (depth_raw.type() != CV_16UC1 || depth_raw.size() != image.size()) {
      return InvalidArgumentError("depth must be CV_16UC1 of the image's size");
    }
    if (!std::isfinite(depth_scale) || depth_scale <= 0) {
      return InvalidArgumentError("depth_scale must be positive");
    }
  }

  FrameFeatures out;
  try {
    cv::Mat grey;
    if (image.channels() == 3) {
      cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    } else {
      grey = image;  // shares the pixels; nothing below writes to them
    }
    std::vector<cv::KeyPoint> candidates;
    std::optional<internal::OrbPyramid> pyramid;
    if (options_.type == FeatureType::kOrb) {
      pyramid = internal::BuildOrbPyramid(grey, options_.orb_levels, options_.orb_scale_factor);
      candidates = DetectOrb(*pyramid);
    } else {
      candidates = DetectOther(grey);
    }
    out.keypoints = BucketKeypoints(std::move(candidates), grey.cols, grey.rows, options_.grid_cols,
                                    options_.grid_rows, options_.max_features);
    // Describing may drop keypoints it cannot (too near a border); the rest stay aligned with
    // the descriptor rows.
    if (pyramid) {
      internal::OrientOrbKeypoints(*pyramid, &out.keypoints);  // the kept ones only
      internal::DescribeOrbKeypoints(*pyramid, static_cast<float>(options_.orb_scale_factor),
                                     *detector_, &out.keypoints, &out.descriptors);
    } else {
      detector_->compute(grey, out.keypoints, out.descriptors);
    }
  } catch (const cv::Exception& e) {
    return InternalError(std::string("feature extraction: ") + e.what());
  }

  const size_t n = out.keypoints.size();
  // Depth is registered to the raw (distorted) image: look it up before undistorting.
  std::vector<double> z(n, 0.0);
  if (with_depth) {
    for (size_t i = 0; i < n; ++i) {
      const int u = static_cast<int>(std::lround(out.keypoints[i].pt.x));
      const int v = static_cast<int>(std::lround(out.keypoints[i].pt.y));
      if (u < 0 || v < 0 || u >= depth_raw.cols || v >= depth_raw.rows) continue;
      const uint16_t raw = depth_raw.at<uint16_t>(v, u);
      if (raw == 0) continue;
      const double metres = raw / depth_scale;
      if (metres >= options_.min_depth_m && metres <= options_.max_depth_m) z[i] = metres;
    }
  }
  if (camera_.HasDistortion() && n > 0) {
    try {
      std::vector<cv::Point2f> distorted(n), undistorted;
      for (size_t i = 0; i < n; ++i) distorted[i] = out.keypoints[i].pt;
      const cv::Matx33d K(camera_.fx, 0, camera_.cx, 0, camera_.fy, camera_.cy, 0, 0, 1);
      const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(camera_.distortion.data()));
      cv::undistortPoints(distorted, undistorted, K, dist, cv::noArray(), K);
      for (size_t i = 0; i < n; ++i) out.keypoints[i].pt = undistorted[i];
    } catch (const cv::Exception& e) {
      return InternalError(std::string("undistorting keypoints: ") + e.what());
    }
  }
  out.points_camera.assign(n, Eigen::Vector3d::Zero());
  out.has_depth.assign(n, false);
  for (size_t i = 0; i < n; ++i) {
    if (z[i] <= 0) continue;
    const double u = out.keypoints[i].pt.x, v = out.keypoints[i].pt.y;
    out.points_camera[i] = Eigen::Vector3d((u - camera_.cx) / camera_.fx * z[i],
                                           (v - camera_.cy) / camera_.fy * z[i], z[i]);
    out.has_depth[i] = true;
  }
  return out;
}

}  // namespace semmap
