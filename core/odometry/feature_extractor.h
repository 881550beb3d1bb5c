// Keypoints and descriptors of one RGB-D frame, spread over the image by grid bucketing, with
// each keypoint's 3D point from the registered depth image.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "core/sensor/frame_features.h"

namespace semmap {
namespace internal {
struct OrbPyramid;
}  // namespace internal

enum class FeatureType { kOrb, kSift, kAkaze };

struct FeatureExtractorOptions {
  FeatureType type = FeatureType::kOrb;
  int max_features = 1000;  // total budget after bucketing
  int grid_cols = 8;        // bucketing grid; each cell gets max_features / cells first,
  int grid_rows = 6;        // what sparse cells leave over goes to the strongest elsewhere
  // Candidates detected before bucketing, as a multiple of max_features.
  double oversample = 2.0;
  // ORB: pyramid levels and scale (4 x 1.2 covers the scale change of frame-to-keyframe
  // tracking and costs about half of the usual 8 levels), FAST threshold.
  int orb_levels = 4;
  double orb_scale_factor = 1.2;
  int orb_fast_threshold = 20;
  // Grid cells where that threshold finds fewer corners than their share of max_features
  // (plain walls, dim or blurred frames) take weaker corners, down to this threshold, from a
  // second detection (as ORB-SLAM2's iniThFAST / minThFAST); 0 disables it. Geometry spread
  // over the whole image, not only its textured corners, is what keeps rotation from drifting.
  int orb_min_fast_threshold = 7;
  // Depth accepted for a 3D point, metres.
  double min_depth_m = 0.1;
  double max_depth_m = 8.0;

  Status Validate() const;
};

class FeatureExtractor {
 public:
  // INVALID_ARGUMENT for bad options or calibration.
  static StatusOr<FeatureExtractor> Create(const FeatureExtractorOptions& options,
                                           const CameraCalibration& camera);

  // `image`: CV_8UC1 grey or CV_8UC3 BGR of the camera's size. `depth_raw`: CV_16UC1 of the
  // same size registered to the image (metres = raw / depth_scale, 0 = none), or empty for
  // features without depth. INVALID_ARGUMENT for wrong types or sizes; INTERNAL when OpenCV
  // fails.
  StatusOr<FrameFeatures> Extract(const cv::Mat& image, const cv::Mat& depth_raw,
                                  double depth_scale) const;

  const FeatureExtractorOptions& options() const { return options_; }
  const CameraCalibration& camera() const { return camera_; }

 private:
  FeatureExtractor(FeatureExtractorOptions options, CameraCalibration camera,
                   cv::Ptr<cv::Feature2D> detector, int candidates)
      : options_(options),
        camera_(camera),
        detector_(std::move(detector)),
        candidates_(candidates) {}

  // Candidates before bucketing: ORB's own detection (internal/orb_keypoints.h) with the weak
  // pass in sparse cells; SIFT and AKAZE through OpenCV.
  std::vector<cv::KeyPoint> DetectOrb(const internal::OrbPyramid& pyramid) const;
  std::vector<cv::KeyPoint> DetectOther(const cv::Mat& grey) const;

  FeatureExtractorOptions options_;
  CameraCalibration camera_;
  // OpenCV detectors keep no state between calls that affects results, but they are not
  // documented as thread-safe: one extractor per tracking thread. For ORB it only describes.
  cv::Ptr<cv::Feature2D> detector_;
  int candidates_;  // max_features * oversample
};

// Adds to `keypoints` the `weak` keypoints that lie in grid cells holding fewer than `share`
// of `keypoints`, at most enough to fill each such cell to its share (strongest first), and
// none within 2 pixels of a keypoint already there (the same corner found twice).
void FillSparseCells(std::vector<cv::KeyPoint>* keypoints, std::vector<cv::KeyPoint> weak,
                     int width, int height, int cols, int rows, int share);

// Keeps at most `budget` keypoints, spread over a cols x rows grid of the width x height image:
// strongest first in each cell up to an equal share, then the strongest remaining anywhere.
std::vector<cv::KeyPoint> BucketKeypoints(std::vector<cv::KeyPoint> keypoints, int width,
                                          int height, int cols, int rows, int budget);

}  // namespace semmap
