#include "client/eval/plot.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "client/eval/plot_canvas.h"
#include "core/sensor/image_encoding.h"

namespace semmap {
namespace {

using eval_internal::Chart;
using eval_internal::LegendEntry;

// BGR.
const cv::Scalar kGreen(40, 160, 0);
const cv::Scalar kBlue(200, 90, 20);
const cv::Scalar kRed(40, 40, 220);
const cv::Scalar kOrange(0, 140, 255);
const cv::Scalar kBlack(0, 0, 0);

std::string FormatMetres(double v) {
  char text[64];
  if (v >= 0.001 || v == 0) {
    std::snprintf(text, sizeof(text), "%.4f m", v);
  } else {
    std::snprintf(text, sizeof(text), "%.3g m", v);
  }
  return text;
}

std::string Title(const PlotOptions& options, const std::string& body) {
  return options.title.empty() ? body : options.title + ": " + body;
}

// Splits a polyline where consecutive stamps are more than kGapIntervals median intervals apart
// (a dropped frame or two does not break the line; a pause in the recording does).
constexpr int64_t kGapIntervals = 5;
constexpr size_t kMaxDifferenceLines = 400;
std::vector<std::vector<cv::Point2d>> SplitAtGaps(const std::vector<int64_t>& stamps_ns,
                                                  const std::vector<cv::Point2d>& points) {
  std::vector<std::vector<cv::Point2d>> runs;
  if (points.empty()) return runs;
  std::vector<int64_t> intervals;
  for (size_t i = 1; i < stamps_ns.size(); ++i)
    intervals.push_back(stamps_ns[i] - stamps_ns[i - 1]);
  int64_t limit = 0;
  if (!intervals.empty()) {
    std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
    limit = kGapIntervals * intervals[intervals.size() / 2];
  }
  runs.emplace_back();
  for (size_t i = 0; i < points.size(); ++i) {
    if (i > 0 && limit > 0 && stamps_ns[i] - stamps_ns[i - 1] > limit) runs.emplace_back();
    runs.back().push_back(points[i]);
  }
  return runs;
}

// At most `limit` evenly spaced points (for legend placement).
std::vector<cv::Point2d> Subsample(const std::vector<cv::Point2d>& points, size_t limit) {
  if (points.size() <= limit) return points;
  std::vector<cv::Point2d> out;
  const double step = static_cast<double>(points.size()) / static_cast<double>(limit);
  for (size_t k = 0; k < limit; ++k) out.push_back(points[static_cast<size_t>(k * step)]);
  return out;
}

Status CheckRenderable(const AteResult& ate, const PlotOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (ate.pairs.empty() || ate.ground_truth.empty()) {
    return InvalidArgumentError("nothing to plot: the ATE result has no pairs");
  }
  return OkStatus();
}

Status WritePng(const cv::Mat& image, const std::string& path) {
  SEMMAP_ASSIGN_OR_RETURN(const std::string bytes, EncodePng(image));
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) return UnavailableError(path + ": cannot create: " + std::strerror(errno));
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  file.close();
  if (!file) return UnavailableError(path + ": write failed");
  return OkStatus();
}

}  // namespace

Status PlotOptions::Validate() const {
  if (width < 300 || width > 8000 || height < 200 || height > 8000) {
    return InvalidArgumentError("plot size must be within 300..8000 x 200..8000 pixels, got " +
                                std::to_string(width) + "x" + std::to_string(height));
  }
  return OkStatus();
}

namespace {

cv::Mat DrawTrajectory(const AteResult& ate, const PlotOptions& options) {
  // The two axes along which the ground truth extends most, in x, y, z order.
  Eigen::Vector3d lo = ate.ground_truth.front().T_world_camera.translation();
  Eigen::Vector3d hi = lo;
  for (const StampedPose& p : ate.ground_truth) {
    lo = lo.cwiseMin(p.T_world_camera.translation());
    hi = hi.cwiseMax(p.T_world_camera.translation());
  }
  const Eigen::Vector3d extent = hi - lo;
  int dropped = 0;  // the axis of least extent
  for (int k = 1; k < 3; ++k) {
    if (extent(k) < extent(dropped)) dropped = k;
  }
  const int u = dropped == 0 ? 1 : 0;
  const int v = dropped == 2 ? 1 : 2;
  const std::array<const char*, 3> names = {"x", "y", "z"};
  const auto project = [&](const Eigen::Vector3d& p) { return cv::Point2d(p(u), p(v)); };

  std::vector<cv::Point2d> gt_points, est_points;
  std::vector<int64_t> gt_stamps, est_stamps;
  for (const StampedPose& p : ate.ground_truth) {
    gt_points.push_back(project(p.T_world_camera.translation()));
    gt_stamps.push_back(p.stamp_ns);
  }
  for (const StampedPose& p : ate.aligned_estimate) {
    est_points.push_back(project(p.T_world_camera.translation()));
    est_stamps.push_back(p.stamp_ns);
  }
  double x_min = gt_points[0].x, x_max = x_min, y_min = gt_points[0].y, y_max = y_min;
  for (const auto* set : {&gt_points, &est_points}) {
    for (const cv::Point2d& p : *set) {
      x_min = std::min(x_min, p.x);
      x_max = std::max(x_max, p.x);
      y_min = std::min(y_min, p.y);
      y_max = std::max(y_max, p.y);
    }
  }
  const double pad = 0.05 * std::max(x_max - x_min, y_max - y_min);
  Chart chart(options.width, options.height);
  chart.SetRange(x_min - pad, x_max + pad, y_min - pad, y_max + pad, /*equal_aspect=*/true);

  std::string body = "ATE RMSE " + FormatMetres(ate.stats.rmse) + ", " +
                     std::to_string(ate.pairs.size()) + " pairs";
  if (ate.scale_estimated) {
    char scale[48];
    std::snprintf(scale, sizeof(scale), ", scale %.4f", ate.alignment.scale);
    body += scale;
  }
  chart.DrawAxes(std::string(names[u]) + " [m]", std::string(names[v]) + " [m]",
                 Title(options, body));
  for (const auto& run : SplitAtGaps(gt_stamps, gt_points)) chart.DrawPolyline(run, kGreen, 2);
  for (const auto& run : SplitAtGaps(est_stamps, est_points)) chart.DrawPolyline(run, kBlue, 2);
  // Difference lines on top; at most ~kMaxDifferenceLines of them, evenly spaced, so that a long
  // trajectory does not turn into a red band.
  const size_t stride = (ate.pairs.size() + kMaxDifferenceLines - 1) / kMaxDifferenceLines;
  for (size_t k = 0; k < ate.pairs.size(); k += stride) {
    chart.DrawSegment(project(ate.pairs[k].gt_position), project(ate.pairs[k].est_position_aligned),
                      kRed, 1);
  }
  const std::string difference_label =
      stride == 1 ? "difference" : "difference (1 in " + std::to_string(stride) + " pairs)";
  chart.DrawMarker(gt_points.front(), kBlack, 6);

  std::vector<cv::Point2d> avoid = Subsample(gt_points, 4000);
  const std::vector<cv::Point2d> est_sample = Subsample(est_points, 4000);
  avoid.insert(avoid.end(), est_sample.begin(), est_sample.end());
  chart.DrawLegend(
      {{kGreen, "ground truth", 2},
       {kBlue, ate.scale_estimated ? "estimate (Sim(3)-aligned)" : "estimate (aligned)", 2},
       {kRed, difference_label, 1},
       {kBlack, "start", 2, false, /*marker=*/true}},
      avoid);
  return chart.image().clone();
}

cv::Mat DrawErrors(const AteResult& ate, const PlotOptions& options) {
  const int64_t t0 = ate.pairs.front().gt_stamp_ns;
  std::vector<cv::Point2d> points;
  std::vector<int64_t> stamps;
  for (const AtePair& pair : ate.pairs) {
    points.emplace_back(static_cast<double>(pair.gt_stamp_ns - t0) * 1e-9, pair.error_m);
    stamps.push_back(pair.gt_stamp_ns);
  }
  const double t_max = points.back().x;
  const double e_max = std::max(ate.stats.max, 1e-9);
  Chart chart(options.width, options.height);
  chart.SetRange(0, t_max > 0 ? t_max : 1, 0, 1.08 * e_max, /*equal_aspect=*/false);
  chart.DrawAxes(
      "time [s]", "error [m]",
      Title(options, "ATE per pose over time (" + std::to_string(ate.pairs.size()) + " pairs)"));
  chart.DrawPolyline({{0, ate.stats.rmse}, {t_max > 0 ? t_max : 1, ate.stats.rmse}}, kOrange, 2,
                     /*dashed=*/true);
  for (const auto& run : SplitAtGaps(stamps, points)) chart.DrawPolyline(run, kBlue, 2);
  chart.DrawLegend({{kBlue, "error of each pose", 2},
                    {kOrange, "RMSE " + FormatMetres(ate.stats.rmse), 2, /*dashed=*/true}},
                   Subsample(points, 4000));
  return chart.image().clone();
}

}  // namespace

StatusOr<cv::Mat> RenderTrajectoryPlot(const AteResult& ate, const PlotOptions& options) {
  SEMMAP_RETURN_IF_ERROR(CheckRenderable(ate, options));
  try {
    return DrawTrajectory(ate, options);
  } catch (const std::exception& e) {
    return InternalError(std::string("drawing the trajectory plot failed: ") + e.what());
  }
}

StatusOr<cv::Mat> RenderErrorPlot(const AteResult& ate, const PlotOptions& options) {
  SEMMAP_RETURN_IF_ERROR(CheckRenderable(ate, options));
  try {
    return DrawErrors(ate, options);
  } catch (const std::exception& e) {
    return InternalError(std::string("drawing the error plot failed: ") + e.what());
  }
}

Status PlotTrajectory(const AteResult& ate, const std::string& png_path,
                      const PlotOptions& options) {
  SEMMAP_ASSIGN_OR_RETURN(const cv::Mat image, RenderTrajectoryPlot(ate, options));
  return WritePng(image, png_path);
}

Status PlotErrors(const AteResult& ate, const std::string& png_path, const PlotOptions& options) {
  SEMMAP_ASSIGN_OR_RETURN(const cv::Mat image, RenderErrorPlot(ate, options));
  return WritePng(image, png_path);
}

}  // namespace semmap
