#include "bench/stats.hpp"

#include "protocol/status.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace lagrange::bench {

double Percentile(std::span<double> v, double p) { return NearestRankPercentile(v, p); }

double Mean(std::span<const double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

Summary Summarize(std::vector<double> v) {
  Summary s;
  s.n = v.size();
  if (v.empty()) return s;
  s.p50 = Percentile(v, 0.50);
  s.p99 = Percentile(v, 0.99);
  s.max = *std::max_element(v.begin(), v.end());
  return s;
}

}  // namespace lagrange::bench
