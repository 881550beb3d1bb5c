#include "client/eval/statistics.h"

#include <algorithm>
#include <cmath>

namespace semmap {

ErrorStatistics ErrorStatistics::Scaled(double factor) const {
  ErrorStatistics s = *this;
  s.rmse *= factor;
  s.mean *= factor;
  s.median *= factor;
  s.std *= factor;
  s.min *= factor;
  s.max *= factor;
  return s;
}

StatusOr<ErrorStatistics> ComputeStatistics(const std::vector<double>& errors) {
  if (errors.empty()) return InvalidArgumentError("no errors to summarise");
  ErrorStatistics s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum = 0;
  double sum_squares = 0;
  for (double e : errors) {
    if (!std::isfinite(e)) return InvalidArgumentError("a per-pose error is not finite");
    sum += e;
    sum_squares += e * e;
  }
  s.rmse = std::sqrt(sum_squares / n);
  s.mean = sum / n;
  double deviation_squares = 0;  // two-pass, as numpy.std: mean of |e - mean|^2
  for (double e : errors) deviation_squares += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(deviation_squares / n);

  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  const size_t half = sorted.size() / 2;
  s.median = sorted.size() % 2 == 1 ? sorted[half] : 0.5 * (sorted[half - 1] + sorted[half]);
  s.min = sorted.front();
  s.max = sorted.back();
  return s;
}

}  // namespace semmap
