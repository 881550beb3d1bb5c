#include "core/recognition/object_model.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>

#include "core/sensor/compressed_image.h"

namespace semmap {

FeatureExtractorOptions DefaultPhotoFeatureOptions() {
  FeatureExtractorOptions o;
  o.type = FeatureType::kOrb;
  o.max_features = 400;
  o.grid_cols = 4;
  o.grid_rows = 4;
  o.oversample = 2.0;
  o.orb_levels = 4;
  o.orb_scale_factor = 1.2;
  o.orb_fast_threshold = 12;
  return o;
}

FeatureMatcherOptions DefaultObjectMatcherOptions() {
  FeatureMatcherOptions o;
  o.ratio = 0.8;
  o.cross_check = true;
  o.max_hamming = 64;
  return o;
}

Status ObjectRecognitionOptions::Validate() const {
  SEMMAP_RETURN_IF_ERROR(photo_features.Validate().WithContext("photo features"));
  if (photo_features.type != FeatureType::kOrb) {
    return InvalidArgumentError("photo features must be ORB (keyframes carry ORB descriptors)");
  }
  SEMMAP_RETURN_IF_ERROR(matcher.Validate().WithContext("object matcher"));
  if (max_photo_side_px < 64 || max_photo_side_px > 4096) {
    return InvalidArgumentError("max_photo_side_px must be in [64, 4096]");
  }
  if (photo_scales < 1 || photo_scales > 8) {
    return InvalidArgumentError("photo_scales must be in [1, 8]");
  }
  if (min_scale_side_px < 32) return InvalidArgumentError("min_scale_side_px must be >= 32");
  if (min_scale_features < 10 || min_scale_features > photo_features.max_features) {
    return InvalidArgumentError("min_scale_features must be in [10, photo max_features]");
  }
  if (min_model_features < 4 || min_model_features > photo_features.max_features) {
    return InvalidArgumentError(
        "min_model_features must be at least 4 and at most the photo feature budget");
  }
  if (min_inliers < 4) {
    return InvalidArgumentError("min_inliers must be at least 4 (a homography needs 4 points)");
  }
  if (min_good_matches < min_inliers) {
    return InvalidArgumentError("min_good_matches must be at least min_inliers");
  }
  if (min_inliers_with_depth < 1 || min_inliers_with_depth > min_inliers) {
    return InvalidArgumentError("min_inliers_with_depth must be in [1, min_inliers]");
  }
  if (!std::isfinite(ransac_reprojection_px) || ransac_reprojection_px <= 0 ||
      ransac_reprojection_px > 50) {
    return InvalidArgumentError("ransac_reprojection_px must be in (0, 50]");
  }
  if (ransac_max_iterations < 10 || ransac_max_iterations > 100000) {
    return InvalidArgumentError("ransac_max_iterations must be in [10, 100000]");
  }
  if (!std::isfinite(min_outline_area_px) || min_outline_area_px < 0) {
    return InvalidArgumentError("min_outline_area_px must be non-negative");
  }
  if (!std::isfinite(min_corner_angle_deg) || min_corner_angle_deg < 0 ||
      min_corner_angle_deg >= 90) {
    return InvalidArgumentError("min_corner_angle_deg must be in [0, 90)");
  }
  if (!std::isfinite(max_side_ratio) || max_side_ratio < 1) {
    return InvalidArgumentError("max_side_ratio must be at least 1");
  }
  if (!std::isfinite(plane_tolerance_m) || plane_tolerance_m <= 0 ||
      !std::isfinite(plane_tolerance_per_m2) || plane_tolerance_per_m2 < 0 ||
      !std::isfinite(plane_min_spread_m) || plane_min_spread_m < 0) {
    return InvalidArgumentError("plane tolerances must be positive");
  }
  if (!(extent_low_percentile >= 0 && extent_low_percentile < extent_high_percentile &&
        extent_high_percentile <= 100)) {
    return InvalidArgumentError("extent percentiles must satisfy 0 <= low < high <= 100");
  }
  if (!std::isfinite(max_xi) || max_xi <= 0) {
    return InvalidArgumentError("max_xi must be positive");
  }
  return OkStatus();
}

namespace {

// Below this ORB finds nothing (its patches are 31 px) and OpenCV may fail outright.
constexpr int kMinPhotoSidePx = 32;

// Features of `grey` (the photo shrunk by `scale`: photo pixels per image pixel along x, y) with
// keypoints in photo pixels, appended to `out`.
Status AppendScale(const cv::Mat& grey, cv::Point2d scale, int budget, int scale_index,
                   const ObjectRecognitionOptions& options, FrameFeatures* out) {
  // The extractor wants a calibration of the image's size; a photo has none, and only the 2D
  // keypoints are used, so any valid pinhole will do.
  CameraCalibration camera;
  camera.width = grey.cols;
  camera.height = grey.rows;
  camera.fx = camera.fy = std::max(grey.cols, grey.rows);
  camera.cx = 0.5 * (grey.cols - 1);
  camera.cy = 0.5 * (grey.rows - 1);
  FeatureExtractorOptions features = options.photo_features;
  features.max_features = budget;
  // Cells of at least 64 px, so a small image's cells are not smaller than a keypoint's patch.
  features.grid_cols = std::clamp(grey.cols / 64, 1, features.grid_cols);
  features.grid_rows = std::clamp(grey.rows / 64, 1, features.grid_rows);
  SEMMAP_ASSIGN_OR_RETURN(const FeatureExtractor extractor,
                          FeatureExtractor::Create(features, camera));
  SEMMAP_ASSIGN_OR_RETURN(FrameFeatures f, extractor.Extract(grey, cv::Mat(), 1.0));
  for (cv::KeyPoint& k : f.keypoints) {
    k.pt.x = static_cast<float>(k.pt.x * scale.x);
    k.pt.y = static_cast<float>(k.pt.y * scale.y);
    k.size = static_cast<float>(k.size * 0.5 * (scale.x + scale.y));
    k.octave += scale_index * features.orb_levels;  // informative: the level over all scales
    out->keypoints.push_back(k);
  }
  if (out->descriptors.empty()) {
    out->descriptors = f.descriptors;
  } else if (!f.descriptors.empty()) {
    cv::vconcat(out->descriptors, f.descriptors, out->descriptors);
  }
  return OkStatus();
}

}  // namespace

StatusOr<ModelView> BuildModelView(const cv::Mat& photo, const ObjectRecognitionOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (photo.empty()) return InvalidArgumentError("the object photo is empty");
  if (photo.depth() != CV_8U ||
      (photo.channels() != 1 && photo.channels() != 3 && photo.channels() != 4)) {
    return InvalidArgumentError("the object photo must be 8-bit grey, BGR or BGRA");
  }
  if (std::min(photo.cols, photo.rows) < kMinPhotoSidePx) {
    return InvalidArgumentError(
        "the " + std::to_string(photo.cols) + "x" + std::to_string(photo.rows) +
        " photo is too small: an object "
        "photo needs at least " +
        std::to_string(kMinPhotoSidePx) + " px on each side; use a larger photo");
  }
  ModelView view;
  view.width = photo.cols;
  view.height = photo.rows;
  const int long_side = std::max(photo.cols, photo.rows);
  // Photo pixels per pixel of the first scale (>= 1).
  double shrink =
      long_side > options.max_photo_side_px
          ? static_cast<double>(long_side) / static_cast<double>(options.max_photo_side_px)
          : 1.0;
  try {
    cv::Mat grey;
    if (photo.channels() == 3) {
      cv::cvtColor(photo, grey, cv::COLOR_BGR2GRAY);
    } else if (photo.channels() == 4) {
      cv::cvtColor(photo, grey, cv::COLOR_BGRA2GRAY);
    } else {
      grey = photo;
    }
    int budget = options.photo_features.max_features;
    for (int i = 0; i < options.photo_scales; ++i) {
      const cv::Size size(std::max(1, static_cast<int>(std::lround(photo.cols / shrink))),
                          std::max(1, static_cast<int>(std::lround(photo.rows / shrink))));
      if (i > 0 && std::max(size.width, size.height) < options.min_scale_side_px) break;
      cv::Mat scaled;
      if (size == grey.size()) {
        scaled = grey;
      } else {
        cv::resize(grey, scaled, size, 0, 0, cv::INTER_AREA);  // area: no aliasing
      }
      const cv::Point2d scale(static_cast<double>(photo.cols) / size.width,
                              static_cast<double>(photo.rows) / size.height);
      SEMMAP_RETURN_IF_ERROR(AppendScale(scaled, scale, budget, i, options, &view.features));
      shrink *= 2.0;
      budget = std::max(options.min_scale_features, budget / 2);
    }
  } catch (const cv::Exception& e) {
    return InternalError(std::string("object photo features: ") + e.what());
  }
  const size_t n = view.features.keypoints.size();
  view.features.points_camera.assign(n, Eigen::Vector3d::Zero());
  view.features.has_depth.assign(n, false);
  if (static_cast<int>(n) < options.min_model_features) {
    return InvalidArgumentError("only " + std::to_string(n) + " features in the " +
                                std::to_string(photo.cols) + "x" + std::to_string(photo.rows) +
                                " photo; a recognisable object needs " +
                                std::to_string(options.min_model_features) +
                                ": use a sharper, more textured or larger photo");
  }
  return view;
}

StatusOr<ModelView> BuildModelViewFromEncoded(std::string_view bytes,
                                              const ObjectRecognitionOptions& options) {
  if (bytes.empty()) return InvalidArgumentError("the object photo is empty (no bytes)");
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(bytes);
  if (!info.ok()) {
    return InvalidArgumentError("the object photo does not decode: it " + info.status().message());
  }
  // The header is read first: a small file must not make the server allocate a huge image.
  const uint64_t pixels = static_cast<uint64_t>(info->width) * info->height;  // < 2^62
  if (pixels > kMaxObjectPhotoPixels) {
    return InvalidArgumentError("the object photo is " + std::to_string(info->width) + "x" +
                                std::to_string(info->height) + " pixels; the limit is " +
                                std::to_string(kMaxObjectPhotoPixels / 1000000) +
                                " megapixels (a crop of the object is enough)");
  }
  StatusOr<cv::Mat> photo = DecodeCompressedImage(bytes, *info, DecodeTarget::kBgr);
  if (!photo.ok()) {
    if (photo.status().code() != StatusCode::kInvalidArgument) return photo.status();
    return InvalidArgumentError("the object photo does not decode: " + photo.status().message());
  }
  return BuildModelView(*photo, options);
}

StatusOr<ObjectModel> BuildObjectModel(int64_t type_id, std::string label,
                                       const std::vector<cv::Mat>& photos,
                                       const ObjectRecognitionOptions& options) {
  if (photos.empty()) return InvalidArgumentError("an object type needs at least one photo");
  ObjectModel model;
  model.type_id = type_id;
  model.label = std::move(label);
  for (size_t i = 0; i < photos.size(); ++i) {
    StatusOr<ModelView> view = BuildModelView(photos[i], options);
    if (!view.ok()) return view.status().WithContext("photo " + std::to_string(i + 1));
    model.views.push_back(std::move(view).value());
  }
  return model;
}

}  // namespace semmap
