// A one-line progress display (frames, frames/s, ETA) on stderr, only when stderr is a terminal.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace semmap::cli {

class ProgressBar {
 public:
  ProgressBar(uint64_t total, bool enabled);
  void Update(uint64_t done, const std::string& note = "");  // redraws at most 10 times/s
  void Done();

 private:
  void Draw(uint64_t done, const std::string& note);
  uint64_t total_;
  bool enabled_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  uint64_t last_done_ = 0;
};

}  // namespace semmap::cli
