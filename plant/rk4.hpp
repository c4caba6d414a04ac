#pragma once
// The classical fourth-order Runge–Kutta step on (q, qd), written once for any
// acceleration function qdd = f(t, q, qd). The RK4 integrator steps a
// PlantModel with it; bench/effects_bench.cpp steps bare Dynamics with it, as
// the baseline that shows what the effects layer costs.
//
// Buffers are allocated by the constructor; Step allocates nothing.

#include "plant/types.hpp"

namespace lagrange {

class Rk4Stepper {
 public:
  explicit Rk4Stepper(int n) : q1_(n), qd1_(n), dq_(n), dqd_(n), kq_(n), kqd_(n) {}

  // (t, h, q, qd) => (q, qd) at t + h. `acceleration(t, q, qd, qdd)` writes
  // qdd at (t, q, qd); it is called four times.
  template <class Acceleration>
  void Step(Acceleration&& acceleration, double t, double h, VecRef q, VecRef qd) {
    // Stage 1 at (q, qd).
    acceleration(t, q, qd, kqd_);
    dq_ = qd;
    dqd_ = kqd_;
    // Stages 2 and 3 at the midpoint, stage 4 at the end.
    kq_ = qd;
    for (int stage = 2; stage <= 4; ++stage) {
      const double a = stage == 4 ? h : 0.5 * h;
      const double w = stage == 4 ? 1.0 : 2.0;
      q1_ = q + a * kq_;
      qd1_ = qd + a * kqd_;
      acceleration(t + a, q1_, qd1_, kqd_);
      kq_ = qd1_;
      dq_ += w * kq_;
      dqd_ += w * kqd_;
    }
    q += (h / 6.0) * dq_;
    qd += (h / 6.0) * dqd_;
  }

 private:
  VectorXd q1_, qd1_, dq_, dqd_, kq_, kqd_;
};

}  // namespace lagrange
