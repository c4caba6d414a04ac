#pragma once
// The statistics every benchmark program computes, one definition each.
//
// Percentiles are by nearest rank (protocol/status.hpp), as lagranged's status_t reports its
// wake-up latency and compute time (daemon/publisher.cpp): the p-th
// percentile of n samples is the ceil(p n)-th smallest (p in (0, 1]), always a
// sample that was measured, never an interpolation between two. (The report,
// bench/report.py, interpolates linearly, as numpy does, over the raw files
// the programs write; these are the figures a program computes itself.)

#include <cstddef>
#include <limits>
#include <span>
#include <vector>

namespace lagrange::bench {

// The ceil(p n)-th smallest of `v` (p in (0, 1]; below 1/n it is the
// smallest); NaN for no samples. Reorders `v` (std::nth_element, no allocation).
double Percentile(std::span<double> v, double p);

// The arithmetic mean; NaN for no samples.
double Mean(std::span<const double> v);

// p50, p99 and max of a sample (Percentile); NaN for none.
struct Summary {
  std::size_t n = 0;
  double p50 = std::numeric_limits<double>::quiet_NaN();
  double p99 = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
};
Summary Summarize(std::vector<double> v);

}  // namespace lagrange::bench
