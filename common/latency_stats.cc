#include "common/latency_stats.h"

#include <algorithm>
#include <cmath>

namespace semmap {

void LatencyStats::Add(double ms) {
  ++count_;
  sum_ += ms;
  max_ = std::max(max_, ms);
  if (samples_.size() < kMaxSamples) samples_.push_back(static_cast<float>(ms));
}

LatencySummary LatencyStats::Summarize() const {
  LatencySummary s;
  s.name = name_;
  s.count = count_;
  if (count_ == 0) return s;
  std::vector<float> sorted = samples_;
  std::sort(sorted.begin(), sorted.end());
  auto rank = [&](double p) {
    const size_t k = static_cast<size_t>(std::ceil(p * sorted.size()));
    return static_cast<double>(sorted[std::clamp<size_t>(k, 1, sorted.size()) - 1]);
  };
  s.p50_ms = rank(0.50);
  s.p95_ms = rank(0.95);
  s.max_ms = max_;
  s.mean_ms = sum_ / count_;
  return s;
}

}  // namespace semmap
