// Reading the text files tests check (TUM lists and trajectories).
#pragma once

#include <string>
#include <vector>

namespace semmap::testing {

// The lines of a TUM-style text file that are neither blank nor comments ('#').
std::vector<std::string> DataLines(const std::string& path);

}  // namespace semmap::testing
