// Finds registered objects in one keyframe: each view of each model is matched against the
// keyframe's ORB descriptors in one pass (ratio test + cross check); views with enough good
// matches are verified with a RANSAC homography from the photo to the keyframe (objects are
// photographed face on, and most faces users photograph are near planar), the homography is
// checked for sanity on the photo's projected outline, and the inliers' 3D points from depth
// give the object's position and extent. Pure: no state between calls, no threads.
//
// Position: where the ray through the photo's centre, mapped into the keyframe by the
// homography, meets the plane fitted (robustly) to the inlier points: the centre of the face
// the photo shows, even when part of it is out of view or its texture (and so its features)
// is concentrated on one side. When no plane fits (too few points, nearly collinear ones, the
// ray grazing it, points off a plane: a non-planar object), the point on that ray at the
// median of the points' distances along it: laterally still the face centre, in depth robust
// to the few inliers on an edge whose depth belongs to the background. On the synthetic room
// the per-axis median of the points alone is off by 3-5 cm on fully visible faces (features
// cluster on the cover's caption) and by up to 30 cm on a poster partly out of view; the
// plane centre by under 1 cm.
// Extent: the per-axis percentile range (10th-90th) of the inlier points, those on the plane
// when it fits: about 80% of a uniformly textured face's size along each keyframe axis.
//
// The neighbour check (common/xi_check.h, keyframe_recognition.h) is the caller's next step; it
// needs the per-model good-match counts returned here and CountGoodMatches on the neighbours. One
// detection per model and keyframe: two copies of an object in one view give the one with more
// inliers.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/object_types.h"
#include "common/status.h"
#include "core/odometry/feature_extractor.h"
#include "core/recognition/object_model.h"
#include "core/recognition/object_position.h"

namespace semmap {

struct ObjectDetection {
  int model_index = -1;  // into the models given to DetectObjects
  int64_t type_id = 0;
  std::string label;
  int view_index = -1;  // the verified view (the one with the most inliers)
  int matches = 0;      // good matches of that view
  int inliers = 0;      // homography inliers
  int inliers_with_depth = 0;
  // Keyframe keypoint indices of the inliers (ascending), with and without depth.
  std::vector<int> inlier_indices;
  cv::Matx33d H_keyframe_photo = cv::Matx33d::eye();  // photo pixels -> keyframe pixels
  std::array<cv::Point2f, 4> outline{};  // the photo's corners in the keyframe (TL, TR, BR, BL)
  Eigen::Vector3d p_keyframe = Eigen::Vector3d::Zero();  // face centre (above), metres
  PositionSource position_source = PositionSource::kMedian;
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();  // percentile range per axis, metres
};

struct KeyframeDetections {
  // Per model (index-aligned with the models given): the most good matches of any of its
  // views in this keyframe, detected or not. N_c of the neighbour check.
  std::vector<int> good_matches;
  // At most one per model (the view with the most inliers), in model order.
  std::vector<ObjectDetection> detections;
};

// `keyframe`: ORB features with 3D points (FeatureExtractor with depth) of a `camera` image
// (its pinhole fx, fy, cx, cy map the undistorted keypoints to rays). Models without views
// are skipped. INVALID_ARGUMENT for bad options, per-keypoint arrays that disagree in size or
// descriptors of another type or width than the views'; INTERNAL when OpenCV fails. A
// keyframe without descriptors gives no detections.
StatusOr<KeyframeDetections> DetectObjects(const FrameFeatures& keyframe,
                                           const CameraCalibration& camera,
                                           const std::vector<ObjectModel>& models,
                                           const ObjectRecognitionOptions& options);

// The most good matches (ratio test + cross check) of any view of `model` in `keyframe`:
// one matching pass per view, no geometry. N_n of the neighbour check, for each neighbour.
StatusOr<int> CountGoodMatches(const ObjectModel& model, const FrameFeatures& keyframe,
                               const FeatureMatcherOptions& matcher);

// The homography sanity check of ObjectRecognitionOptions on a photo's projected outline
// (exposed for tests): OK, or INVALID_ARGUMENT saying what is wrong.
Status CheckProjectedOutline(const cv::Matx33d& H_keyframe_photo, int photo_width, int photo_height,
                             const ObjectRecognitionOptions& options,
                             std::array<cv::Point2f, 4>* outline = nullptr);

// The observation record of a detection (type, label, position, extent, matches, inliers and
// `xi`); the caller fills in the map, keyframe, session, seq and stamp.
ObjectObservation ToObservation(const ObjectDetection& detection, double xi);

}  // namespace semmap
