#include "tests/testing/text_lines.h"

#include <fstream>

namespace semmap::testing {

std::vector<std::string> DataLines(const std::string& path) {
  std::ifstream file(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(file, line);) {
    if (!line.empty() && line[0] != '#') lines.push_back(line);
  }
  return lines;
}

}  // namespace semmap::testing
