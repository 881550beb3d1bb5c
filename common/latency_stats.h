// Collects latency samples of one pipeline stage and summarises them (p50/p95/max/mean).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace semmap {

struct LatencySummary {
  std::string name;
  uint64_t count = 0;
  double p50_ms = 0, p95_ms = 0, max_ms = 0, mean_ms = 0;
};

class LatencyStats {
 public:
  explicit LatencyStats(std::string name) : name_(std::move(name)) {}
  void Add(double ms);
  // Percentiles by nearest rank over every sample kept (the first 1M; enough for any session).
  LatencySummary Summarize() const;

 private:
  static constexpr size_t kMaxSamples = 1u << 20;
  std::string name_;
  std::vector<float> samples_;
  uint64_t count_ = 0;
  double sum_ = 0, max_ = 0;
};

}  // namespace semmap
