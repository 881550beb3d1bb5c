// Deterministic pseudo-random numbers for the synthetic scene. SplitMix64 gives the same
// sequence for a seed on every platform, unlike std::*_distribution whose algorithms the
// standard leaves to each library; everything random in semmap_synth goes through this.
#pragma once

#include <cmath>
#include <cstdint>

namespace semmap::synth {

// SplitMix64's finaliser: a bijective, well-mixing hash of 64 bits.
constexpr uint64_t Mix64(uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ULL;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBULL;
  x ^= x >> 31;
  return x;
}

// A seed for one independent stream (a texture, a frame's noise...) derived from the scene
// seed, a stream tag and an index, so streams do not depend on the order they are drawn in.
constexpr uint64_t DeriveSeed(uint64_t seed, uint64_t stream, uint64_t index = 0) {
  return Mix64(Mix64(seed ^ Mix64(stream + 0x632BE59BD9B4E019ULL)) + index);
}

class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}

  uint64_t NextU64() {
    state_ += 0x9E3779B97F4A7C15ULL;
    return Mix64(state_);
  }
  // Uniform in [0, 1).
  double Uniform() { return static_cast<double>(NextU64() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [lo, hi] (hi >= lo).
  int UniformInt(int lo, int hi) {
    const uint64_t span = static_cast<uint64_t>(static_cast<int64_t>(hi) - lo) + 1;
    return lo + static_cast<int>(NextU64() % span);
  }
  bool Bernoulli(double p) { return Uniform() < p; }
  // Standard normal (Box-Muller; one value per call, the partner is dropped for simplicity).
  double Normal() {
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  uint64_t state_;
};

}  // namespace semmap::synth
