#include "core/slam/loop_verifier.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "common/xi_check.h"

namespace semmap {
namespace {

// Per-keypoint arrays of one size, and descriptors comparable with the query's. Checked here
// rather than left to MatchDescriptors, which sees only the keypoints with depth (none may
// have depth) and would index out of range on short arrays.
Status CheckFeatures(const FrameFeatures& f, const std::string& name, const FrameFeatures& query) {
  const size_t n = f.keypoints.size();
  if (f.points_camera.size() != n || f.has_depth.size() != n ||
      (n > 0 && static_cast<size_t>(f.descriptors.rows) != n)) {
    return InvalidArgumentError("loop " + name + " features: " + std::to_string(n) +
                                " keypoints but " + std::to_string(f.descriptors.rows) +
                                " descriptors, " + std::to_string(f.points_camera.size()) +
                                " points, " + std::to_string(f.has_depth.size()) + " depth flags");
  }
  const cv::Mat& d = f.descriptors;
  const cv::Mat& q = query.descriptors;
  if (!d.empty() && !q.empty() && (d.type() != q.type() || d.cols != q.cols)) {
    return InvalidArgumentError("loop " + name +
                                ": descriptor types or widths differ from the query's");
  }
  return OkStatus();
}

// One solve of the query's 2D keypoints against another keyframe's 3D points.
struct Solve {
  int num_matches = 0;
  std::vector<std::pair<int, int>> matches;  // (query keypoint, other keypoint), solve order
  std::optional<MotionEstimate> estimate;    // nullopt: too little support for a pose
  int inliers() const { return estimate ? static_cast<int>(estimate->inliers.size()) : 0; }
};

// As RgbdTracker: only the other keyframe's keypoints with depth are matched (the rest could
// not enter PnP), which also makes the brute-force matching cheaper.
// Below `min_matches` no solve is tried (it could not pass), and the count is 0.
StatusOr<Solve> SolveAgainst(const FrameFeatures& query, const FrameFeatures& other,
                             const CameraCalibration& camera, const LoopVerifierOptions& options,
                             int min_matches) {
  std::vector<int> depth_index;
  depth_index.reserve(other.size());
  for (size_t i = 0; i < other.size(); ++i) {
    if (other.has_depth[i]) depth_index.push_back(static_cast<int>(i));
  }
  cv::Mat depth_descriptors(static_cast<int>(depth_index.size()), other.descriptors.cols,
                            other.descriptors.type());
  for (size_t r = 0; r < depth_index.size(); ++r) {
    other.descriptors.row(depth_index[r]).copyTo(depth_descriptors.row(static_cast<int>(r)));
  }
  SEMMAP_ASSIGN_OR_RETURN(std::vector<cv::DMatch> matches,
                          MatchDescriptors(depth_descriptors, query.descriptors, options.matcher));
  Solve solve;
  solve.num_matches = static_cast<int>(matches.size());
  if (solve.num_matches < min_matches) return solve;
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Point2f> pixels;
  points.reserve(matches.size());
  pixels.reserve(matches.size());
  solve.matches.reserve(matches.size());
  for (const cv::DMatch& m : matches) {
    const int other_keypoint = depth_index[static_cast<size_t>(m.queryIdx)];
    points.push_back(other.points_camera[static_cast<size_t>(other_keypoint)]);
    pixels.push_back(query.keypoints[static_cast<size_t>(m.trainIdx)].pt);
    solve.matches.emplace_back(m.trainIdx, other_keypoint);
  }
  StatusOr<MotionEstimate> estimate = EstimateMotion(points, pixels, camera, options.motion);
  if (estimate.ok()) {
    solve.estimate = std::move(estimate).value();
  } else if (estimate.status().code() != StatusCode::kFailedPrecondition) {
    return estimate.status();  // a real failure, not just too little support
  }
  return solve;
}

}  // namespace

Status LoopVerifierOptions::Validate() const {
  SEMMAP_RETURN_IF_ERROR(matcher.Validate());
  SEMMAP_RETURN_IF_ERROR(motion.Validate());
  if (min_inliers < motion.min_inliers) {
    return InvalidArgumentError("loop min_inliers must be >= motion.min_inliers");
  }
  if (!std::isfinite(max_rms_px) || max_rms_px <= 0) {
    return InvalidArgumentError("loop max_rms_px must be positive");
  }
  if (!std::isfinite(min_inlier_ratio) || min_inlier_ratio < 0 || min_inlier_ratio > 1) {
    return InvalidArgumentError("loop min_inlier_ratio must be in [0, 1]");
  }
  if (!std::isfinite(max_xi) || max_xi <= 0) {
    return InvalidArgumentError("loop max_xi must be positive");
  }
  return OkStatus();
}

std::string_view LoopDecisionName(LoopDecision d) {
  switch (d) {
    case LoopDecision::kAccepted:
      return "accepted";
    case LoopDecision::kTooFewMatches:
      return "too few matches";
    case LoopDecision::kGeometryFailed:
      return "geometry failed";
    case LoopDecision::kXiTooHigh:
      return "xi too high";
    case LoopDecision::kNoNeighbours:
      return "no neighbours";
  }
  return "unknown";
}

LoopDecision DecideGeometry(int num_matches, int candidate_inliers, double rms_px,
                            const LoopVerifierOptions& options) {
  if (num_matches < std::max(options.min_inliers, options.motion.min_matches)) {
    return LoopDecision::kTooFewMatches;
  }
  if (candidate_inliers < options.min_inliers || !(rms_px <= options.max_rms_px) ||
      candidate_inliers < options.min_inlier_ratio * num_matches) {
    return LoopDecision::kGeometryFailed;
  }
  return LoopDecision::kAccepted;
}

namespace {

LoopDecision ToLoopDecision(const XiDecision& xi) {
  if (xi.accepted()) return LoopDecision::kAccepted;
  return xi.verdict == XiVerdict::kNoNeighbours ? LoopDecision::kNoNeighbours
                                                : LoopDecision::kXiTooHigh;
}

}  // namespace

LoopDecision DecideXi(int candidate_inliers, int neighbour_inliers, int num_neighbours,
                      const LoopVerifierOptions& options) {
  return ToLoopDecision(
      CheckXi(candidate_inliers,
              num_neighbours > 0 ? std::vector<int>{neighbour_inliers} : std::vector<int>{},
              options.max_xi, options.allow_without_neighbours));
}

StatusOr<LoopVerification> VerifyLoopCandidate(const FrameFeatures& query,
                                               const FrameFeatures& candidate,
                                               const std::vector<const FrameFeatures*>& neighbours,
                                               const CameraCalibration& camera,
                                               const LoopVerifierOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera).WithContext("loop verifier camera"));
  SEMMAP_RETURN_IF_ERROR(CheckFeatures(query, "query", query));
  SEMMAP_RETURN_IF_ERROR(CheckFeatures(candidate, "candidate", query));
  // Checked up front, so that a bad neighbour is an error even when geometry rejects first.
  for (size_t i = 0; i < neighbours.size(); ++i) {
    if (neighbours[i] == nullptr) {
      return InvalidArgumentError("loop neighbour " + std::to_string(i) + " is null");
    }
    SEMMAP_RETURN_IF_ERROR(CheckFeatures(*neighbours[i], "neighbour " + std::to_string(i), query));
  }

  LoopVerification out;
  // The candidate must reach min_inliers, so fewer matches cannot pass; a neighbour only has
  // to support it, so any solve EstimateMotion accepts counts.
  SEMMAP_ASSIGN_OR_RETURN(const Solve c,
                          SolveAgainst(query, candidate, camera, options,
                                       std::max(options.min_inliers, options.motion.min_matches)));
  out.num_matches = c.num_matches;
  out.candidate_inliers = c.inliers();
  if (c.estimate) {
    out.rms_px = c.estimate->rms_reprojection_px;
    out.T_candidate_query = c.estimate->T_reference_current;
    out.information = c.estimate->information;
    out.inlier_matches.reserve(c.estimate->inliers.size());
    for (int i : c.estimate->inliers)
      out.inlier_matches.push_back(c.matches[static_cast<size_t>(i)]);
  }
  out.decision = DecideGeometry(out.num_matches, out.candidate_inliers, out.rms_px, options);
  if (!out.accepted()) return out;  // each neighbour costs a full descriptor match: skip them

  // N_n is the maximum over the neighbours, not their mean or sum. The query revisits one
  // place, so usually one neighbour (the one on the query's side of the candidate) shares
  // about as much of its view as the candidate does, while the others see less. On rendered
  // revisits with neighbours one keyframe step apart, xi with the maximum was 0.6-1.36; with
  // the mean 0.86-1.39 for two neighbours and up to 1.7 for four (farther neighbours drag it
  // down, so the mean rejects more true revisits the more neighbours are passed). The sum
  // stayed below 1 with four neighbours in every case, even where the best of them had under
  // 60% of the candidate's inliers (xi 1.7-2.4 by the maximum): it rejects little, and its
  // scale changes with the number of neighbours.
  for (const FrameFeatures* n : neighbours) {
    SEMMAP_ASSIGN_OR_RETURN(const Solve s,
                            SolveAgainst(query, *n, camera, options, options.motion.min_matches));
    out.inliers_per_neighbour.push_back(s.inliers());
    out.neighbour_inliers = std::max(out.neighbour_inliers, s.inliers());
  }
  const XiDecision xi = CheckXi(out.candidate_inliers, out.inliers_per_neighbour, options.max_xi,
                                options.allow_without_neighbours);
  out.xi = xi.xi;
  out.decision = ToLoopDecision(xi);
  return out;
}

}  // namespace semmap
