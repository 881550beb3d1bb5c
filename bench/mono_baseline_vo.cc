// The classical monocular baseline of issue 13's bench: keyframe-based monocular VO as the
// textbooks build it. Initialisation by the five-point essential matrix (ORB, ratio test,
// RANSAC, recoverPose) once the first pair has enough parallax, its points triangulated; then
// every frame by PnP-RANSAC against the current reference keyframe's triangulated points, and a
// new reference (points triangulated from both known poses) whenever the view has moved on.
// Monocular geometry cannot know the metric scale: the first baseline has unit length and the
// caller aligns the scale to ground truth (semmap eval ate --scale), the best case for
// classical monocular VO.
//
//   mono_baseline_vo DATASET_DIR OUT_TUM_FILE
#include <algorithm>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

#include "client/datasets/dataset.h"
#include "client/datasets/trajectory_io.h"

namespace {

using semmap::StampedPose;

constexpr double kNewReferenceFlowPx = 25;  // median flow that starts a new reference
constexpr int kMinInliers = 15;

struct Keyframe {
  std::vector<cv::KeyPoint> keypoints;
  std::vector<cv::Point2f> undistorted;
  cv::Mat descriptors;
  std::vector<std::optional<Eigen::Vector3d>> points;  // per keypoint, world frame
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

cv::Matx34d Projection(const cv::Matx33d& K, const Eigen::Isometry3d& T_world_camera) {
  const Eigen::Isometry3d T_camera_world = T_world_camera.inverse();
  cv::Matx34d P;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) P(r, c) = T_camera_world.linear()(r, c);
    P(r, 3) = T_camera_world.translation()(r);
  }
  return K * P;
}

// Triangulates the matches (a index, b index) between two placed frames into b's points, keeping
// those in front of both cameras that reproject within 2 px.
void Triangulate(const Keyframe& a, Keyframe& b, const std::vector<std::pair<int, int>>& matches,
                 const cv::Matx33d& K) {
  if (matches.empty()) return;
  std::vector<cv::Point2f> pa, pb;
  for (const auto& [ia, ib] : matches) {
    pa.push_back(a.undistorted[static_cast<size_t>(ia)]);
    pb.push_back(b.undistorted[static_cast<size_t>(ib)]);
  }
  cv::Mat X;
  const cv::Matx34d Pa = Projection(K, a.T_world_camera), Pb = Projection(K, b.T_world_camera);
  cv::triangulatePoints(Pa, Pb, pa, pb, X);
  X.convertTo(X, CV_64F);
  for (size_t i = 0; i < matches.size(); ++i) {
    const double w = X.at<double>(3, static_cast<int>(i));
    if (std::abs(w) < 1e-12) continue;
    const Eigen::Vector3d p(X.at<double>(0, static_cast<int>(i)) / w,
                            X.at<double>(1, static_cast<int>(i)) / w,
                            X.at<double>(2, static_cast<int>(i)) / w);
    bool good = true;
    for (const auto& [frame, pixel] : {std::pair<const Keyframe*, cv::Point2f>{&a, pa[i]},
                                       std::pair<const Keyframe*, cv::Point2f>{&b, pb[i]}}) {
      const Eigen::Vector3d q = frame->T_world_camera.inverse() * p;
      if (q.z() <= 0) {
        good = false;
        break;
      }
      const double u = K(0, 0) * q.x() / q.z() + K(0, 2), v = K(1, 1) * q.y() / q.z() + K(1, 2);
      if (std::hypot(u - pixel.x, v - pixel.y) > 2.0) good = false;
    }
    if (good) b.points[static_cast<size_t>(matches[i].second)] = p;
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: mono_baseline_vo DATASET_DIR OUT_TUM_FILE\n");
    return 2;
  }
  semmap::StatusOr<semmap::Dataset> dataset = semmap::OpenDataset(argv[1]);
  if (!dataset.ok()) {
    std::fprintf(stderr, "mono_baseline_vo: %s\n", dataset.status().ToString().c_str());
    return 1;
  }
  const semmap::CameraCalibration& c = dataset->camera;
  const cv::Matx33d K(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  const cv::Mat distortion(1, 5, CV_64F, const_cast<double*>(c.distortion.data()));
  cv::Ptr<cv::ORB> orb = cv::ORB::create(2000);
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<StampedPose> poses;
  std::optional<Keyframe> ref;
  bool initialised = false;
  Eigen::Isometry3d T_world_last = Eigen::Isometry3d::Identity();
  int held = 0;
  int lost_in_a_row = 0;
  int reinitialisations = 0;
  // After a loss, a re-initialisation's unit baseline is given the recent speed (metres per
  // frame at the running scale) times the frames since the reference: the scale carries over
  // roughly, as a classical system's relocalisation-free restart would guess it.
  double speed = 0;
  int frames_since_ref = 0;
  for (const semmap::DatasetFrame& frame : dataset->frames) {
    const cv::Mat grey = cv::imread(frame.colour_path, cv::IMREAD_GRAYSCALE);
    if (grey.empty()) {
      std::fprintf(stderr, "mono_baseline_vo: cannot read %s\n", frame.colour_path.c_str());
      return 1;
    }
    Keyframe cur;
    orb->detectAndCompute(grey, cv::noArray(), cur.keypoints, cur.descriptors);
    std::vector<cv::Point2f> pixels;
    for (const cv::KeyPoint& k : cur.keypoints) pixels.push_back(k.pt);
    if (!pixels.empty())
      cv::undistortPoints(pixels, cur.undistorted, K, distortion, cv::noArray(), K);
    cur.points.resize(cur.keypoints.size());
    if (!ref) {
      ref = std::move(cur);
      poses.push_back({frame.stamp_ns, T_world_last});
      continue;
    }
    std::vector<std::vector<cv::DMatch>> knn;
    if (!cur.descriptors.empty() && !ref->descriptors.empty()) {
      matcher.knnMatch(cur.descriptors, ref->descriptors, knn, 2);
    }
    std::vector<std::pair<int, int>> matches;  // (reference, current)
    std::vector<double> flow;
    for (const auto& m : knn) {
      if (m.size() == 2 && m[0].distance < 0.8F * m[1].distance) {
        matches.emplace_back(m[0].trainIdx, m[0].queryIdx);
        flow.push_back(cv::norm(cur.keypoints[static_cast<size_t>(m[0].queryIdx)].pt -
                                ref->keypoints[static_cast<size_t>(m[0].trainIdx)].pt));
      }
    }
    const double median_flow = Median(flow);
    bool placed = false;
    ++frames_since_ref;
    const bool reinitialise = initialised && lost_in_a_row >= 2;
    if (!initialised || reinitialise) {
      // The first pair with enough parallax: relative pose with a unit baseline.
      const double min_flow = reinitialise ? kNewReferenceFlowPx / 2 : kNewReferenceFlowPx;
      if (matches.size() >= 50 && median_flow >= min_flow) {
        std::vector<cv::Point2f> pa, pb;
        for (const auto& [ia, ib] : matches) {
          pa.push_back(ref->undistorted[static_cast<size_t>(ia)]);
          pb.push_back(cur.undistorted[static_cast<size_t>(ib)]);
        }
        cv::Mat mask, R, t;
        const cv::Mat E = cv::findEssentialMat(pa, pb, K, cv::RANSAC, 0.999, 1.0, mask);
        if (E.rows == 3 && E.cols == 3 && cv::recoverPose(E, pa, pb, K, R, t, mask) >= 30) {
          Eigen::Isometry3d T_cur_ref = Eigen::Isometry3d::Identity();
          for (int r = 0; r < 3; ++r) {
            for (int k = 0; k < 3; ++k) T_cur_ref.linear()(r, k) = R.at<double>(r, k);
            T_cur_ref.translation()(r) = t.at<double>(r);
          }
          if (reinitialise) {
            T_cur_ref.translation() *= std::max(speed, 1e-3) * frames_since_ref;
            ++reinitialisations;
          }
          cur.T_world_camera = ref->T_world_camera * T_cur_ref.inverse();
          Triangulate(*ref, cur, matches, K);
          T_world_last = cur.T_world_camera;
          initialised = placed = true;
          frames_since_ref = 0;
          ref = std::move(cur);
        }
      }
    } else {
      // PnP against the reference's points.
      std::vector<cv::Point3d> object;
      std::vector<cv::Point2d> image;
      std::vector<std::pair<int, int>> with_points;
      for (const auto& [ir, ic] : matches) {
        const std::optional<Eigen::Vector3d>& p = ref->points[static_cast<size_t>(ir)];
        if (!p) continue;
        object.emplace_back(p->x(), p->y(), p->z());
        image.emplace_back(cur.undistorted[static_cast<size_t>(ic)]);
        with_points.emplace_back(ir, ic);
      }
      cv::Mat rvec, tvec, inliers;
      if (object.size() >= static_cast<size_t>(kMinInliers) &&
          cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false, 200, 2.0, 0.999,
                             inliers) &&
          inliers.rows >= kMinInliers) {
        cv::Mat R;
        cv::Rodrigues(rvec, R);
        Eigen::Isometry3d T_cur_world = Eigen::Isometry3d::Identity();
        for (int r = 0; r < 3; ++r) {
          for (int k = 0; k < 3; ++k) T_cur_world.linear()(r, k) = R.at<double>(r, k);
          T_cur_world.translation()(r) = tvec.at<double>(r);
        }
        cur.T_world_camera = T_cur_world.inverse();
        const double step = (T_world_last.inverse() * cur.T_world_camera).translation().norm();
        // A jump far beyond the recent speed is a wrong PnP solution (repeated texture, a stale
        // reference): the frame counts as lost.
        if (speed > 0 && step > 5 * speed * (1 + lost_in_a_row)) {
          ++held;
          ++lost_in_a_row;
          poses.push_back({frame.stamp_ns, T_world_last});
          continue;
        }
        speed = 0.8 * speed + 0.2 * step;
        T_world_last = cur.T_world_camera;
        placed = true;
        if (median_flow >= kNewReferenceFlowPx || inliers.rows < 60) {
          Triangulate(*ref, cur, matches, K);
          frames_since_ref = 0;
          ref = std::move(cur);
        }
      }
    }
    if (!placed) ++held;
    lost_in_a_row = placed || !initialised ? 0 : lost_in_a_row + 1;
    poses.push_back({frame.stamp_ns, T_world_last});
  }
  if (const semmap::Status written = semmap::WriteTumTrajectory(argv[2], poses); !written.ok()) {
    std::fprintf(stderr, "mono_baseline_vo: %s\n", written.ToString().c_str());
    return 1;
  }
  std::printf(
      "mono_baseline_vo: %zu frames, %d held (initialising, or no pose), %d "
      "re-initialisations; scale unknown: align it (semmap eval ate --scale)\n",
      poses.size(), held, reinitialisations);
  return 0;
}
