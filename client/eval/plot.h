// Figures of an ATE evaluation, drawn with OpenCV and written as PNG.
//  - Trajectory: top view on the plane of the two ground-truth axes with the largest extent
//    (equal scale on both), ground truth green, aligned estimate blue, red lines joining the
//    associated poses (at most ~400, evenly spaced), metric axes with ticks, a legend and the
//    ATE RMSE in the title. Lines break where a trajectory has a gap of more than five median
//    stamp intervals (the TUM script breaks at two, which splits lines at every dropped frame).
//  - Errors: the per-pair error (m) over time (s since the first pair), with the RMSE as a
//    dashed line.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "client/eval/ate.h"
#include "common/status.h"

namespace semmap {

struct PlotOptions {
  int width = 1000;   // pixels, 300..8000
  int height = 800;   // pixels, 200..8000
  std::string title;  // optional prefix of the title (e.g. the sequence name)

  Status Validate() const;
};

// The figures as BGR images (for tests and callers that compose their own output).
StatusOr<cv::Mat> RenderTrajectoryPlot(const AteResult& ate, const PlotOptions& options = {});
StatusOr<cv::Mat> RenderErrorPlot(const AteResult& ate, const PlotOptions& options = {});

// Render and write a PNG. INVALID_ARGUMENT for bad options or a result without pairs,
// UNAVAILABLE when the file cannot be written.
Status PlotTrajectory(const AteResult& ate, const std::string& png_path,
                      const PlotOptions& options = {});
Status PlotErrors(const AteResult& ate, const std::string& png_path,
                  const PlotOptions& options = {});

}  // namespace semmap
