#include "tests/testing/synth/noise.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "tests/testing/synth/rng.h"

namespace semmap::synth {
namespace {

// An approximately standard normal value from 64 random bits: the sum of four 16-bit uniforms
// (Irwin-Hall), rescaled; much cheaper than Box-Muller and plenty for sensor noise.
inline float FastNormal(uint64_t bits) {
  const uint32_t sum =
      static_cast<uint32_t>(bits & 0xFFFF) + static_cast<uint32_t>((bits >> 16) & 0xFFFF) +
      static_cast<uint32_t>((bits >> 32) & 0xFFFF) + static_cast<uint32_t>(bits >> 48);
  // Mean 2 * 65535, variance 4 * 65536^2 / 12.
  constexpr float kScale = 1.7320508f / 65536.0f;
  return (static_cast<float>(sum) - 131070.0f) * kScale;
}

}  // namespace

Status ValidateNoiseOptions(const NoiseOptions& o) {
  if (!std::isfinite(o.depth_sigma_a) || !std::isfinite(o.depth_sigma_b) || o.depth_sigma_a < 0 ||
      o.depth_sigma_b < 0) {
    return InvalidArgumentError("depth noise sigmas must be finite and >= 0");
  }
  if (!(o.drop_depth_probability >= 0 && o.drop_depth_probability <= 1)) {
    return InvalidArgumentError("drop-depth probability must be in [0, 1], got " +
                                std::to_string(o.drop_depth_probability));
  }
  if (!std::isfinite(o.colour_noise_sigma) || o.colour_noise_sigma < 0) {
    return InvalidArgumentError("colour noise sigma must be finite and >= 0");
  }
  if (o.motion_blur_samples < 0 || o.motion_blur_samples > 64) {
    return InvalidArgumentError("motion blur samples must be 0..64, got " +
                                std::to_string(o.motion_blur_samples));
  }
  if (!(o.exposure > 0 && o.exposure <= 1)) {
    return InvalidArgumentError("exposure must be in (0, 1] of the frame interval");
  }
  return OkStatus();
}

double DepthNoiseSigma(const NoiseOptions& options, double z) {
  const double dz = z - 0.4;
  return options.depth_sigma_a + options.depth_sigma_b * dz * dz;
}

void AddDepthNoise(const NoiseOptions& options, double depth_scale, uint64_t seed, cv::Mat* depth) {
  Rng rng(seed);
  for (int y = 0; y < depth->rows; ++y) {
    uint16_t* row = depth->ptr<uint16_t>(y);
    for (int x = 0; x < depth->cols; ++x) {
      const uint64_t bits = rng.NextU64();
      if (row[x] == 0) continue;
      const double z = row[x] / depth_scale;
      const double noisy = (z + DepthNoiseSigma(options, z) * FastNormal(bits)) * depth_scale;
      row[x] = static_cast<uint16_t>(std::clamp(std::lround(noisy), 1L, 65535L));
    }
  }
}

void DropDepthPixels(double probability, uint64_t seed, cv::Mat* depth) {
  if (probability <= 0) return;
  Rng rng(seed);
  // Compare 32-bit uniforms with a fixed threshold; two pixels per random draw.
  const uint64_t threshold = static_cast<uint64_t>(std::ldexp(std::min(probability, 1.0), 32));
  for (int y = 0; y < depth->rows; ++y) {
    uint16_t* row = depth->ptr<uint16_t>(y);
    for (int x = 0; x < depth->cols; x += 2) {
      const uint64_t bits = rng.NextU64();
      if ((bits & 0xFFFFFFFFu) < threshold) row[x] = 0;
      if (x + 1 < depth->cols && (bits >> 32) < threshold) row[x + 1] = 0;
    }
  }
}

void AddColourNoise(double sigma, uint64_t seed, cv::Mat* bgr) {
  if (sigma <= 0) return;
  Rng rng(seed);
  const float s = static_cast<float>(sigma);
  for (int y = 0; y < bgr->rows; ++y) {
    uint8_t* row = bgr->ptr<uint8_t>(y);
    const int n = bgr->cols * bgr->channels();
    for (int i = 0; i < n; ++i) {
      const float v = static_cast<float>(row[i]) + s * FastNormal(rng.NextU64()) + 0.5f;
      row[i] = static_cast<uint8_t>(std::clamp(v, 0.0f, 255.0f));
    }
  }
}

}  // namespace semmap::synth
