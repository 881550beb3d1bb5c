#include "tests/testing/synth/texture.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "tests/testing/synth/rng.h"

namespace semmap::synth {
namespace {

constexpr int kShift = 4;  // sub-texel precision of OpenCV drawing coordinates (1/16)
constexpr double kOne = 1 << kShift;

struct Palette {
  double hue;         // [0, 1)
  double hue_spread;  // standard deviation of a shape's hue around `hue`
  double sat_lo, sat_hi;
  double val_lo, val_hi;
};

struct StyleParams {
  double min_radius;  // texels; the smallest shapes
  double max_radius;  // texels; the largest (also capped by the texture's size)
  double coverage;    // area drawn per scale octave, as a fraction of the texture
  double text_share;  // fraction of a scale's shapes that are words
};

StyleParams ParamsFor(TextureStyle style) {
  switch (style) {
    case TextureStyle::kObject:
      return {8.0, 90.0, 0.70, 0.10};  // 1 mm texels: 8 mm to 9 cm, legible from metres away
    case TextureStyle::kFurniture:
      return {3.0, 70.0, 0.40, 0.04};
    default:
      return {3.0, 90.0, 0.40, 0.04};
  }
}

Palette PaletteFor(TextureStyle style, Rng& rng) {
  switch (style) {
    case TextureStyle::kWall:
      return {rng.Uniform(), 0.08, 0.15, 0.75, 0.10, 0.97};
    case TextureStyle::kFloor:
      return {rng.Uniform(0.03, 0.11), 0.04, 0.20, 0.75, 0.08, 0.85};
    case TextureStyle::kCeiling:
      return {rng.Uniform(), 0.15, 0.00, 0.35, 0.20, 0.98};
    case TextureStyle::kFurniture:
      return {rng.Uniform(0.04, 0.12), 0.05, 0.30, 0.85, 0.08, 0.90};
    case TextureStyle::kObject:
      return {rng.Uniform(), 0.30, 0.50, 1.00, 0.08, 1.00};
  }
  return {0, 0.1, 0, 1, 0, 1};
}

cv::Scalar HsvToBgr(double h, double s, double v) {
  h = h - std::floor(h);
  const double x = h * 6.0;
  const int sector = static_cast<int>(x) % 6;
  const double f = x - std::floor(x);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = v, g = t, b = p;
  switch (sector) {
    case 1:
      r = q, g = v, b = p;
      break;
    case 2:
      r = p, g = v, b = t;
      break;
    case 3:
      r = p, g = q, b = v;
      break;
    case 4:
      r = t, g = p, b = v;
      break;
    case 5:
      r = v, g = p, b = q;
      break;
    default:
      break;
  }
  return cv::Scalar(b * 255.0, g * 255.0, r * 255.0);
}

cv::Scalar RandomColour(const Palette& palette, Rng& rng) {
  const double h = palette.hue + palette.hue_spread * rng.Normal();
  // One draw per statement: the order of a call's arguments is unspecified (gcc and clang
  // differ), and the scene must not depend on the compiler. This order is the one gcc took.
  const double v = rng.Uniform(palette.val_lo, palette.val_hi);
  const double s = rng.Uniform(palette.sat_lo, palette.sat_hi);
  return HsvToBgr(h, s, v);
}

cv::Point FixedPoint(double x, double y) {
  return cv::Point(static_cast<int>(std::lround(x * kOne)),
                   static_cast<int>(std::lround(y * kOne)));
}

// A smooth random colour field: a coarse grid of palette colours, upsampled bicubically.
cv::Mat BaseLayer(int cols, int rows, const Palette& palette, Rng& rng) {
  const int grid_cols = std::max(2, cols / 48), grid_rows = std::max(2, rows / 48);
  cv::Mat grid(grid_rows, grid_cols, CV_8UC3);
  Palette soft = palette;
  soft.val_lo = 0.35 + 0.4 * palette.val_lo;
  soft.val_hi = 0.35 + 0.6 * palette.val_hi;
  for (int r = 0; r < grid_rows; ++r) {
    for (int c = 0; c < grid_cols; ++c) {
      const cv::Scalar colour = RandomColour(soft, rng);
      grid.at<cv::Vec3b>(r, c) =
          cv::Vec3b(cv::saturate_cast<uchar>(colour[0]), cv::saturate_cast<uchar>(colour[1]),
                    cv::saturate_cast<uchar>(colour[2]));
    }
  }
  cv::Mat base;
  cv::resize(grid, base, cv::Size(cols, rows), 0, 0, cv::INTER_CUBIC);
  return base;
}

std::string RandomWord(Rng& rng) {
  static constexpr char kLetters[] = "ABCDEFGHJKLMNPQRSTUVWXYZ0123456789#%&";
  const int length = rng.UniformInt(2, 7);
  std::string word;
  for (int i = 0; i < length; ++i) {
    word += kLetters[rng.UniformInt(0, static_cast<int>(sizeof(kLetters)) - 2)];
  }
  return word;
}

void DrawWord(cv::Mat& image, double x, double y, double radius, const cv::Scalar& colour,
              Rng& rng) {
  const int font = rng.Bernoulli(0.5) ? cv::FONT_HERSHEY_SIMPLEX : cv::FONT_HERSHEY_DUPLEX;
  const double scale = std::max(0.25, radius / 14.0);  // ~1.7 * radius tall glyphs
  const int thickness = std::max(1, static_cast<int>(std::lround(scale * 1.6)));
  cv::putText(image, RandomWord(rng), cv::Point(static_cast<int>(x), static_cast<int>(y)), font,
              scale, colour, thickness, cv::LINE_AA);
}

// One random shape of about `radius` texels around (x, y).
void DrawShape(cv::Mat& image, double x, double y, double radius, const Palette& palette,
               Rng& rng) {
  const cv::Scalar colour = RandomColour(palette, rng);
  const double angle = rng.Uniform(0.0, 2.0 * std::numbers::pi);
  const double ca = std::cos(angle), sa = std::sin(angle);
  switch (rng.UniformInt(0, 6)) {
    case 0: {  // rotated rectangle
      const double a = radius, b = radius * rng.Uniform(0.3, 1.0);
      const cv::Point pts[4] = {
          FixedPoint(x + a * ca - b * sa, y + a * sa + b * ca),
          FixedPoint(x - a * ca - b * sa, y - a * sa + b * ca),
          FixedPoint(x - a * ca + b * sa, y - a * sa - b * ca),
          FixedPoint(x + a * ca + b * sa, y + a * sa - b * ca),
      };
      cv::fillConvexPoly(image, pts, 4, colour, cv::LINE_AA, kShift);
      break;
    }
    case 1: {  // triangle
      cv::Point pts[3];
      for (int i = 0; i < 3; ++i) {
        const double t = angle + i * 2.0 * std::numbers::pi / 3.0 + rng.Uniform(-0.6, 0.6);
        const double r = radius * rng.Uniform(0.6, 1.3);
        pts[i] = FixedPoint(x + r * std::cos(t), y + r * std::sin(t));
      }
      cv::fillConvexPoly(image, pts, 3, colour, cv::LINE_AA, kShift);
      break;
    }
    case 2: {  // ellipse
      const cv::Size axes(static_cast<int>(radius * kOne),
                          static_cast<int>(radius * rng.Uniform(0.35, 1.0) * kOne));
      cv::ellipse(image, FixedPoint(x, y), axes, angle * 180.0 / std::numbers::pi, 0, 360, colour,
                  cv::FILLED, cv::LINE_AA, kShift);
      break;
    }
    case 3: {  // irregular star-like polygon (non-convex: many corners)
      const int n = rng.UniformInt(5, 9);
      std::vector<cv::Point> pts;
      for (int i = 0; i < n; ++i) {
        const double t = angle + i * 2.0 * std::numbers::pi / n;
        const double r = radius * (i % 2 == 0 ? rng.Uniform(0.8, 1.3) : rng.Uniform(0.3, 0.7));
        pts.push_back(FixedPoint(x + r * std::cos(t), y + r * std::sin(t)));
      }
      const cv::Point* poly = pts.data();
      const int count = n;
      cv::fillPoly(image, &poly, &count, 1, colour, cv::LINE_AA, kShift);
      break;
    }
    case 4: {  // bar
      const double half = radius * rng.Uniform(0.8, 1.6);
      const int thickness = std::max(1, static_cast<int>(radius * rng.Uniform(0.15, 0.4)));
      cv::line(image, FixedPoint(x - half * ca, y - half * sa),
               FixedPoint(x + half * ca, y + half * sa), colour, thickness, cv::LINE_AA, kShift);
      break;
    }
    case 5: {  // outlined square or ring
      const int thickness = std::max(1, static_cast<int>(radius * 0.22));
      if (rng.Bernoulli(0.5)) {
        cv::circle(image, FixedPoint(x, y), static_cast<int>(radius * 0.8 * kOne), colour,
                   thickness, cv::LINE_AA, kShift);
      } else {
        const double a = radius * 0.8;
        const cv::Point pts[4] = {
            FixedPoint(x + a * ca - a * sa, y + a * sa + a * ca),
            FixedPoint(x - a * ca - a * sa, y - a * sa + a * ca),
            FixedPoint(x - a * ca + a * sa, y - a * sa - a * ca),
            FixedPoint(x + a * ca + a * sa, y + a * sa - a * ca),
        };
        const cv::Point* poly = pts;
        const int count = 4;
        cv::polylines(image, &poly, &count, 1, true, colour, thickness, cv::LINE_AA, kShift);
      }
      break;
    }
    default: {  // 2x2 checker: strong X-junctions
      const cv::Scalar other = RandomColour(palette, rng);
      const double a = radius * 0.7;
      for (int i = 0; i < 4; ++i) {
        const double sx = (i & 1) ? 1.0 : -1.0, sy = (i & 2) ? 1.0 : -1.0;
        const cv::Point pts[4] = {
            FixedPoint(x, y),
            FixedPoint(x + sx * a * ca, y + sx * a * sa),
            FixedPoint(x + sx * a * ca - sy * a * sa, y + sx * a * sa + sy * a * ca),
            FixedPoint(x - sy * a * sa, y + sy * a * ca),
        };
        cv::fillConvexPoly(image, pts, 4, (i == 0 || i == 3) ? colour : other, cv::LINE_AA, kShift);
      }
      break;
    }
  }
}

// The label on a light band, small enough (at most 0.55 of the width, 0.1 of the height) that
// the shared glyphs of two objects' captions stay a minor part of their textures.
void DrawCaption(cv::Mat& image, std::string_view caption, Rng& rng) {
  if (caption.empty()) return;
  const std::string text(caption);
  const int font = cv::FONT_HERSHEY_DUPLEX;
  int baseline = 0;
  const cv::Size unit = cv::getTextSize(text, font, 1.0, 2, &baseline);
  const double scale = std::min(0.55 * image.cols / std::max(1, unit.width),
                                0.10 * image.rows / std::max(1, unit.height));
  const int thickness = std::max(1, static_cast<int>(scale * 2.0));
  const cv::Size size = cv::getTextSize(text, font, scale, thickness, &baseline);
  const int pad = std::max(2, size.height / 4);
  const int x =
      static_cast<int>(rng.Uniform(pad, std::max<double>(pad + 1, image.cols - size.width - pad)));
  const int y = static_cast<int>(rng.Uniform(
      size.height + pad, std::max<double>(size.height + pad + 1, image.rows - baseline - pad)));
  // Draws in sequence, last argument first (see RandomColour).
  const double band_v = rng.Uniform(0.85, 1.0), band_s = rng.Uniform(0.0, 0.3);
  const cv::Scalar band = HsvToBgr(rng.Uniform(), band_s, band_v);
  const double ink_v = rng.Uniform(0.0, 0.3), ink_s = rng.Uniform(0.3, 1.0);
  const cv::Scalar ink = HsvToBgr(rng.Uniform(), ink_s, ink_v);
  cv::rectangle(image, cv::Point(x - pad, y - size.height - pad),
                cv::Point(x + size.width + pad, y + baseline + pad), band, cv::FILLED);
  cv::putText(image, text, cv::Point(x, y), font, scale, ink, thickness, cv::LINE_AA);
}

cv::Mat GenerateTextureOrThrow(int cols, int rows, TextureStyle style, uint64_t seed,
                               std::string_view caption) {
  Rng rng(seed);
  const Palette palette = PaletteFor(style, rng);
  const StyleParams params = ParamsFor(style);
  cv::Mat image = BaseLayer(cols, rows, palette, rng);

  const double area = static_cast<double>(cols) * rows;
  const double max_radius =
      std::max(params.min_radius, std::min(params.max_radius, std::min(cols, rows) / 4.0));
  // Largest shapes first: smaller ones land on top, so every scale stays visible.
  for (double radius = max_radius; radius >= params.min_radius * 0.99; radius *= 0.5) {
    const int count = static_cast<int>(
        std::lround(params.coverage * area / (std::numbers::pi * radius * radius)));
    for (int i = 0; i < count; ++i) {
      const double jitter = radius * rng.Uniform(0.7, 1.4);
      const double x = rng.Uniform(-radius, cols + radius);
      const double y = rng.Uniform(-radius, rows + radius);
      if (radius >= 5.0 && rng.Bernoulli(params.text_share)) {
        DrawWord(image, x, y, jitter, RandomColour(palette, rng), rng);
      } else {
        DrawShape(image, x, y, jitter, palette, rng);
      }
    }
  }
  if (style == TextureStyle::kObject) DrawCaption(image, caption, rng);
  return image;
}

}  // namespace

StatusOr<cv::Mat> GenerateTexture(int cols, int rows, TextureStyle style, uint64_t seed,
                                  std::string_view caption) {
  constexpr int kMin = 8, kMax = 16384;
  if (cols < kMin || rows < kMin || cols > kMax || rows > kMax) {
    return InvalidArgumentError("texture size must be 8..16384 texels, got " +
                                std::to_string(cols) + "x" + std::to_string(rows));
  }
  try {
    return GenerateTextureOrThrow(cols, rows, style, seed, caption);
  } catch (const cv::Exception& e) {
    return InternalError(std::string("texture generation failed: ") + e.what());
  }
}

}  // namespace semmap::synth
