// Summary statistics of per-pose errors, computed as numpy computes them in the TUM and KITTI
// tools: rmse = sqrt(sum e^2 / n), the arithmetic mean, numpy's median (mean of the two middle
// values for an even count), the population standard deviation (numpy's default, ddof = 0),
// min and max.
#pragma once

#include <cstddef>
#include <vector>

#include "common/status.h"

namespace semmap {

struct ErrorStatistics {
  size_t count = 0;
  double rmse = 0;
  double mean = 0;
  double median = 0;
  double std = 0;
  double min = 0;
  double max = 0;

  // Every value multiplied by `factor` (> 0), e.g. radians to degrees.
  ErrorStatistics Scaled(double factor) const;
};

// INVALID_ARGUMENT for an empty input or a non-finite error.
StatusOr<ErrorStatistics> ComputeStatistics(const std::vector<double>& errors);

}  // namespace semmap
