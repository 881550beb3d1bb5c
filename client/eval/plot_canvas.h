// A minimal 2-D chart on an OpenCV image: axes with "nice" ticks and labels, a title, a legend,
// polylines in data coordinates. Internal to semmap_eval (the figures are in plot.h).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace semmap::eval_internal {

// Ticks at multiples of 1, 2 or 5 x 10^k covering [min, max] with about `target` intervals.
struct Ticks {
  double step = 1;
  std::vector<double> values;
  int decimals = 0;  // enough to tell neighbouring ticks apart
};
Ticks NiceTicks(double min, double max, int target);
std::string FormatTick(double value, int decimals);

struct LegendEntry {
  cv::Scalar colour;
  std::string label;
  int thickness = 2;
  bool dashed = false;
  bool marker = false;  // a circle instead of a line sample
};

class Chart {
 public:
  // A white width x height image; the plot area leaves margins for labels and the title.
  Chart(int width, int height);

  // Sets the data range shown in the plot area. With `equal_aspect`, the smaller range grows
  // (about its centre) so one metre has the same length on both axes.
  void SetRange(double x_min, double x_max, double y_min, double y_max, bool equal_aspect);

  // Grid, frame, ticks, tick labels, axis labels and the title.
  void DrawAxes(const std::string& x_label, const std::string& y_label, const std::string& title);

  // Data-space polyline, clipped to the plot area, anti-aliased.
  void DrawPolyline(const std::vector<cv::Point2d>& points, const cv::Scalar& colour, int thickness,
                    bool dashed = false);
  void DrawSegment(const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour,
                   int thickness);
  void DrawMarker(const cv::Point2d& p, const cv::Scalar& colour, int radius);

  // A boxed legend in the plot-area corner that covers the fewest of `avoid` (data points).
  void DrawLegend(const std::vector<LegendEntry>& entries, const std::vector<cv::Point2d>& avoid);

  cv::Point2d ToPixel(const cv::Point2d& data) const;
  const cv::Mat& image() const { return image_; }
  const cv::Rect& plot_area() const { return area_; }

 private:
  void PutText(const std::string& text, cv::Point origin, double scale, int thickness,
               const cv::Scalar& colour);
  void PutVerticalText(const std::string& text, cv::Point centre, double scale);

  cv::Mat image_;
  cv::Rect area_;
  double x_min_ = 0, x_max_ = 1, y_min_ = 0, y_max_ = 1;
};

}  // namespace semmap::eval_internal
