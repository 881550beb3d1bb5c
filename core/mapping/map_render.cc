#include "core/mapping/map_render.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <new>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <ranges>

#include "core/sensor/image_encoding.h"

namespace semmap {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kFont = cv::FONT_HERSHEY_DUPLEX;
constexpr int kShift = 4;  // sub-pixel bits for OpenCV drawing
constexpr double kSubPixel = 1 << kShift;
constexpr double kMinSpanM = 2.0;  // a room-sized view for a map of one pose
constexpr double kMarginFraction = 0.04;
constexpr double kLowPercentile = 0.01;
constexpr double kHighPercentile = 0.99;
constexpr double kMaxSplatPx = 12;  // for a 1600 px picture
// Without a cloud the oblique grid lies this far below the cameras (a hand-held camera).
constexpr double kDefaultCameraHeightM = 1.2;

// BGR.
const cv::Scalar kWhite(255, 255, 255);
const cv::Vec3b kAreaBackground(246, 246, 246);
const cv::Vec3b kGridColour(218, 218, 218);
const cv::Scalar kOriginGridColour(196, 196, 196);
const cv::Scalar kFrameColour(160, 160, 160);
const cv::Scalar kText(40, 40, 40);
const cv::Scalar kMutedText(110, 110, 110);
const cv::Scalar kTrajectory(30, 30, 225);  // red
const cv::Scalar kKeyframe(45, 45, 45);
const cv::Scalar kLoopEdge(60, 165, 0);  // green

// Pixel sizes below are for a 1600 px picture and scale with it.
struct Layout {
  double ui = 1;
  int title_band = 0;
  int left = 0;
  int right = 0;
  int top = 0;
  int bottom = 0;
};

Layout MakeLayout(int long_side) {
  Layout l;
  l.ui = std::clamp(long_side / 1600.0, 0.55, 5.0);
  const auto px = [&](double v) { return static_cast<int>(std::lround(v * l.ui)); };
  l.title_band = px(46);
  l.left = px(58);
  l.right = px(18);
  l.top = px(8);
  l.bottom = px(34);
  return l;
}

int Px(const Layout& l, double v) { return std::max(1, static_cast<int>(std::lround(v * l.ui))); }

// A cloud point in view coordinates: (right, image_up, toward_viewer) is orthonormal, so
// distances are world distances.
struct ViewPoint {
  float u = 0;
  float v = 0;
  float depth = 0;
  uint32_t index = 0;
};

struct View {
  MapViewProjection projection;
  Layout layout;
  double tilt_rad = 0;
  std::vector<ViewPoint> points;  // after the height clip
  double spacing_m = 0;           // typical distance between neighbouring cloud points
};

std::string Num(size_t i) { return std::to_string(i); }

// Far beyond any map; keeps float view coordinates and pixel arithmetic well-behaved.
constexpr double kMaxCoordinateM = 1e6;

bool Sane(double v) { return std::abs(v) <= kMaxCoordinateM; }  // false for NaN
bool Sane(const Eigen::Vector3d& v) { return Sane(v.x()) && Sane(v.y()) && Sane(v.z()); }
bool Sane(const Eigen::Isometry3d& T) {
  return T.linear().allFinite() && T.linear().cwiseAbs().maxCoeff() <= 2 && Sane(T.translation());
}

Status ValidateInput(const MapRenderInput& in) {
  const std::string bad = " is not finite or beyond 1e6 m";
  for (size_t i = 0; i < in.cloud.size(); ++i) {
    const RenderPoint& p = in.cloud[i];
    if (!Sane(p.x) || !Sane(p.y) || !Sane(p.z)) {
      return InvalidArgumentError("cloud point " + Num(i) + bad);
    }
  }
  for (size_t s = 0; s < in.trajectories.size(); ++s) {
    for (size_t i = 0; i < in.trajectories[s].size(); ++i) {
      if (!Sane(in.trajectories[s][i])) {
        return InvalidArgumentError("trajectory " + Num(s) + " pose " + Num(i) +
                                    " is not a finite rigid pose within 1e6 m");
      }
    }
  }
  for (size_t i = 0; i < in.keyframes.size(); ++i) {
    if (!Sane(in.keyframes[i])) {
      return InvalidArgumentError("keyframe " + Num(i) +
                                  " is not a finite rigid pose within 1e6 m");
    }
  }
  for (size_t i = 0; i < in.loop_edges.size(); ++i) {
    if (!Sane(in.loop_edges[i].first) || !Sane(in.loop_edges[i].second)) {
      return InvalidArgumentError("loop edge " + Num(i) + bad);
    }
  }
  for (size_t i = 0; i < in.objects.size(); ++i) {
    const RenderObject& o = in.objects[i];
    if (!Sane(o.centre) || !Sane(o.extent)) return InvalidArgumentError("object " + Num(i) + bad);
    if ((o.extent.array() < 0).any()) {
      return InvalidArgumentError("object " + Num(i) + " has a negative extent");
    }
  }
  return OkStatus();
}

std::vector<Eigen::Isometry3d> AllCameras(const MapRenderInput& in) {
  std::vector<Eigen::Isometry3d> out;
  for (const auto& t : in.trajectories) out.insert(out.end(), t.begin(), t.end());
  out.insert(out.end(), in.keyframes.begin(), in.keyframes.end());
  return out;
}

const Eigen::Isometry3d* FirstCamera(const MapRenderInput& in) {
  for (const auto& t : in.trajectories) {
    if (!t.empty()) return &t.front();
  }
  return in.keyframes.empty() ? nullptr : &in.keyframes.front();
}

// The ground-plane heading that points up in the picture (see the header).
Eigen::Vector3d GroundForward(const Eigen::Vector3d& up, const Eigen::Isometry3d* first_camera) {
  std::vector<Eigen::Vector3d> candidates;
  if (first_camera != nullptr) {
    candidates.emplace_back(first_camera->linear().col(2));
    candidates.emplace_back(-first_camera->linear().col(1));
  }
  candidates.emplace_back(Eigen::Vector3d::UnitZ());
  candidates.emplace_back(Eigen::Vector3d::UnitX());
  for (const Eigen::Vector3d& c : candidates) {
    const Eigen::Vector3d ground = c - c.dot(up) * up;
    // 0.25: more than ~15 degrees off the vertical, so the heading is meaningful.
    if (ground.norm() > 0.25 * std::max(c.norm(), 1e-12)) return ground.normalized();
  }
  return Eigen::Vector3d::UnitY();  // unreachable: z and x cannot both be parallel to up
}

// Value at fraction q of `values` (reordered).
float Percentile(std::vector<float>& values, double q) {
  const size_t k = static_cast<size_t>(std::lround(q * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

// Median nearest-neighbour distance over a sample of up to 1024 points, from a uniform grid of
// cell `cell` (sorted cell keys): a neighbour within one cell is found exactly, so once more
// than half the samples find one, the median is exact. Exact duplicates are ignored.
double EstimateSpacing(const std::vector<ViewPoint>& pts, double cell) {
  const size_t n = pts.size();
  if (n < 2) return 0;
  constexpr int64_t kHalf = int64_t{1} << 20;  // 21 bits per axis
  const size_t samples = std::min<size_t>(n, 1024);
  const size_t stride = n / samples;
  std::vector<std::pair<uint64_t, uint32_t>> keyed(n);
  std::vector<double> nearest(samples);
  for (int attempt = 0; attempt < 6; ++attempt, cell *= 3) {
    const auto coord = [&](float c) {
      return static_cast<int64_t>(
          std::clamp(std::floor(c / cell), -double(kHalf), double(kHalf - 1)));
    };
    const auto pack = [](int64_t x, int64_t y, int64_t z) {
      return (static_cast<uint64_t>(x + kHalf) << 42) | (static_cast<uint64_t>(y + kHalf) << 21) |
             static_cast<uint64_t>(z + kHalf);
    };
    for (size_t i = 0; i < n; ++i) {
      keyed[i] = {pack(coord(pts[i].u), coord(pts[i].v), coord(pts[i].depth)),
                  static_cast<uint32_t>(i)};
    }
    std::sort(keyed.begin(), keyed.end());
    const double limit = cell * cell;
    for (size_t s = 0; s < samples; ++s) {
      const ViewPoint& p = pts[s * stride];
      const int64_t cx = coord(p.u), cy = coord(p.v), cz = coord(p.depth);
      double best = std::numeric_limits<double>::infinity();
      for (int64_t dx = -1; dx <= 1; ++dx) {
        for (int64_t dy = -1; dy <= 1; ++dy) {
          for (int64_t dz = -1; dz <= 1; ++dz) {
            const int64_t x = cx + dx, y = cy + dy, z = cz + dz;
            if (std::max({std::abs(x), std::abs(y), std::abs(z)}) >= kHalf) continue;
            const uint64_t key = pack(x, y, z);
            auto it =
                std::lower_bound(keyed.begin(), keyed.end(), std::make_pair(key, uint32_t{0}));
            for (; it != keyed.end() && it->first == key; ++it) {
              const ViewPoint& q = pts[it->second];
              const double du = q.u - p.u, dv = q.v - p.v, dd = q.depth - p.depth;
              const double d2 = du * du + dv * dv + dd * dd;
              if (d2 > 0 && d2 < best) best = d2;
            }
          }
        }
      }
      nearest[s] = best <= limit ? std::sqrt(best) : std::numeric_limits<double>::infinity();
    }
    const auto mid = nearest.begin() + static_cast<std::ptrdiff_t>(samples / 2);
    std::nth_element(nearest.begin(), mid, nearest.end());
    if (std::isfinite(*mid)) return *mid;
  }
  return cell;  // very sparse: the splat size cap takes over
}

double NiceStep(double at_least) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(at_least)));
  for (double f : {1.0, 2.0, 5.0, 10.0}) {
    if (f * magnitude >= at_least * (1 - 1e-9)) return f * magnitude;
  }
  return 10 * magnitude;
}

// Largest 1/2/5 x 10^k not above `at_most`.
double NiceStepBelow(double at_most) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(at_most)));
  for (double f : {5.0, 2.0, 1.0}) {
    if (f * magnitude <= at_most * (1 + 1e-9)) return f * magnitude;
  }
  return magnitude;
}

std::string FormatMetres(double value, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  std::string s = text;
  if (s.find_first_not_of("-0.") == std::string::npos && s[0] == '-') s.erase(0, 1);  // "-0"
  return s;
}

std::string WithThousands(size_t n) {
  std::string digits = std::to_string(n);
  std::string out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

// Hershey fonts are ASCII only: one '?' per UTF-8 character, spaces for control bytes.
std::string Printable(const std::string& s, size_t max_chars) {
  std::string out;
  for (unsigned char c : s) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else if (c < 0x20 || c == 0x7f) {
      out += ' ';
    } else if (c >= 0xc0 || c < 0x80) {
      out += '?';
    }  // UTF-8 continuation bytes: dropped
  }
  if (out.size() > max_chars) out = out.substr(0, max_chars - 3) + "...";
  return out;
}

StatusOr<View> ComputeView(const MapRenderInput& input, const MapRenderOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  SEMMAP_RETURN_IF_ERROR(ValidateInput(input));
  View view;
  MapViewProjection& p = view.projection;
  view.layout = MakeLayout(options.long_side_px);

  const std::vector<Eigen::Isometry3d> cameras = AllCameras(input);
  p.up = options.up ? options.up->normalized() : EstimateUpDirection(cameras);
  p.forward = GroundForward(p.up, FirstCamera(input));
  p.right = p.forward.cross(p.up).normalized();
  view.tilt_rad = options.view == RenderView::kOblique ? options.oblique_tilt_deg * kPi / 180 : 0;
  const double c = std::cos(view.tilt_rad), s = std::sin(view.tilt_rad);
  p.image_up = (c * p.forward + s * p.up).normalized();
  p.toward_viewer = (c * p.up - s * p.forward).normalized();

  double camera_height = 0;
  for (const auto& T : cameras) camera_height += T.translation().dot(p.up);
  if (!cameras.empty()) {
    camera_height /= static_cast<double>(cameras.size());
    p.clip_height = camera_height + options.clip_above_camera_m;
  }

  const Eigen::Vector3f up_f = p.up.cast<float>();
  const Eigen::Vector3f right_f = p.right.cast<float>();
  const Eigen::Vector3f image_up_f = p.image_up.cast<float>();
  const Eigen::Vector3f toward_f = p.toward_viewer.cast<float>();
  std::vector<float> heights;
  view.points.reserve(input.cloud.size());
  heights.reserve(input.cloud.size());
  for (size_t i = 0; i < input.cloud.size(); ++i) {
    const RenderPoint& rp = input.cloud[i];
    const Eigen::Vector3f q(rp.x, rp.y, rp.z);
    const float h = q.dot(up_f);
    if (h > p.clip_height) continue;
    heights.push_back(h);
    view.points.push_back(
        {q.dot(right_f), q.dot(image_up_f), q.dot(toward_f), static_cast<uint32_t>(i)});
  }

  // Bounds in view coordinates (u along right, v along image_up).
  double u_min = std::numeric_limits<double>::infinity(), u_max = -u_min;
  double v_min = u_min, v_max = -u_min;
  const auto extend = [&](const Eigen::Vector3d& q) {
    const double u = q.dot(p.right), v = q.dot(p.image_up);
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
  };
  double cloud_area_m2 = 0;
  if (!view.points.empty()) {
    std::vector<float> values(view.points.size());
    for (size_t i = 0; i < values.size(); ++i) values[i] = view.points[i].u;
    const double lo_u = Percentile(values, kLowPercentile);
    const double hi_u = Percentile(values, kHighPercentile);
    for (size_t i = 0; i < values.size(); ++i) values[i] = view.points[i].v;
    const double lo_v = Percentile(values, kLowPercentile);
    const double hi_v = Percentile(values, kHighPercentile);
    u_min = lo_u;
    u_max = hi_u;
    v_min = lo_v;
    v_max = hi_v;
    cloud_area_m2 = (hi_u - lo_u) * (hi_v - lo_v);
    p.floor_height = Percentile(heights, 0.02);
  } else if (!cameras.empty()) {
    p.floor_height = camera_height - kDefaultCameraHeightM;
  }
  for (const auto& T : cameras) extend(T.translation());
  for (const auto& [a, b] : input.loop_edges) {
    extend(a);
    extend(b);
  }
  for (const RenderObject& o : input.objects) {
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d sign((corner & 1) ? 0.5 : -0.5, (corner & 2) ? 0.5 : -0.5,
                                 (corner & 4) ? 0.5 : -0.5);
      extend(o.centre + sign.cwiseProduct(o.extent));
    }
  }
  if (!(u_min <= u_max)) u_min = u_max = v_min = v_max = 0;  // nothing at all
  const auto pad = [](double& lo, double& hi) {
    const double margin = kMarginFraction * (hi - lo);
    lo -= margin;
    hi += margin;
    if (hi - lo < kMinSpanM) {
      const double mid = 0.5 * (lo + hi);
      lo = mid - 0.5 * kMinSpanM;
      hi = mid + 0.5 * kMinSpanM;
    }
  };
  pad(u_min, u_max);
  pad(v_min, v_max);
  const double span_u = u_max - u_min, span_v = v_max - v_min;

  // Image size: the long side as asked, the other following the map's aspect.
  const Layout& l = view.layout;
  const int long_side = options.long_side_px;
  const int fixed_w = l.left + l.right;
  const int fixed_h = l.title_band + l.top + l.bottom;
  int width = long_side, height = long_side;
  if (span_u >= span_v) {
    const double ppm = (long_side - fixed_w) / span_u;
    height = static_cast<int>(std::lround(span_v * ppm)) + fixed_h;
  } else {
    const double ppm = (long_side - fixed_h) / span_v;
    width = static_cast<int>(std::lround(span_u * ppm)) + fixed_w;
  }
  const int short_min = std::max(200, long_side / 2);
  width = std::clamp(width, short_min, long_side);
  height = std::clamp(height, short_min, long_side);
  p.image_width = width;
  p.image_height = height;
  p.area_x = l.left;
  p.area_y = l.title_band + l.top;
  p.area_width = width - fixed_w;
  p.area_height = height - fixed_h;
  p.pixels_per_metre = std::min(p.area_width / span_u, p.area_height / span_v);
  // Centre the content; the spare space shows more of the map.
  p.left_m = 0.5 * (u_min + u_max) - 0.5 * p.area_width / p.pixels_per_metre;
  p.top_m = 0.5 * (v_min + v_max) + 0.5 * p.area_height / p.pixels_per_metre;
  // A metre grid when 1 m lines are >= 45 px apart (rows in oblique view are foreshortened by
  // cos(tilt)) and 2 to 25 of them cross the map; else a 1/2/5 step with ~15 lines at most.
  const double min_step = 45 * l.ui / (p.pixels_per_metre * c);
  const double max_span = std::max(p.area_width, p.area_height) / p.pixels_per_metre;
  p.grid_step_m = min_step <= 1 && max_span >= 2 && max_span <= 25
                      ? 1.0
                      : NiceStep(std::max(min_step, max_span / 15));

  view.spacing_m = EstimateSpacing(
      view.points,
      std::max(1e-3, 2 * std::sqrt(cloud_area_m2 / std::max<size_t>(1, view.points.size()))));
  return view;
}

cv::Point Fixed(double x, double y) {
  constexpr double kLimit = 1e6;  // OpenCV's fixed-point drawing overflows beyond
  return {static_cast<int>(std::lround(std::clamp(x, -kLimit, kLimit) * kSubPixel)),
          static_cast<int>(std::lround(std::clamp(y, -kLimit, kLimit) * kSubPixel))};
}

// Drawing in the map area (a sub-image: OpenCV clips there), area-local coordinates.
class AreaCanvas {
 public:
  AreaCanvas(cv::Mat3b& image, const MapViewProjection& p)
      : p_(p), area_(image(cv::Rect(p.area_x, p.area_y, p.area_width, p.area_height))) {}

  cv::Point2d Local(const Eigen::Vector3d& q) const {
    const Eigen::Vector2d px = p_.ToPixel(q);
    return {px.x() - p_.area_x, px.y() - p_.area_y};
  }
  cv::Point F(const cv::Point2d& q) const { return Fixed(q.x, q.y); }

  void Line(const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour, int thickness) {
    cv::line(area_, F(a), F(b), colour, thickness, cv::LINE_AA, kShift);
  }

  void DashedLine(const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour,
                  int thickness, double on, double off) {
    const double length = cv::norm(b - a);
    if (!(length > 0) || length > 1e6) return Line(a, b, colour, thickness);
    for (double s = 0; s < length; s += on + off) {
      const double e = std::min(length, s + on);
      Line(a + (b - a) * (s / length), a + (b - a) * (e / length), colour, thickness);
    }
  }

  void Disc(const cv::Point2d& c, double radius, const cv::Scalar& colour, int thickness) {
    cv::circle(area_, F(c), static_cast<int>(std::lround(radius * kSubPixel)), colour, thickness,
               cv::LINE_AA, kShift);
  }

  cv::Mat& mat() { return area_; }

 private:
  const MapViewProjection& p_;
  cv::Mat area_;
};

void PutText(cv::Mat& image, const std::string& text, cv::Point origin, double scale,
             const cv::Scalar& colour, int thickness) {
  cv::putText(image, text, origin, kFont, scale, colour, thickness, cv::LINE_AA);
}

cv::Size TextSize(const std::string& text, double scale, int thickness, int* baseline) {
  return cv::getTextSize(text, kFont, scale, thickness, baseline);
}

// A white panel at `opacity` over the picture.
void Panel(cv::Mat& image, cv::Rect rect, double opacity, const cv::Scalar& border) {
  rect &= cv::Rect(0, 0, image.cols, image.rows);
  if (rect.empty()) return;
  cv::Mat roi = image(rect);
  cv::Mat white(roi.size(), roi.type(), kWhite);
  cv::addWeighted(white, opacity, roi, 1 - opacity, 0, roi);
  cv::rectangle(image, rect, border, 1);
}

void DrawGrid(cv::Mat3b& image, const View& view) {
  const MapViewProjection& p = view.projection;
  const Layout& l = view.layout;
  const double step = p.grid_step_m;
  const double c = std::cos(view.tilt_rad), s = std::sin(view.tilt_rad);
  const double ppm = p.pixels_per_metre;
  const double scale = 0.45 * l.ui;
  const int thickness = std::max(1, static_cast<int>(std::lround(l.ui * 0.8)));
  cv::Mat area = image(cv::Rect(p.area_x, p.area_y, p.area_width, p.area_height));
  const int grid_thickness = std::max(1, static_cast<int>(std::lround(l.ui * 0.8)));
  int baseline = 0;

  // Columns: u = a (independent of height). Rows: ground coordinate b along forward at the
  // floor height, v = cos(t) b + sin(t) floor.
  const double right_m = p.left_m + p.area_width / ppm;
  int last_label_end = -1 << 30;
  for (double k = std::ceil(p.left_m / step); k * step <= right_m; k += 1) {
    const double a = k * step;
    const int x = static_cast<int>(std::lround((a - p.left_m) * ppm - 0.5));
    const cv::Scalar colour = std::abs(k) < 0.5 ? kOriginGridColour : cv::Scalar(kGridColour);
    cv::line(area, {x, 0}, {x, p.area_height - 1}, colour, grid_thickness, cv::LINE_8);
    const std::string label = FormatMetres(a, step);
    const cv::Size size = TextSize(label, scale, thickness, &baseline);
    const int gx = p.area_x + x - size.width / 2;
    if (gx < last_label_end + Px(l, 8) || gx + size.width > image.cols) continue;
    PutText(image, label, {gx, p.area_y + p.area_height + Px(l, 8) + size.height}, scale,
            kMutedText, thickness);
    last_label_end = gx + size.width;
  }
  const double bottom_m = p.top_m - p.area_height / ppm;
  const double b_top = (p.top_m - s * p.floor_height) / c;
  const double b_bottom = (bottom_m - s * p.floor_height) / c;
  int last_label_top = 1 << 30;
  for (double k = std::ceil(b_bottom / step); k * step <= b_top; k += 1) {
    const double b = k * step;
    const double v = c * b + s * p.floor_height;
    const int y = static_cast<int>(std::lround((p.top_m - v) * ppm - 0.5));
    const cv::Scalar colour = std::abs(k) < 0.5 ? kOriginGridColour : cv::Scalar(kGridColour);
    cv::line(area, {0, y}, {p.area_width - 1, y}, colour, grid_thickness, cv::LINE_8);
    const std::string label = FormatMetres(b, step);
    const cv::Size size = TextSize(label, scale, thickness, &baseline);
    const int gy = p.area_y + y + size.height / 2;
    if (gy > last_label_top - Px(l, 6) || gy - size.height < p.area_y - Px(l, 2)) continue;
    PutText(image, label, {p.area_x - Px(l, 8) - size.width, gy}, scale, kMutedText, thickness);
    last_label_top = gy - size.height;
  }
}

// Splats into a z-buffer, then composites with a little depth shading (darker where a
// neighbour is nearer the viewer: edges of furniture and walls read as outlines).
void DrawCloud(cv::Mat3b& image, const View& view, const MapRenderInput& input) {
  const MapViewProjection& p = view.projection;
  if (view.points.empty()) return;
  const int w = p.area_width, h = p.area_height;
  const double spacing_px = view.spacing_m * p.pixels_per_metre;
  // One pixel wider than the spacing so jittered neighbours still overlap: solid, not speckled.
  const int k = spacing_px < 0.75
                    ? 1
                    : std::min(static_cast<int>(std::lround(kMaxSplatPx * view.layout.ui)),
                               static_cast<int>(std::ceil(spacing_px)) + 1);
  cv::Mat1f depth(h, w, -std::numeric_limits<float>::infinity());
  cv::Mat3b colour(h, w, cv::Vec3b(0, 0, 0));
  const double ppm = p.pixels_per_metre;
  const double half = (k - 1) / 2.0;
  for (const ViewPoint& q : view.points) {
    const double x = (q.u - p.left_m) * ppm - 0.5;
    const double y = (p.top_m - q.v) * ppm - 0.5;
    if (x < -k || y < -k || x > w + k || y > h + k) continue;
    const int x0 = std::max(0, static_cast<int>(std::lround(x - half)));
    const int y0 = std::max(0, static_cast<int>(std::lround(y - half)));
    const int x1 = std::min(w, static_cast<int>(std::lround(x - half)) + k);
    const int y1 = std::min(h, static_cast<int>(std::lround(y - half)) + k);
    const RenderPoint& rp = input.cloud[q.index];
    const cv::Vec3b bgr(rp.b, rp.g, rp.r);
    for (int yy = y0; yy < y1; ++yy) {
      float* zrow = depth.ptr<float>(yy);
      cv::Vec3b* crow = colour.ptr<cv::Vec3b>(yy);
      for (int xx = x0; xx < x1; ++xx) {
        if (q.depth > zrow[xx]) {
          zrow[xx] = q.depth;
          crow[xx] = bgr;
        }
      }
    }
  }
  const int o = std::max(2, k);
  constexpr float kNoise = 0.01f;  // creases below this (a noisy floor) do not shade
  constexpr float kScale = 0.06f;  // metres of crease for a 1/e darkening
  cv::Mat3b area = image(cv::Rect(p.area_x, p.area_y, w, h));
  for (int y = 0; y < h; ++y) {
    const float* zrow = depth.ptr<float>(y);
    const cv::Vec3b* crow = colour.ptr<cv::Vec3b>(y);
    cv::Vec3b* out = area.ptr<cv::Vec3b>(y);
    const float* up = depth.ptr<float>(std::max(0, y - o));
    const float* down = depth.ptr<float>(std::min(h - 1, y + o));
    for (int x = 0; x < w; ++x) {
      const float z = zrow[x];
      if (!std::isfinite(z)) continue;
      // Against the mean of opposite neighbours, so a tilted plane (oblique view) is not a step.
      const auto crease = [&](float a, float b) {
        const float m = 0.5f * ((std::isfinite(a) ? a : z) + (std::isfinite(b) ? b : z)) - z;
        return m > kNoise ? m - kNoise : 0.0f;
      };
      const float step =
          crease(up[x], down[x]) + crease(zrow[std::max(0, x - o)], zrow[std::min(w - 1, x + o)]);
      const float shade = 0.55f + 0.45f * std::exp(-step / kScale);
      for (int ch = 0; ch < 3; ++ch) {
        out[x][ch] = static_cast<uint8_t>(std::lround(crow[x][ch] * shade));
      }
    }
  }
}

cv::Scalar ObjectColour(const RenderObject& o) { return cv::Scalar(o.rgb[2], o.rgb[1], o.rgb[0]); }

double Luminance(const cv::Scalar& bgr) { return 0.114 * bgr[0] + 0.587 * bgr[1] + 0.299 * bgr[2]; }

struct ObjectOutline {
  const RenderObject* object;
  std::vector<cv::Point2d> corners;  // area-local
  double depth;
};

std::vector<ObjectOutline> ProjectObjects(const MapRenderInput& input, const View& view,
                                          const AreaCanvas& canvas) {
  std::vector<ObjectOutline> out;
  for (const RenderObject& o : input.objects) {
    ObjectOutline outline{&o, {}, view.projection.Depth(o.centre)};
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d sign((corner & 1) ? 0.5 : -0.5, (corner & 2) ? 0.5 : -0.5,
                                 (corner & 4) ? 0.5 : -0.5);
      outline.corners.push_back(canvas.Local(o.centre + sign.cwiseProduct(o.extent)));
    }
    out.push_back(std::move(outline));
  }
  // Farther boxes first, so nearer outlines stay on top.
  std::stable_sort(out.begin(), out.end(), [](const ObjectOutline& a, const ObjectOutline& b) {
    return a.depth < b.depth;
  });
  return out;
}

// Corner bit i set: the +extent side along world axis i.
bool EdgeVisible(int a, int axis, const Eigen::Vector3d& toward_viewer) {
  // Visible when one of its two faces faces the viewer (outlines and front edges only, so
  // the far edges do not cross the box in oblique view).
  for (int i = 0; i < 3; ++i) {
    if (i == axis) continue;
    const double outward = (a & (1 << i)) ? 1.0 : -1.0;
    if (outward * toward_viewer[i] > 1e-6) return true;
  }
  return false;
}

void DrawObjectBoxes(AreaCanvas& canvas, const std::vector<ObjectOutline>& outlines,
                     const MapViewProjection& p, const Layout& l) {
  const int thickness = Px(l, 2);
  for (const ObjectOutline& o : outlines) {
    const cv::Scalar colour = ObjectColour(*o.object);
    // A halo of the opposite lightness keeps the outline visible on any cloud colour.
    const cv::Scalar halo = Luminance(colour) > 150 ? cv::Scalar(40, 40, 40) : kWhite;
    for (int pass = 0; pass < 2; ++pass) {
      for (int a = 0; a < 8; ++a) {
        for (int axis = 0; axis < 3; ++axis) {
          const int b = a | (1 << axis);
          if (b == a || !EdgeVisible(a, axis, p.toward_viewer)) continue;
          canvas.Line(o.corners[a], o.corners[b], pass == 0 ? halo : colour,
                      pass == 0 ? thickness + Px(l, 2) : thickness);
        }
      }
    }
  }
}

void DrawObjectLabels(cv::Mat3b& image, const MapViewProjection& p,
                      const std::vector<ObjectOutline>& outlines, const Layout& l) {
  const double scale = 0.5 * l.ui;
  const int thickness = std::max(1, static_cast<int>(std::lround(l.ui)));
  const int pad = Px(l, 4);
  const cv::Rect area(p.area_x, p.area_y, p.area_width, p.area_height);
  std::vector<cv::Rect> placed;
  // Nearest first. Reverse iterators: clang 14 (tsan preset) cannot compile libstdc++ 12's
  // std::views::reverse.
  // NOLINTNEXTLINE(modernize-loop-convert)
  for (auto it = outlines.rbegin(); it != outlines.rend(); ++it) {
    const auto& outline = *it;
    const std::string text = Printable(outline.object->label, 40);
    if (text.empty()) continue;
    double min_x = 1e9, max_x = -1e9, min_y = 1e9, max_y = -1e9;
    for (const cv::Point2d& c : outline.corners) {
      min_x = std::min(min_x, c.x);
      max_x = std::max(max_x, c.x);
      min_y = std::min(min_y, c.y);
      max_y = std::max(max_y, c.y);
    }
    int baseline = 0;
    const cv::Size size = TextSize(text, scale, thickness, &baseline);
    const cv::Size box(size.width + 2 * pad, size.height + baseline + 2 * pad);
    const double cx = p.area_x + 0.5 * (min_x + max_x);
    const auto at = [&](double top) {
      cv::Rect r(static_cast<int>(std::lround(cx - box.width / 2.0)), static_cast<int>(top),
                 box.width, box.height);
      r.x = std::clamp(r.x, area.x + 1, std::max(area.x + 1, area.x + area.width - r.width - 1));
      r.y = std::clamp(r.y, area.y + 1, std::max(area.y + 1, area.y + area.height - r.height - 1));
      return r;
    };
    const auto free = [&](const cv::Rect& r) {
      return std::none_of(placed.begin(), placed.end(),
                          [&](const cv::Rect& q) { return (q & r).area() > 0; });
    };
    // Above the box, else below it, else stacked upwards out of the others' way.
    const double above = p.area_y + min_y - pad - box.height;
    const double below = p.area_y + max_y + pad;
    cv::Rect rect = at(above);
    if (!free(rect)) rect = at(below);
    for (int tries = 1; tries <= 6 && !free(rect); ++tries) {
      rect = at(above - tries * (box.height + Px(l, 2)));
    }
    placed.push_back(rect);
    const cv::Scalar colour = ObjectColour(*outline.object);
    Panel(image, rect, 0.88, colour);
    cv::rectangle(image, rect, colour, Px(l, 2));
    PutText(image, text, {rect.x + pad, rect.y + pad + size.height}, scale, kText, thickness);
  }
}

void DrawTrajectories(AreaCanvas& canvas, const MapRenderInput& input, const Layout& l) {
  const int thickness = Px(l, 2);
  for (const auto& trajectory : input.trajectories) {
    if (trajectory.empty()) continue;
    std::vector<cv::Point> pixels;
    pixels.reserve(trajectory.size());
    for (const auto& T : trajectory) pixels.push_back(canvas.F(canvas.Local(T.translation())));
    cv::polylines(canvas.mat(), pixels, false, kTrajectory, thickness, cv::LINE_AA, kShift);
    // The start: a ring, so sessions and direction can be told apart.
    canvas.Disc(canvas.Local(trajectory.front().translation()), 5 * l.ui, kTrajectory, thickness);
  }
}

void DrawKeyframes(AreaCanvas& canvas, const MapRenderInput& input, const MapViewProjection& p,
                   const Layout& l) {
  const double radius = 3.2 * l.ui;
  for (const auto& T : input.keyframes) {
    const cv::Point2d c = canvas.Local(T.translation());
    // Heading tick: the optical axis as drawn.
    const Eigen::Vector3d f = T.linear().col(2);
    const cv::Point2d dir(f.dot(p.right), -f.dot(p.image_up));
    const double n = cv::norm(dir);
    if (n > 0.2) canvas.Line(c, c + dir * (10 * l.ui / n), kKeyframe, Px(l, 1.5));
    canvas.Disc(c, radius + Px(l, 1), kWhite, cv::FILLED);
    canvas.Disc(c, radius, kKeyframe, cv::FILLED);
  }
}

void DrawLoopEdges(AreaCanvas& canvas, const MapRenderInput& input, const Layout& l) {
  for (const auto& [a, b] : input.loop_edges) {
    canvas.DashedLine(canvas.Local(a), canvas.Local(b), kLoopEdge, Px(l, 2), 9 * l.ui, 6 * l.ui);
  }
}

void DrawScaleBar(cv::Mat3b& image, const MapViewProjection& p, const Layout& l) {
  const double metres =
      NiceStepBelow(std::min(230 * l.ui, 0.3 * p.area_width) / p.pixels_per_metre);
  const int length = static_cast<int>(std::lround(metres * p.pixels_per_metre));
  const std::string label = FormatMetres(metres, metres) + " m";
  const double scale = 0.5 * l.ui;
  const int thickness = std::max(1, static_cast<int>(std::lround(l.ui)));
  int baseline = 0;
  const cv::Size size = TextSize(label, scale, thickness, &baseline);
  const int pad = Px(l, 8);
  const int bar = Px(l, 5);
  const cv::Rect panel(p.area_x + Px(l, 10),
                       p.area_y + p.area_height - Px(l, 10) - (size.height + bar + 3 * pad),
                       std::max(length, size.width) + 2 * pad, size.height + bar + 3 * pad);
  Panel(image, panel, 0.85, kFrameColour);
  const int x0 = panel.x + pad, y_bar = panel.y + panel.height - pad - bar;
  // Half black, half white, like a map's scale bar.
  cv::rectangle(image, cv::Rect(x0, y_bar, length, bar), kText, cv::FILLED);
  cv::rectangle(image, cv::Rect(x0 + length / 2, y_bar + 1, length - length / 2 - 1, bar - 2),
                kWhite, cv::FILLED);
  PutText(image, label, {x0 + (length - size.width) / 2, y_bar - pad / 2 - 1}, scale, kText,
          thickness);
}

enum class LegendSample { kLine, kDashed, kMarker, kBox };
struct LegendEntry {
  std::string label;
  cv::Scalar colour;
  LegendSample sample;
};

// What the legend would hide at `rect`: cloud pixels count 1, overlay pixels (trajectories,
// boxes, labels: where `image` differs from `cloud_only`) 20.
int64_t HiddenContent(const cv::Mat3b& image, const cv::Mat3b& cloud_only, const cv::Rect& rect) {
  int64_t count = 0;
  for (int y = rect.y; y < rect.y + rect.height; ++y) {
    const cv::Vec3b* row = image.ptr<cv::Vec3b>(y);
    const cv::Vec3b* under = cloud_only.ptr<cv::Vec3b>(y);
    for (int x = rect.x; x < rect.x + rect.width; ++x) {
      if (row[x] != under[x]) {
        count += 20;
      } else if (row[x] != kAreaBackground && row[x] != kGridColour) {
        count += 1;
      }
    }
  }
  return count;
}

void DrawLegend(cv::Mat3b& image, const cv::Mat3b& cloud_only, const MapViewProjection& p,
                const MapRenderInput& input, const Layout& l) {
  std::vector<LegendEntry> entries;
  const bool any_trajectory = std::any_of(input.trajectories.begin(), input.trajectories.end(),
                                          [](const auto& t) { return !t.empty(); });
  if (any_trajectory) entries.push_back({"camera trajectory", kTrajectory, LegendSample::kLine});
  if (!input.keyframes.empty()) entries.push_back({"keyframe", kKeyframe, LegendSample::kMarker});
  if (!input.loop_edges.empty()) {
    entries.push_back({"loop closure", kLoopEdge, LegendSample::kDashed});
  }
  if (!input.objects.empty()) {
    entries.push_back({"object", ObjectColour(input.objects.front()), LegendSample::kBox});
  }
  if (entries.empty()) return;
  const double scale = 0.5 * l.ui;
  const int thickness = std::max(1, static_cast<int>(std::lround(l.ui)));
  const int row = Px(l, 24), sample = Px(l, 34), pad = Px(l, 10);
  int baseline = 0, text_width = 0;
  for (const LegendEntry& e : entries) {
    text_width = std::max(text_width, TextSize(e.label, scale, thickness, &baseline).width);
  }
  const cv::Size box(sample + 3 * pad + text_width, static_cast<int>(entries.size()) * row + pad);
  const int inset = Px(l, 10);
  const cv::Rect area(p.area_x, p.area_y, p.area_width, p.area_height);
  const std::array<cv::Point, 3> corners = {
      cv::Point(area.x + area.width - inset - box.width, area.y + inset),  // top right
      cv::Point(area.x + inset, area.y + inset),                           // top left
      cv::Point(area.x + area.width - inset - box.width,
                area.y + area.height - inset - box.height),  // bottom right (scale bar: left)
  };
  cv::Rect best;
  int64_t best_count = std::numeric_limits<int64_t>::max();
  for (const cv::Point& corner : corners) {
    const cv::Rect rect = cv::Rect(corner, box) & area;
    const int64_t count = HiddenContent(image, cloud_only, rect);
    if (count < best_count) {
      best_count = count;
      best = cv::Rect(corner, box);
    }
  }
  Panel(image, best, 0.9, kFrameColour);
  for (size_t i = 0; i < entries.size(); ++i) {
    const LegendEntry& e = entries[i];
    const int y = best.y + pad / 2 + static_cast<int>(i) * row + row / 2;
    const cv::Point a(best.x + pad, y), b(best.x + pad + sample, y);
    switch (e.sample) {
      case LegendSample::kLine:
        cv::line(image, a, b, e.colour, Px(l, 2), cv::LINE_AA);
        break;
      case LegendSample::kDashed: {
        const int dash = std::max(2, sample / 3 - Px(l, 1));
        cv::line(image, a, a + cv::Point(dash, 0), e.colour, Px(l, 2), cv::LINE_AA);
        cv::line(image, b - cv::Point(dash, 0), b, e.colour, Px(l, 2), cv::LINE_AA);
        break;
      }
      case LegendSample::kMarker:
        cv::circle(image, (a + b) / 2, Px(l, 3.2), e.colour, cv::FILLED, cv::LINE_AA);
        break;
      case LegendSample::kBox:
        cv::rectangle(image, cv::Rect(a.x + sample / 6, y - row / 3, sample * 2 / 3, row * 2 / 3),
                      e.colour, Px(l, 2), cv::LINE_AA);
        break;
    }
    const cv::Size size = TextSize(e.label, scale, thickness, &baseline);
    PutText(image, e.label, {b.x + pad, y + size.height / 2}, scale, kText, thickness);
  }
}

void DrawTitleBand(cv::Mat3b& image, const View& view, const MapRenderInput& input,
                   const MapRenderOptions& options) {
  const Layout& l = view.layout;
  const MapViewProjection& p = view.projection;
  const int x0 = p.area_x, x1 = p.area_x + p.area_width;
  const int baseline_y = static_cast<int>(std::lround(l.title_band * 0.72));
  const double info_scale = 0.5 * l.ui;
  const int thin = std::max(1, static_cast<int>(std::lround(l.ui)));
  int baseline = 0;

  std::string info = options.view == RenderView::kTopDown ? "top-down" : "oblique";
  info += " | " + WithThousands(input.cloud.size()) + " points";
  if (!input.objects.empty()) info += " | " + WithThousands(input.objects.size()) + " objects";
  info += " | grid " + FormatMetres(p.grid_step_m, p.grid_step_m) + " m";
  cv::Size info_size = TextSize(info, info_scale, thin, &baseline);

  const double title_scale = 0.8 * l.ui;
  const int bold = thin + (l.ui >= 0.9 ? 1 : 0);
  std::string title = Printable(input.title, 80);
  // Shorten the title before dropping the info line.
  while (title.size() > 4 &&
         TextSize(title, title_scale, bold, &baseline).width + info_size.width + Px(l, 24) >
             x1 - x0) {
    title = title.substr(0, title.size() - 4) + "...";
  }
  const cv::Size title_size = TextSize(title, title_scale, bold, &baseline);
  if (!title.empty()) PutText(image, title, {x0, baseline_y}, title_scale, kText, bold);
  if (title_size.width + info_size.width + Px(l, 24) <= x1 - x0) {
    PutText(image, info, {x1 - info_size.width, baseline_y}, info_scale, kMutedText, thin);
  }
  cv::line(image, {0, l.title_band - 1}, {image.cols - 1, l.title_band - 1},
           cv::Scalar(225, 225, 225), 1);
}

StatusOr<std::string> Render(const MapRenderInput& input, const MapRenderOptions& options) {
  SEMMAP_ASSIGN_OR_RETURN(View view, ComputeView(input, options));
  const MapViewProjection& p = view.projection;
  const Layout& l = view.layout;
  cv::Mat3b image(p.image_height, p.image_width, cv::Vec3b(255, 255, 255));
  const cv::Rect area(p.area_x, p.area_y, p.area_width, p.area_height);
  image(area).setTo(kAreaBackground);

  DrawGrid(image, view);
  DrawCloud(image, view, input);
  const cv::Mat3b cloud_only = image.clone();
  AreaCanvas canvas(image, p);
  const std::vector<ObjectOutline> outlines = ProjectObjects(input, view, canvas);
  DrawObjectBoxes(canvas, outlines, p, l);
  DrawLoopEdges(canvas, input, l);
  DrawTrajectories(canvas, input, l);
  DrawKeyframes(canvas, input, p, l);
  DrawObjectLabels(image, p, outlines, l);

  const bool empty = input.cloud.empty() && input.objects.empty() && input.keyframes.empty() &&
                     std::all_of(input.trajectories.begin(), input.trajectories.end(),
                                 [](const auto& t) { return t.empty(); });
  if (empty) {
    const std::string text = "empty map";
    const double scale = 0.8 * l.ui;
    int baseline = 0;
    const cv::Size size = TextSize(text, scale, 1, &baseline);
    PutText(image, text,
            {area.x + (area.width - size.width) / 2, area.y + (area.height + size.height) / 2},
            scale, kMutedText, std::max(1, static_cast<int>(std::lround(l.ui))));
  }
  DrawScaleBar(image, p, l);
  DrawLegend(image, cloud_only, p, input, l);
  cv::rectangle(image, area, kFrameColour, 1);
  DrawTitleBand(image, view, input, options);

  // Level 3: within a few percent of the smallest file at a fraction of level 9's time.
  return EncodePng(image, 3);
}

}  // namespace

Status MapRenderOptions::Validate() const {
  if (long_side_px < 200 || long_side_px > 8000) {
    return InvalidArgumentError("long_side_px must be in [200, 8000], got " +
                                std::to_string(long_side_px));
  }
  if (up && (!up->allFinite() || !std::isfinite(up->norm()) || !(up->norm() > 1e-9))) {
    return InvalidArgumentError("up must be finite and non-zero");
  }
  if (!(oblique_tilt_deg >= 5 && oblique_tilt_deg <= 80)) {
    return InvalidArgumentError("oblique_tilt_deg must be in [5, 80]");
  }
  if (std::isnan(clip_above_camera_m)) {
    return InvalidArgumentError("clip_above_camera_m must not be NaN");
  }
  return OkStatus();
}

Eigen::Vector3d EstimateUpDirection(const std::vector<Eigen::Isometry3d>& T_world_camera) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();  // of the cameras' x axes
  for (const Eigen::Isometry3d& T : T_world_camera) {
    sum -= T.linear().col(1).normalized();
    const Eigen::Vector3d x = T.linear().col(0).normalized();
    scatter += x * x.transpose();
  }
  // Opposite cameras (or none) leave no direction; a tiny sum is noise, not an answer.
  const double n = sum.norm();
  const double count = static_cast<double>(T_world_camera.size());
  if (!std::isfinite(n) || n < 1e-3 * std::max(1.0, count)) return -Eigen::Vector3d::UnitY();
  Eigen::Vector3d mean_up = sum / n;
  // Hand-held cameras are seldom rolled but often pitched the same way (towards the floor),
  // which tilts the mean -y. Pitch turns about x, so x stays horizontal: with enough yaw
  // spread (second eigenvalue, ~8 degrees), the normal of the x axes is up, pitch or not.
  if (!scatter.allFinite()) return mean_up;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  if (eigen.info() != Eigen::Success || eigen.eigenvalues()(1) < 0.02 * count) return mean_up;
  Eigen::Vector3d normal = eigen.eigenvectors().col(0).normalized();
  if (normal.dot(mean_up) < 0) normal = -normal;
  // Far from the mean -y (cameras rolled every which way): no consistent horizon.
  return normal.dot(mean_up) > std::cos(40 * kPi / 180) ? normal : mean_up;
}

Eigen::Vector2d MapViewProjection::ToPixel(const Eigen::Vector3d& p_world) const {
  return {area_x - 0.5 + (p_world.dot(right) - left_m) * pixels_per_metre,
          area_y - 0.5 + (top_m - p_world.dot(image_up)) * pixels_per_metre};
}

StatusOr<MapViewProjection> ComputeMapViewProjection(const MapRenderInput& input,
                                                     const MapRenderOptions& options) {
  try {
    SEMMAP_ASSIGN_OR_RETURN(View view, ComputeView(input, options));
    return view.projection;
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory computing the map view");
  }
}

StatusOr<std::string> RenderMapPng(const MapRenderInput& input, const MapRenderOptions& options) {
  try {
    return Render(input, options);
  } catch (const cv::Exception& e) {
    return InternalError(std::string("rendering the map picture: ") + e.what());
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory rendering the map picture");
  }
}

}  // namespace semmap
