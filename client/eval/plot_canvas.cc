#include "client/eval/plot_canvas.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

namespace semmap::eval_internal {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_DUPLEX;
constexpr double kTickScale = 0.5;
constexpr double kLabelScale = 0.6;
constexpr double kTitleScale = 0.75;
constexpr int kShift = 4;  // sub-pixel bits for OpenCV drawing
constexpr double kSubPixel = 1 << kShift;
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(228, 228, 228);
const cv::Scalar kWhite(255, 255, 255);

cv::Point Fixed(const cv::Point2d& p) {
  return {static_cast<int>(std::lround(p.x * kSubPixel)),
          static_cast<int>(std::lround(p.y * kSubPixel))};
}

// Keeps pixel coordinates in a range OpenCV's fixed-point drawing handles.
cv::Point2d Clamp(const cv::Point2d& p) {
  constexpr double kLimit = 1e6;
  return {std::clamp(p.x, -kLimit, kLimit), std::clamp(p.y, -kLimit, kLimit)};
}

}  // namespace

Ticks NiceTicks(double min, double max, int target) {
  Ticks t;
  const double span = max - min;
  if (!(span > 0) || !std::isfinite(span) || target < 1) {
    t.values = {min};
    return t;
  }
  const double raw = span / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double normalised = raw / magnitude;
  const double factor = normalised < 1.5 ? 1 : normalised < 3.5 ? 2 : normalised < 7.5 ? 5 : 10;
  t.step = factor * magnitude;
  t.decimals = std::max(0, static_cast<int>(-std::floor(std::log10(t.step) + 1e-9)));
  const double first = std::ceil(min / t.step - 1e-9);
  for (int j = 0; j < 1000; ++j) {  // bounded: k + 1 == k for huge k
    const double value = (first + j) * t.step;
    if (value > max + 1e-9 * t.step) break;
    t.values.push_back(value);
  }
  return t;
}

std::string FormatTick(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  std::string s = text;
  // "-0.0" and the like read as zero.
  if (s.find_first_not_of("-0.") == std::string::npos && s[0] == '-') s.erase(0, 1);
  return s;
}

Chart::Chart(int width, int height)
    : image_(std::max(height, 200), std::max(width, 300), CV_8UC3, kWhite) {
  const int left = 100;
  const int right = 30;
  const int top = 56;
  const int bottom = 72;
  area_ = cv::Rect(left, top, image_.cols - left - right, image_.rows - top - bottom);
}

void Chart::SetRange(double x_min, double x_max, double y_min, double y_max, bool equal_aspect) {
  const auto widen = [](double& lo, double& hi) {
    if (!(hi - lo > 1e-12 * std::max({1.0, std::abs(lo), std::abs(hi)}))) {
      const double pad = std::max(0.5, 1e-6 * std::abs(lo));
      lo -= pad;
      hi += pad;
    }
  };
  widen(x_min, x_max);
  widen(y_min, y_max);
  if (equal_aspect) {
    const double per_metre =
        std::min(area_.width / (x_max - x_min), area_.height / (y_max - y_min));
    const double x_centre = 0.5 * (x_min + x_max);
    const double y_centre = 0.5 * (y_min + y_max);
    const double x_half = 0.5 * area_.width / per_metre;
    const double y_half = 0.5 * area_.height / per_metre;
    x_min = x_centre - x_half;
    x_max = x_centre + x_half;
    y_min = y_centre - y_half;
    y_max = y_centre + y_half;
  }
  x_min_ = x_min;
  x_max_ = x_max;
  y_min_ = y_min;
  y_max_ = y_max;
}

cv::Point2d Chart::ToPixel(const cv::Point2d& data) const {
  const double x = area_.x + (data.x - x_min_) / (x_max_ - x_min_) * area_.width;
  const double y = area_.y + area_.height - (data.y - y_min_) / (y_max_ - y_min_) * area_.height;
  return {x, y};
}

void Chart::PutText(const std::string& text, cv::Point origin, double scale, int thickness,
                    const cv::Scalar& colour) {
  cv::putText(image_, text, origin, kFont, scale, colour, thickness, cv::LINE_AA);
}

void Chart::PutVerticalText(const std::string& text, cv::Point centre, double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  cv::Mat horizontal(size.height + baseline + 4, size.width + 4, CV_8UC3, kWhite);
  cv::putText(horizontal, text, cv::Point(2, size.height + 2), kFont, scale, kBlack, 1,
              cv::LINE_AA);
  cv::Mat vertical;
  cv::rotate(horizontal, vertical, cv::ROTATE_90_COUNTERCLOCKWISE);
  cv::Rect target(centre.x - vertical.cols / 2, centre.y - vertical.rows / 2, vertical.cols,
                  vertical.rows);
  target &= cv::Rect(0, 0, image_.cols, image_.rows);
  vertical(cv::Rect(0, 0, target.width, target.height)).copyTo(image_(target));
}

void Chart::DrawAxes(const std::string& x_label, const std::string& y_label,
                     const std::string& title) {
  const Ticks x_ticks = NiceTicks(x_min_, x_max_, std::max(3, area_.width / 110));
  const Ticks y_ticks = NiceTicks(y_min_, y_max_, std::max(3, area_.height / 90));
  int baseline = 0;
  for (double v : x_ticks.values) {
    const int px = static_cast<int>(std::lround(ToPixel({v, y_min_}).x));
    cv::line(image_, {px, area_.y}, {px, area_.y + area_.height}, kGrid, 1);
    cv::line(image_, {px, area_.y + area_.height}, {px, area_.y + area_.height + 5}, kBlack, 1);
    const std::string label = FormatTick(v, x_ticks.decimals);
    const cv::Size size = cv::getTextSize(label, kFont, kTickScale, 1, &baseline);
    PutText(label, {px - size.width / 2, area_.y + area_.height + 10 + size.height}, kTickScale, 1,
            kBlack);
  }
  for (double v : y_ticks.values) {
    const int py = static_cast<int>(std::lround(ToPixel({x_min_, v}).y));
    cv::line(image_, {area_.x, py}, {area_.x + area_.width, py}, kGrid, 1);
    cv::line(image_, {area_.x - 5, py}, {area_.x, py}, kBlack, 1);
    const std::string label = FormatTick(v, y_ticks.decimals);
    const cv::Size size = cv::getTextSize(label, kFont, kTickScale, 1, &baseline);
    PutText(label, {area_.x - 9 - size.width, py + size.height / 2}, kTickScale, 1, kBlack);
  }
  cv::rectangle(image_, area_, kBlack, 1);

  const cv::Size x_size = cv::getTextSize(x_label, kFont, kLabelScale, 1, &baseline);
  PutText(x_label, {area_.x + (area_.width - x_size.width) / 2, image_.rows - 14}, kLabelScale, 1,
          kBlack);
  PutVerticalText(y_label, {22, area_.y + area_.height / 2}, kLabelScale);
  const cv::Size t_size = cv::getTextSize(title, kFont, kTitleScale, 1, &baseline);
  PutText(title, {std::max(4, (image_.cols - t_size.width) / 2), 36}, kTitleScale, 1, kBlack);
}

void Chart::DrawPolyline(const std::vector<cv::Point2d>& points, const cv::Scalar& colour,
                         int thickness, bool dashed) {
  if (points.empty()) return;
  cv::Mat area = image_(area_);
  const cv::Point2d offset(area_.x, area_.y);
  std::vector<cv::Point> pixels;
  pixels.reserve(points.size());
  for (const cv::Point2d& p : points) pixels.push_back(Fixed(Clamp(ToPixel(p) - offset)));
  if (points.size() == 1) {
    cv::circle(area, pixels[0], thickness * static_cast<int>(kSubPixel), colour, cv::FILLED,
               cv::LINE_AA, kShift);
    return;
  }
  if (!dashed) {
    cv::polylines(area, pixels, false, colour, thickness, cv::LINE_AA, kShift);
    return;
  }
  // Dashes of 10 px with 6 px gaps, continuing across vertices.
  constexpr double kOn = 10 * kSubPixel;
  constexpr double kPeriod = 16 * kSubPixel;
  double phase = 0;
  for (size_t i = 0; i + 1 < pixels.size(); ++i) {
    const cv::Point2d a(pixels[i]);
    const cv::Point2d b(pixels[i + 1]);
    const double length = cv::norm(b - a);
    double s = 0;
    while (s < length) {
      const double in_period = std::fmod(phase + s, kPeriod);
      const double run = in_period < kOn ? kOn - in_period : kPeriod - in_period;
      const double e = std::min(length, s + run);
      if (in_period < kOn) {
        const cv::Point2d p = a + (b - a) * (s / length);
        const cv::Point2d q = a + (b - a) * (e / length);
        cv::line(area, cv::Point(cvRound(p.x), cvRound(p.y)), cv::Point(cvRound(q.x), cvRound(q.y)),
                 colour, thickness, cv::LINE_AA, kShift);
      }
      s = e;
    }
    phase += length;
  }
}

void Chart::DrawSegment(const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour,
                        int thickness) {
  cv::Mat area = image_(area_);
  const cv::Point2d offset(area_.x, area_.y);
  cv::line(area, Fixed(Clamp(ToPixel(a) - offset)), Fixed(Clamp(ToPixel(b) - offset)), colour,
           thickness, cv::LINE_AA, kShift);
}

void Chart::DrawMarker(const cv::Point2d& p, const cv::Scalar& colour, int radius) {
  cv::Mat area = image_(area_);
  const cv::Point2d offset(area_.x, area_.y);
  cv::circle(area, Fixed(Clamp(ToPixel(p) - offset)), radius * static_cast<int>(kSubPixel), colour,
             2, cv::LINE_AA, kShift);
}

void Chart::DrawLegend(const std::vector<LegendEntry>& entries,
                       const std::vector<cv::Point2d>& avoid) {
  if (entries.empty()) return;
  constexpr int kRow = 24;
  constexpr int kSample = 34;
  int baseline = 0;
  int text_width = 0;
  for (const LegendEntry& e : entries) {
    text_width =
        std::max(text_width, cv::getTextSize(e.label, kFont, kTickScale, 1, &baseline).width);
  }
  const cv::Size box(kSample + 26 + text_width, static_cast<int>(entries.size()) * kRow + 12);
  constexpr int kInset = 10;
  const std::array<cv::Point, 4> corners = {
      cv::Point(area_.x + area_.width - kInset - box.width, area_.y + kInset),  // top right
      cv::Point(area_.x + kInset, area_.y + kInset),                            // top left
      cv::Point(area_.x + area_.width - kInset - box.width,
                area_.y + area_.height - kInset - box.height),                    // bottom right
      cv::Point(area_.x + kInset, area_.y + area_.height - kInset - box.height),  // bottom left
  };
  size_t best = 0;
  size_t best_count = static_cast<size_t>(-1);
  for (size_t c = 0; c < corners.size(); ++c) {
    const cv::Rect rect(corners[c], box);
    size_t count = 0;
    for (const cv::Point2d& p : avoid) {
      const cv::Point2d px = ToPixel(p);
      if (rect.contains(cv::Point(static_cast<int>(px.x), static_cast<int>(px.y)))) ++count;
    }
    if (count < best_count) {
      best_count = count;
      best = c;
    }
  }
  const cv::Rect rect(corners[best], box);
  cv::rectangle(image_, rect, kWhite, cv::FILLED);
  cv::rectangle(image_, rect, cv::Scalar(150, 150, 150), 1);
  for (size_t i = 0; i < entries.size(); ++i) {
    const LegendEntry& e = entries[i];
    const int y = rect.y + 6 + static_cast<int>(i) * kRow + kRow / 2;
    const cv::Point a(rect.x + 10, y);
    const cv::Point b(rect.x + 10 + kSample, y);
    if (e.marker) {
      cv::circle(image_, (a + b) / 2, 6, e.colour, 2, cv::LINE_AA);
    } else if (e.dashed) {
      cv::line(image_, a, a + cv::Point(12, 0), e.colour, e.thickness, cv::LINE_AA);
      cv::line(image_, b - cv::Point(12, 0), b, e.colour, e.thickness, cv::LINE_AA);
    } else {
      cv::line(image_, a, b, e.colour, e.thickness, cv::LINE_AA);
    }
    const cv::Size size = cv::getTextSize(e.label, kFont, kTickScale, 1, &baseline);
    PutText(e.label, {b.x + 12, y + size.height / 2}, kTickScale, 1, kBlack);
  }
}

}  // namespace semmap::eval_internal
