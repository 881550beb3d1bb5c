// What the recogniser knows about a registered object type: the 2D ORB features of each of its
// photos (views), and the options that govern building views and recognising them in
// keyframes. Photos come from users (a crop or a photo with little background) at any size;
// they are shrunk to a bounded long side before extraction so that a 12-megapixel phone photo
// costs what a 640 px one does, and their keypoints are then expressed in the photo's own
// pixels so that a view built now and one decoded from the store (ObjectView in
// common/object_types.h: width, height, features) are the same thing.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "core/odometry/feature_extractor.h"
#include "core/odometry/feature_matcher.h"

namespace semmap {

// ORB for photos, per octave: 400 features on a 4x4 grid, the keyframes' 4 levels of 1.2, and
// a lower FAST threshold than keyframes (12) because a shrunk photo loses contrast.
FeatureExtractorOptions DefaultPhotoFeatureOptions();
// Ratio 0.8 with the cross check and at most 64 bits (the odometry matcher's defaults).
FeatureMatcherOptions DefaultObjectMatcherOptions();

struct ObjectRecognitionOptions {
  // Photo features. A photo is usually several times larger in pixels than the object appears
  // in a keyframe (a 21 cm book photographed at 1 mm/px is seen ~90 px wide at 1.3 m, a 4x
  // scale change), more than the keyframes' ORB pyramid (4 levels of 1.2, 1.7x) bridges, and
  // one deep pyramid on the photo gives its coarse levels too few features. So the photo is
  // described at photo_scales octaves (1, 1/2, 1/4, ...; each with the keyframes' pyramid,
  // photo_features.max_features at the first, half as many at each next, at least
  // min_scale_features), which covers scale changes of 1-14x; octaves whose longer side would
  // fall under min_scale_side_px are skipped. All of a view's features match in one pass.
  FeatureExtractorOptions photo_features = DefaultPhotoFeatureOptions();
  int photo_scales = 4;
  int min_scale_side_px = 80;
  int min_scale_features = 50;
  int max_photo_side_px = 640;  // longer photos are shrunk to this before extraction
  int min_model_features = 50;  // fewer: the photo is rejected (blurred, plain or tiny)

  // Matching photo -> keyframe: ratio test and cross check (Hamming, POPCNT matcher).
  FeatureMatcherOptions matcher = DefaultObjectMatcherOptions();
  // A view is verified geometrically only with at least this many good matches: the cheap
  // early exit, as most object types are not in most keyframes. By chance a ~700-feature view
  // gets 5-20 good matches (mean 11) in a 1000-feature keyframe that does not show it, and
  // RANSAC on such a candidate costs 2-3 ms, several times its matching pass; at 20 the 50-type
  // benchmark verifies about one candidate per keyframe (10 at 15) and the synthetic laps
  // lose no detection.
  int min_good_matches = 20;
  // Homography RANSAC (photo -> keyframe pixels). 500 iterations find a model with 12 of 40
  // matches right 98% of the time.
  double ransac_reprojection_px = 4.0;
  int ransac_max_iterations = 500;
  int min_inliers = 12;            // homography inliers needed for a detection
  int min_inliers_with_depth = 8;  // of which with a 3D point (position and extent need them)
  // Sanity of the homography, on the photo's outline projected into the keyframe: it must be
  // a convex quadrilateral with the photo's orientation (not mirrored), cover at least this
  // many pixels, have no corner sharper than min_corner_angle_deg (a perspective view of a
  // rectangle within ~70 degrees of head-on keeps its corners above ~30 degrees) and no
  // opposite sides more than max_side_ratio apart in length.
  double min_outline_area_px = 300.0;
  double min_corner_angle_deg = 25.0;
  double max_side_ratio = 4.0;
  // Position on the plane of the inlier points (object_detector.h): a RANSAC plane with a
  // tolerance of plane_tolerance_m + plane_tolerance_per_m2 * z^2 at the points' median depth
  // z (depth noise grows with z^2; 3 cm at 2 m), used when at least half the points (and
  // min_inliers_with_depth) lie on it, they spread at least plane_min_spread_m across it and
  // the ray meets it at more than 10 degrees.
  double plane_tolerance_m = 0.01;
  double plane_tolerance_per_m2 = 0.005;
  double plane_min_spread_m = 0.01;
  // Extent: the per-axis range between these percentiles of the inlier 3D points.
  double extent_low_percentile = 10.0;
  double extent_high_percentile = 90.0;
  // Neighbour check (common/xi_check.h): reject when N_c / N_n > max_xi.
  double max_xi = 1.25;

  Status Validate() const;
};

// One photo of an object type, ready to match. Keypoints are in the original photo's pixels
// (width x height) even when extraction ran on a shrunk copy; there is no depth
// (points_camera zero, has_depth false).
struct ModelView {
  FrameFeatures features;
  int width = 0;  // the photo as given, pixels
  int height = 0;
};

// A registered object type as the recogniser sees it.
struct ObjectModel {
  int64_t type_id = 0;
  std::string label;
  std::vector<ModelView> views;
};

// `photo`: CV_8UC1 grey, CV_8UC3 BGR or CV_8UC4 BGRA, any size. INVALID_ARGUMENT with a reason
// a user can act on for an empty image, another pixel type, a side under 32 px, or fewer than
// min_model_features features; INTERNAL when OpenCV fails.
StatusOr<ModelView> BuildModelView(const cv::Mat& photo, const ObjectRecognitionOptions& options);

// Largest object photo accepted from encoded bytes (checked from the header, before decoding).
inline constexpr uint64_t kMaxObjectPhotoPixels = 24'000'000;

// The same from encoded PNG or JPEG bytes; INVALID_ARGUMENT for bytes that do not fully decode
// (truncated or corrupt) or a photo over kMaxObjectPhotoPixels.
StatusOr<ModelView> BuildModelViewFromEncoded(std::string_view bytes,
                                              const ObjectRecognitionOptions& options);

// Builds a model from several photos; every photo must pass (the error names the photo).
StatusOr<ObjectModel> BuildObjectModel(int64_t type_id, std::string label,
                                       const std::vector<cv::Mat>& photos,
                                       const ObjectRecognitionOptions& options);

}  // namespace semmap
