#pragma once
// Rate limits for what the receive and publish threads write: log lines and
// replies. Neither allocates, locks or reads a clock: the caller passes the time.

#include <algorithm>
#include <cstdint>

namespace lagrange {

// At most one line per second; counts what it held back.
class LogThrottle {
 public:
  // True when a line may be written at `now_us`; `suppressed` then says how
  // many were held back since the last one (and is reset).
  bool Allow(std::int64_t now_us, std::int64_t& suppressed) {
    if (now_us - last_us_ < 1'000'000) {
      ++held_;
      return false;
    }
    suppressed = held_;
    held_ = 0;
    last_us_ = now_us;
    return true;
  }

 private:
  std::int64_t last_us_ = -1'000'000'000;
  std::int64_t held_ = 0;
};

// At most `rate` events per second on average, in bursts of up to `burst`.
class TokenBucket {
 public:
  TokenBucket(double rate, double burst) : rate_(rate), burst_(burst), tokens_(burst) {}
  bool Take(std::int64_t now_us) {
    if (last_us_ >= 0) tokens_ = std::min(burst_, tokens_ + rate_ * static_cast<double>(now_us - last_us_) * 1e-6);
    last_us_ = now_us;
    if (tokens_ < 1.0) return false;
    tokens_ -= 1.0;
    return true;
  }

 private:
  double rate_, burst_, tokens_;
  std::int64_t last_us_ = -1;
};

}  // namespace lagrange
