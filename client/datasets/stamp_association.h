// Colour/depth association by timestamp, with the rule of the TUM RGB-D benchmark's
// associate.py, so frame pairs match what published results were computed on.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace semmap {

// All pairs with |a - b| < max_difference_ns (strict) are candidates; they are accepted
// greedily by smallest |a - b| (ties: earlier a, then earlier b), each stamp used at most once.
// Returns, for each stamp of `a`, the index into `b` of its partner, or nullopt.
// Inputs need not be sorted.
std::vector<std::optional<size_t>> AssociateStamps(const std::vector<int64_t>& a,
                                                   const std::vector<int64_t>& b,
                                                   int64_t max_difference_ns);

}  // namespace semmap
