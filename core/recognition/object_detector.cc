#include "core/recognition/object_detector.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <optional>
#include <string>
#include <utility>

#include "core/odometry/feature_matcher.h"

namespace semmap {
namespace {

Status CheckFeatures(const FrameFeatures& f, std::string_view what) {
  const size_t n = f.keypoints.size();
  if (static_cast<size_t>(f.descriptors.rows) != n || f.points_camera.size() != n ||
      f.has_depth.size() != n) {
    return InvalidArgumentError(std::string(what) +
                                ": keypoints, descriptors, points and depth flags differ in count");
  }
  return OkStatus();
}

double Cross(const cv::Point2d& a, const cv::Point2d& b) { return a.x * b.y - a.y * b.x; }

// Geometric verification of one view's matches. Fills `out` (not model/type/label) and returns
// true when the view is detected.
StatusOr<bool> VerifyView(const ModelView& view, const FrameFeatures& keyframe,
                          const CameraCalibration& camera, const std::vector<cv::DMatch>& matches,
                          const ObjectRecognitionOptions& options, ObjectDetection* out) {
  std::vector<cv::Point2f> src, dst;
  src.reserve(matches.size());
  dst.reserve(matches.size());
  for (const cv::DMatch& m : matches) {
    src.push_back(view.features.keypoints[static_cast<size_t>(m.queryIdx)].pt);
    dst.push_back(keyframe.keypoints[static_cast<size_t>(m.trainIdx)].pt);
  }
  cv::Matx33d Hm;
  std::vector<uchar> mask;
  try {
    const cv::Mat H = cv::findHomography(src, dst, cv::RANSAC, options.ransac_reprojection_px, mask,
                                         options.ransac_max_iterations, 0.995);
    if (H.empty() || H.rows != 3 || H.cols != 3) return false;
    H.convertTo(cv::Mat(Hm, false), CV_64F);
  } catch (const cv::Exception& e) {
    return InternalError(std::string("object homography: ") + e.what());
  }
  const int inliers = static_cast<int>(std::count(mask.begin(), mask.end(), uchar{1}));
  if (inliers < options.min_inliers) return false;
  std::array<cv::Point2f, 4> outline{};
  if (!CheckProjectedOutline(Hm, view.width, view.height, options, &outline).ok()) return false;

  std::vector<int> indices;
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (!mask[i]) continue;
    const int k = matches[i].trainIdx;
    indices.push_back(k);
    if (keyframe.has_depth[static_cast<size_t>(k)]) {
      points.push_back(keyframe.points_camera[static_cast<size_t>(k)]);
    }
  }
  const int with_depth = static_cast<int>(points.size());
  if (with_depth < options.min_inliers_with_depth) return false;
  std::sort(indices.begin(), indices.end());

  const cv::Vec3d c = Hm * cv::Vec3d(0.5 * view.width, 0.5 * view.height, 1.0);
  std::optional<Eigen::Vector3d> ray;
  if (c[2] > 1e-9) {
    ray = Eigen::Vector3d((c[0] / c[2] - camera.cx) / camera.fx,
                          (c[1] / c[2] - camera.cy) / camera.fy, 1.0);
  }
  const ObjectPosition position = EstimateObjectPosition(points, ray, options);

  out->matches = static_cast<int>(matches.size());
  out->inliers = inliers;
  out->inliers_with_depth = with_depth;
  out->inlier_indices = std::move(indices);
  out->H_keyframe_photo = Hm;
  out->outline = outline;
  out->p_keyframe = position.p;
  out->extent = position.extent;
  out->position_source = position.source;
  return true;
}

Status CheckModels(const std::vector<ObjectModel>& models, const FrameFeatures& keyframe) {
  for (const ObjectModel& model : models) {
    for (const ModelView& view : model.views) {
      SEMMAP_RETURN_IF_ERROR(CheckFeatures(view.features, "object view of " + model.label));
      if (view.features.descriptors.empty() || keyframe.descriptors.empty()) continue;
      if (view.features.descriptors.type() != keyframe.descriptors.type() ||
          view.features.descriptors.cols != keyframe.descriptors.cols) {
        return InvalidArgumentError("object view of " + model.label +
                                    ": descriptors differ in type or width from the keyframe's");
      }
    }
  }
  return OkStatus();
}

}  // namespace

Status CheckProjectedOutline(const cv::Matx33d& H, int photo_width, int photo_height,
                             const ObjectRecognitionOptions& options,
                             std::array<cv::Point2f, 4>* outline) {
  const double w = photo_width, h = photo_height;
  const cv::Vec3d corners[4] = {{0, 0, 1}, {w, 0, 1}, {w, h, 1}, {0, h, 1}};
  cv::Point2d q[4];
  for (int i = 0; i < 4; ++i) {
    const cv::Vec3d p = H * corners[i];
    // A corner at or beyond the horizon: the plane would cross behind the camera.
    if (!(p[2] > 1e-9) || !std::isfinite(p[0]) || !std::isfinite(p[1])) {
      return InvalidArgumentError("the photo's outline crosses the horizon");
    }
    q[i] = cv::Point2d(p[0] / p[2], p[1] / p[2]);
    if (outline) (*outline)[static_cast<size_t>(i)] = cv::Point2f(q[i]);
  }
  // Image y points down, so the photo's TL -> TR -> BR -> BL turns with positive cross
  // products; every corner must turn the same way (convex, not mirrored).
  double area = 0;
  for (int i = 0; i < 4; ++i) {
    const cv::Point2d in = q[i] - q[(i + 3) % 4];
    const cv::Point2d outgoing = q[(i + 1) % 4] - q[i];
    if (!(Cross(in, outgoing) > 0)) {
      return InvalidArgumentError("the photo's outline is not convex or is mirrored");
    }
    area += 0.5 * Cross(q[i], q[(i + 1) % 4]);
  }
  if (area < options.min_outline_area_px) {
    return InvalidArgumentError("the photo's outline covers only " +
                                std::to_string(static_cast<int>(area)) + " px");
  }
  const double min_angle = options.min_corner_angle_deg * std::numbers::pi / 180.0;
  double side[4];
  for (int i = 0; i < 4; ++i) {
    const cv::Point2d a = q[(i + 3) % 4] - q[i], b = q[(i + 1) % 4] - q[i];
    side[i] = std::hypot(b.x, b.y);
    const double angle = std::atan2(std::abs(Cross(a, b)), a.dot(b));
    if (angle < min_angle) {
      return InvalidArgumentError("the photo's outline has a corner of " +
                                  std::to_string(angle * 180.0 / std::numbers::pi) + " degrees");
    }
  }
  for (int i = 0; i < 2; ++i) {
    const double a = side[i], b = side[i + 2];
    if (std::max(a, b) > options.max_side_ratio * std::min(a, b)) {
      return InvalidArgumentError("the photo's outline is sheared (opposite sides " +
                                  std::to_string(a) + " and " + std::to_string(b) + " px)");
    }
  }
  return OkStatus();
}

StatusOr<int> CountGoodMatches(const ObjectModel& model, const FrameFeatures& keyframe,
                               const FeatureMatcherOptions& matcher) {
  int best = 0;
  for (const ModelView& view : model.views) {
    SEMMAP_ASSIGN_OR_RETURN(
        const std::vector<cv::DMatch> matches,
        MatchDescriptors(view.features.descriptors, keyframe.descriptors, matcher));
    best = std::max(best, static_cast<int>(matches.size()));
  }
  return best;
}

StatusOr<KeyframeDetections> DetectObjects(const FrameFeatures& keyframe,
                                           const CameraCalibration& camera,
                                           const std::vector<ObjectModel>& models,
                                           const ObjectRecognitionOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera));
  SEMMAP_RETURN_IF_ERROR(CheckFeatures(keyframe, "keyframe features"));
  SEMMAP_RETURN_IF_ERROR(CheckModels(models, keyframe));
  KeyframeDetections out;
  out.good_matches.assign(models.size(), 0);
  for (size_t m = 0; m < models.size(); ++m) {
    const ObjectModel& model = models[m];
    ObjectDetection best;
    bool found = false;
    for (size_t v = 0; v < model.views.size(); ++v) {
      const ModelView& view = model.views[v];
      SEMMAP_ASSIGN_OR_RETURN(
          const std::vector<cv::DMatch> matches,
          MatchDescriptors(view.features.descriptors, keyframe.descriptors, options.matcher));
      const int good = static_cast<int>(matches.size());
      out.good_matches[m] = std::max(out.good_matches[m], good);
      if (good < options.min_good_matches) continue;  // the common case: not in view
      ObjectDetection candidate;
      SEMMAP_ASSIGN_OR_RETURN(const bool detected,
                              VerifyView(view, keyframe, camera, matches, options, &candidate));
      if (!detected || (found && candidate.inliers <= best.inliers)) continue;
      candidate.view_index = static_cast<int>(v);
      best = std::move(candidate);
      found = true;
    }
    if (!found) continue;
    best.model_index = static_cast<int>(m);
    best.type_id = model.type_id;
    best.label = model.label;
    out.detections.push_back(std::move(best));
  }
  return out;
}

ObjectObservation ToObservation(const ObjectDetection& detection, double xi) {
  ObjectObservation o;
  o.type_id = detection.type_id;
  o.label = detection.label;
  o.p_keyframe = detection.p_keyframe;
  o.extent = detection.extent;
  o.matches = detection.matches;
  o.inliers = detection.inliers;
  o.xi = xi;
  return o;
}

}  // namespace semmap
