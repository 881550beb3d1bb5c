#include "tests/testing/synth/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace semmap::synth {

// The render-ready types Renderer::Prepared holds: outside the anonymous namespace, since a
// class with external linkage must not hold members of file-local types (and in a unity batch
// this file is not the main file, where gcc would say so).
namespace render_detail {

struct MipLevel {
  const uint32_t* texels = nullptr;  // BGRA, little-endian: 0xAARRGGBB
  int cols = 0, rows = 0;
  size_t stride = 0;               // in texels
  float scale_s = 1, scale_t = 1;  // level-0 texel coordinates to this level's
};

struct PreparedTexture {
  std::vector<cv::Mat> images;  // CV_8UC4, level 0 first (owns the texels)
  std::vector<MipLevel> levels;
};

struct PreparedSurface {
  Eigen::Vector3d origin, u, v, normal;
  double width, height;
  double texels_per_m_s, texels_per_m_t;
  int texture;
};

}  // namespace render_detail
using render_detail::MipLevel;
using render_detail::PreparedSurface;
using render_detail::PreparedTexture;

namespace {

using Eigen::Vector3d;

constexpr double kNearM = 0.01;  // near clipping plane
constexpr int kMaxMipLevels = 6;
constexpr float kEdgeTexels = 0.02f;  // tolerance of the inside test at rectangle edges

// Blends two BGRA texels, weight w/256 of b (w in 0..256), two channels per multiply.
inline uint32_t Lerp(uint32_t a, uint32_t b, uint32_t w) {
  const uint32_t iw = 256 - w;
  const uint32_t rb = ((a & 0xFF00FFu) * iw + (b & 0xFF00FFu) * w) >> 8;
  const uint32_t g = (((a >> 8) & 0xFF00FFu) * iw + ((b >> 8) & 0xFF00FFu) * w) >> 8;
  return (rb & 0xFF00FFu) | ((g & 0xFF00FFu) << 8);
}

// Bilinear sample at texel coordinates (s, t) of `m` (texel centres at +0.5), clamped.
inline uint32_t SampleBilinear(const MipLevel& m, float s, float t) {
  const float fx = s - 0.5f, fy = t - 0.5f;
  const float flx = std::floor(fx), fly = std::floor(fy);
  const int ix = static_cast<int>(flx), iy = static_cast<int>(fly);
  const uint32_t ax = static_cast<uint32_t>((fx - flx) * 256.0f);
  const uint32_t ay = static_cast<uint32_t>((fy - fly) * 256.0f);
  const int x0 = std::clamp(ix, 0, m.cols - 1), x1 = std::clamp(ix + 1, 0, m.cols - 1);
  const int y0 = std::clamp(iy, 0, m.rows - 1), y1 = std::clamp(iy + 1, 0, m.rows - 1);
  const uint32_t* r0 = m.texels + static_cast<size_t>(y0) * m.stride;
  const uint32_t* r1 = m.texels + static_cast<size_t>(y1) * m.stride;
  return Lerp(Lerp(r0[x0], r0[x1], ax), Lerp(r1[x0], r1[x1], ax), ay);
}

PreparedTexture PrepareTexture(const cv::Mat& bgr) {
  PreparedTexture texture;
  cv::Mat level;
  cv::cvtColor(bgr, level, cv::COLOR_BGR2BGRA);
  texture.images.push_back(level);
  while (static_cast<int>(texture.images.size()) < kMaxMipLevels &&
         std::min(texture.images.back().cols, texture.images.back().rows) >= 8) {
    cv::Mat down;
    cv::pyrDown(texture.images.back(), down);
    texture.images.push_back(down);
  }
  for (const cv::Mat& image : texture.images) {
    MipLevel m;
    m.texels = image.ptr<uint32_t>(0);
    m.cols = image.cols;
    m.rows = image.rows;
    m.stride = image.step1() / 4;
    m.scale_s = static_cast<float>(image.cols) / static_cast<float>(bgr.cols);
    m.scale_t = static_cast<float>(image.rows) / static_cast<float>(bgr.rows);
    texture.levels.push_back(m);
  }
  return texture;
}

// A convex polygon in the camera frame, at most 4 corners + 1 from the near-plane clip.
struct Polygon {
  std::array<Vector3d, 8> p;
  int n = 0;
};

Polygon ClipNear(const Polygon& in) {
  Polygon out;
  for (int i = 0; i < in.n; ++i) {
    const Vector3d& a = in.p[static_cast<size_t>(i)];
    const Vector3d& b = in.p[static_cast<size_t>((i + 1) % in.n)];
    const bool a_in = a.z() >= kNearM, b_in = b.z() >= kNearM;
    if (a_in) out.p[static_cast<size_t>(out.n++)] = a;
    if (a_in != b_in) {
      const double alpha = (kNearM - a.z()) / (b.z() - a.z());
      out.p[static_cast<size_t>(out.n++)] = a + alpha * (b - a);
    }
  }
  return out;
}

// Per-frame plane equations of one visible surface, in pixel coordinates:
//   w = 1/z = wx x + wy y + w0;  s = (sx x + sy y + s0n) / w - s_off  (texels), same for t.
struct Raster {
  double wx, wy, w0;
  double sx, sy, s0n, s_off;
  double tx, ty, t0n, t_off;
  float s_max, t_max;  // texture size in level-0 texels
  std::array<double, 8> px, py;
  int n;
  double y_min, y_max;
  const PreparedTexture* texture;
};

}  // namespace

struct Renderer::Prepared {
  std::vector<PreparedTexture> textures;
  std::vector<PreparedSurface> surfaces;
};

namespace {

Status ValidatePinhole(const CameraCalibration& camera) {
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera));
  if (camera.HasDistortion()) {
    return InvalidArgumentError(
        "the synthetic renderer models pinhole cameras only (no distortion)");
  }
  if (static_cast<int64_t>(camera.width) * camera.height > 64LL * 1024 * 1024) {
    return InvalidArgumentError("camera image too large to render");
  }
  return OkStatus();
}

// Sets up `r` for surface `s` seen from a camera with pose T_camera_world; false when the
// surface faces away, lies behind the near plane or outside the image.
bool SetUpRaster(const PreparedSurface& s, const Eigen::Isometry3d& T_camera_world,
                 const Vector3d& camera_position, const CameraCalibration& cam,
                 const std::vector<PreparedTexture>& textures, Raster* r) {
  if ((camera_position - s.origin).dot(s.normal) <= 1e-9) return false;  // back face
  const Eigen::Matrix3d R = T_camera_world.linear();
  const Vector3d o = T_camera_world * s.origin;
  const Vector3d u = R * s.u, v = R * s.v, n = R * s.normal;
  Polygon quad;
  quad.n = 4;
  quad.p = {o, o + s.width * u, o + s.width * u + s.height * v, o + s.height * v};
  const Polygon clipped = ClipNear(quad);
  if (clipped.n < 3) return false;
  double x_lo = 1e30, x_hi = -1e30;
  r->y_min = 1e30;
  r->y_max = -1e30;
  r->n = clipped.n;
  for (int i = 0; i < clipped.n; ++i) {
    const Vector3d& p = clipped.p[static_cast<size_t>(i)];
    const double x = cam.fx * p.x() / p.z() + cam.cx, y = cam.fy * p.y() / p.z() + cam.cy;
    r->px[static_cast<size_t>(i)] = x;
    r->py[static_cast<size_t>(i)] = y;
    x_lo = std::min(x_lo, x), x_hi = std::max(x_hi, x);
    r->y_min = std::min(r->y_min, y), r->y_max = std::max(r->y_max, y);
  }
  // (Also rejects non-finite poses: every comparison with NaN is false.)
  if (!(x_hi >= -1 && x_lo <= cam.width && r->y_max >= -1 && r->y_min <= cam.height)) return false;

  // Ray through pixel (x, y): d = (a x + b, c y + e, 1) with a = 1/fx, b = -cx/fx, ...
  const double a = 1.0 / cam.fx, b = -cam.cx / cam.fx, c = 1.0 / cam.fy, e = -cam.cy / cam.fy;
  const double d = n.dot(o);  // plane n.X = d; negative for a front face
  r->wx = n.x() * a / d;
  r->wy = n.y() * c / d;
  r->w0 = (n.x() * b + n.y() * e + n.z()) / d;
  const double ks = s.texels_per_m_s, kt = s.texels_per_m_t;
  r->sx = ks * u.x() * a;
  r->sy = ks * u.y() * c;
  r->s0n = ks * (u.x() * b + u.y() * e + u.z());
  r->s_off = ks * u.dot(o);
  r->tx = kt * v.x() * a;
  r->ty = kt * v.y() * c;
  r->t0n = kt * (v.x() * b + v.y() * e + v.z());
  r->t_off = kt * v.dot(o);
  r->texture = &textures[static_cast<size_t>(s.texture)];
  r->s_max = static_cast<float>(r->texture->levels[0].cols) + kEdgeTexels;
  r->t_max = static_cast<float>(r->texture->levels[0].rows) + kEdgeTexels;
  return true;
}

// Columns [x0, x1] of row y that may show the polygon (its span at y plus one pixel of slack;
// the exact inside test happens per pixel). False when the row misses it.
bool RowSpan(const Raster& r, int y, int width, int* x0, int* x1) {
  const double yc = std::clamp(static_cast<double>(y), r.y_min, r.y_max);
  double lo = 1e30, hi = -1e30;
  for (int i = 0; i < r.n; ++i) {
    const size_t j = static_cast<size_t>((i + 1) % r.n);
    const double ya = r.py[static_cast<size_t>(i)], yb = r.py[j];
    const double xa = r.px[static_cast<size_t>(i)], xb = r.px[j];
    if (yc < std::min(ya, yb) || yc > std::max(ya, yb)) continue;
    if (std::abs(yb - ya) < 1e-12) {
      lo = std::min({lo, xa, xb}), hi = std::max({hi, xa, xb});
    } else {
      const double x = xa + (yc - ya) * (xb - xa) / (yb - ya);
      lo = std::min(lo, x), hi = std::max(hi, x);
    }
  }
  if (lo > hi) return false;
  *x0 = static_cast<int>(std::max(0.0, std::floor(lo)));
  *x1 = static_cast<int>(std::min(width - 1.0, std::ceil(hi)));
  return *x0 <= *x1;
}

// Nearest mip level for a pixel footprint of sqrt(rho2) level-0 texels.
inline int MipLevelFor(float rho2, int levels) {
  const int level = rho2 < 2.0f     ? 0
                    : rho2 < 8.0f   ? 1
                    : rho2 < 32.0f  ? 2
                    : rho2 < 128.0f ? 3
                    : rho2 < 512.0f ? 4
                                    : 5;
  return std::min(level, levels - 1);
}

void DrawSurface(const Raster& r, int width, int height, float* inv_depth, cv::Mat& bgr) {
  const int y_begin = static_cast<int>(std::max(0.0, std::floor(r.y_min)));
  const int y_end = static_cast<int>(std::min(height - 1.0, std::ceil(r.y_max)));
  const float wx = static_cast<float>(r.wx), wy = static_cast<float>(r.wy);
  const float sx = static_cast<float>(r.sx), sy = static_cast<float>(r.sy);
  const float tx = static_cast<float>(r.tx), ty = static_cast<float>(r.ty);
  const float s_off = static_cast<float>(r.s_off), t_off = static_cast<float>(r.t_off);
  const MipLevel* levels = r.texture->levels.data();
  const int level_count = static_cast<int>(r.texture->levels.size());
  for (int y = y_begin; y <= y_end; ++y) {
    int x0 = 0, x1 = 0;
    if (!RowSpan(r, y, width, &x0, &x1)) continue;
    const float w_row = static_cast<float>(r.wy * y + r.w0);
    const float s_row = static_cast<float>(r.sy * y + r.s0n);
    const float t_row = static_cast<float>(r.ty * y + r.t0n);
    float* zrow = inv_depth + static_cast<size_t>(y) * width;
    uint8_t* crow = bgr.ptr<uint8_t>(y);
    for (int x = x0; x <= x1; ++x) {
      const float xf = static_cast<float>(x);
      const float w = wx * xf + w_row;
      if (!(w > zrow[x])) continue;  // behind the camera or hidden
      const float z = 1.0f / w;
      const float sz = (sx * xf + s_row) * z, tz = (tx * xf + t_row) * z;  // s + s_off, t + t_off
      const float s = sz - s_off, t = tz - t_off;
      if (s < -kEdgeTexels || s > r.s_max || t < -kEdgeTexels || t > r.t_max) continue;
      zrow[x] = w;
      // Texel footprint of the pixel: derivatives of (s, t) along x and y.
      const float dsdx = (sx - sz * wx) * z, dtdx = (tx - tz * wx) * z;
      const float dsdy = (sy - sz * wy) * z, dtdy = (ty - tz * wy) * z;
      const float rho2 = std::max(dsdx * dsdx + dtdx * dtdx, dsdy * dsdy + dtdy * dtdy);
      const MipLevel& m = levels[MipLevelFor(rho2, level_count)];
      const uint32_t texel = SampleBilinear(m, s * m.scale_s, t * m.scale_t);
      uint8_t* out = crow + 3 * x;
      out[0] = static_cast<uint8_t>(texel);
      out[1] = static_cast<uint8_t>(texel >> 8);
      out[2] = static_cast<uint8_t>(texel >> 16);
    }
  }
}

}  // namespace

StatusOr<Renderer> Renderer::Create(const Scene& scene, const CameraCalibration& camera) {
  SEMMAP_RETURN_IF_ERROR(ValidateScene(scene));
  SEMMAP_RETURN_IF_ERROR(ValidatePinhole(camera));
  auto prepared = std::make_shared<Prepared>();
  try {
    for (const cv::Mat& texture : scene.textures) {
      prepared->textures.push_back(PrepareTexture(texture));
    }
  } catch (const cv::Exception& e) {
    return InternalError(std::string("preparing textures failed: ") + e.what());
  }
  for (const Surface& s : scene.AllSurfaces()) {
    const cv::Mat& texture = scene.textures[static_cast<size_t>(s.texture)];
    prepared->surfaces.push_back(PreparedSurface{s.origin, s.u_axis, s.v_axis, s.Normal(), s.width,
                                                 s.height, texture.cols / s.width,
                                                 texture.rows / s.height, s.texture});
  }
  return Renderer(std::move(prepared), camera);
}

StatusOr<Renderer> Renderer::WithCamera(const CameraCalibration& camera) const {
  SEMMAP_RETURN_IF_ERROR(ValidatePinhole(camera));
  return Renderer(prepared_, camera);
}

RenderedFrame Renderer::Render(const Eigen::Isometry3d& T_world_camera) const {
  RenderedFrame frame;
  Render(T_world_camera, &frame);
  return frame;
}

void Renderer::Render(const Eigen::Isometry3d& T_world_camera, RenderedFrame* frame) const {
  const int width = camera_.width, height = camera_.height;
  frame->bgr.create(height, width, CV_8UC3);
  frame->bgr.setTo(cv::Scalar::all(0));
  frame->depth.create(height, width, CV_16UC1);
  std::vector<float> inv_depth(static_cast<size_t>(width) * height, 0.0f);

  const Eigen::Isometry3d T_camera_world = T_world_camera.inverse();
  const Vector3d camera_position = T_world_camera.translation();
  // Nearest surfaces first, so most hidden pixels fail the depth test before shading.
  std::vector<std::pair<double, const PreparedSurface*>> order;
  order.reserve(prepared_->surfaces.size());
  for (const PreparedSurface& s : prepared_->surfaces) {
    const Vector3d rel = camera_position - s.origin;
    const Vector3d nearest = s.origin + std::clamp(rel.dot(s.u), 0.0, s.width) * s.u +
                             std::clamp(rel.dot(s.v), 0.0, s.height) * s.v;
    order.emplace_back((camera_position - nearest).squaredNorm(), &s);
  }
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [distance, surface] : order) {
    Raster raster;
    if (!SetUpRaster(*surface, T_camera_world, camera_position, camera_, prepared_->textures,
                     &raster)) {
      continue;
    }
    DrawSurface(raster, width, height, inv_depth.data(), frame->bgr);
  }
  // Inverse depth to 16-bit depth; beyond the format's range (13.1 m) reads as no return.
  for (int y = 0; y < height; ++y) {
    const float* w = inv_depth.data() + static_cast<size_t>(y) * width;
    uint16_t* out = frame->depth.ptr<uint16_t>(y);
    for (int x = 0; x < width; ++x) {
      const float raw = w[x] > 0.0f ? static_cast<float>(kDepthScale) / w[x] + 0.5f : 0.0f;
      out[x] = raw < 65535.5f ? static_cast<uint16_t>(raw) : 0;
    }
  }
}

}  // namespace semmap::synth
