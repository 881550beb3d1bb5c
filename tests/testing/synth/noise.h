// Sensor imperfections applied to rendered frames: Kinect-like depth noise, dropped depth
// pixels, colour noise, and motion blur (rendered by sequence_frame.h from poses across the
// exposure). Deterministic given the seed passed in; all off by default.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>

#include "common/status.h"

namespace semmap::synth {

struct NoiseOptions {
  // Axial depth noise of a structured-light sensor (Nguyen et al. 2012, Kinect v1):
  // sigma(z) = depth_sigma_a + depth_sigma_b * (z - 0.4 m)^2, Gaussian, in metres.
  bool depth_noise = false;
  double depth_sigma_a = 0.0012;
  double depth_sigma_b = 0.0019;
  // Each depth pixel independently reads 0 (no return) with this probability.
  double drop_depth_probability = 0.0;
  // Zero-mean Gaussian noise per colour channel, in 8-bit levels; 0 = off.
  double colour_noise_sigma = 0.0;
  // Motion blur: the colour image averages renders spread over the exposure, about one per
  // pixel of image motion and at most this many (0 or 1 = off); depth is not blurred.
  int motion_blur_samples = 0;
  double exposure = 0.5;  // fraction of the frame interval the shutter is open
};

// sigmas >= 0 and finite, probability in [0, 1], samples 0..64, exposure in (0, 1].
Status ValidateNoiseOptions(const NoiseOptions& options);

// Sigma of the depth noise at depth z metres.
double DepthNoiseSigma(const NoiseOptions& options, double z);

// In place on a CV_16UC1 depth image (units 1/depth_scale m); pixels at 0 stay 0.
void AddDepthNoise(const NoiseOptions& options, double depth_scale, uint64_t seed, cv::Mat* depth);
void DropDepthPixels(double probability, uint64_t seed, cv::Mat* depth);
// In place on a CV_8UC3 image.
void AddColourNoise(double sigma, uint64_t seed, cv::Mat* bgr);

}  // namespace semmap::synth
