// "On average at most R events per second, with bursts of up to B": the operator's frame-rate
// limit per ingest session. A client pacing at or under R is never refused, whatever its timing
// jitter or a server stall that lets its frames arrive together (the bucket refills meanwhile).
// Not synchronised: its owner serialises the calls.
#pragma once

#include <algorithm>
#include <chrono>

namespace semmap {

class TokenBucket {
 public:
  using Clock = std::chrono::steady_clock;

  // Starts full. `rate_per_s` > 0, `burst` >= 1.
  TokenBucket(double rate_per_s, double burst, Clock::time_point now = Clock::now())
      : rate_per_s_(rate_per_s), burst_(burst), tokens_(burst), last_(now) {}

  // Takes one token at `now` and returns true, or returns false (taking nothing) when the
  // bucket is empty.
  bool TryTake(Clock::time_point now = Clock::now()) {
    if (now > last_) {
      const double elapsed_s = std::chrono::duration<double>(now - last_).count();
      tokens_ = std::min(burst_, tokens_ + elapsed_s * rate_per_s_);
      last_ = now;
    }
    if (tokens_ < 1.0) return false;
    tokens_ -= 1.0;
    return true;
  }

  double rate_per_s() const { return rate_per_s_; }

 private:
  double rate_per_s_;
  double burst_;
  double tokens_;
  Clock::time_point last_;
};

}  // namespace semmap
