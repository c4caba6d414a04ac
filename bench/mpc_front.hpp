#pragma once
// The logic of bench/mpc_sweep.cpp that can be wrong without a build of the
// simulator: which runs are on the work-precision front, and from when a
// condition held to the end of a run. The standard library alone, so that
// tests/bench/mpc_front_test.cpp compiles it in seconds.

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace lagrange::bench {

// One run on the front's axes: both to be minimised.
struct FrontPoint {
  double time = 0.0;      // s, the mean solve time
  double cost = 0.0;      // the closed-loop tracking cost
  bool eligible = false;  // a successful run (a failure is never on the front)
};

// on[i]: point i is eligible, finite, and no other such point is as good on
// both axes and better on one (it is not dominated). Equal points are both on it.
inline std::vector<bool> ParetoFront(const std::vector<FrontPoint>& points) {
  auto usable = [](const FrontPoint& p) { return p.eligible && std::isfinite(p.time) && std::isfinite(p.cost); };
  std::vector<bool> on(points.size(), false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!usable(points[i])) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < points.size() && !dominated; ++j) {
      const FrontPoint& a = points[j];
      const FrontPoint& b = points[i];
      dominated = j != i && usable(a) && a.time <= b.time && a.cost <= b.cost && (a.time < b.time || a.cost < b.cost);
    }
    on[i] = !dominated;
  }
  return on;
}

// Follows a run's samples in time order: Since() is the time of the first
// sample from which `ok` held at every sample to the latest, NaN while the
// latest sample did not hold (a run that ends outside never "held").
class HeldSince {
 public:
  void Add(double t, bool ok) {
    if (!ok) {
      since_ = kNan;
    } else if (std::isnan(since_)) {
      since_ = t;
    }
  }
  double Since() const { return since_; }
  // Held over at least the last `span` s of samples ending at `t_end`.
  bool HeldFor(double span, double t_end) const { return !std::isnan(since_) && t_end - since_ >= span - 1e-9; }

 private:
  static constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  double since_ = kNan;
};

}  // namespace lagrange::bench
