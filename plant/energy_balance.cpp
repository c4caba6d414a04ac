#include "plant/energy_balance.hpp"

#include <cmath>

namespace lagrange {

namespace {

// Row i of every force whose energy V does not hold.
double NonConservativeForce(const EffectForces& f, int i) {
  return f.tau_applied[i] + f.disturbance[i] + f.damping[i] + f.friction[i] + f.limits[i] - f.limit_springs[i];
}

}  // namespace

double NonConservativePower(ConstVecRef qd, const EffectForces& f) {
  double p = 0.0;
  for (int i = 0; i < qd.size(); ++i) p += qd[i] * NonConservativeForce(f, i);
  return p;
}

double HeldWork(ConstVecRef q_start, ConstVecRef q_end, const EffectForces& f) {
  double w = 0.0;
  for (int i = 0; i < q_start.size(); ++i) w += (q_end[i] - q_start[i]) * NonConservativeForce(f, i);
  return w;
}

void EnergyBalance::Reset(double energy) {
  *this = EnergyBalance{};
  energy0_ = energy;
  energy_ = energy;
}

void EnergyBalance::Rebase(double energy) {
  energy0_ += energy - energy_;
  energy_ = energy;
  slope_known_ = false;
}

void EnergyBalance::AddTickWithWork(double h, double command_work, double rest_start, double rest_end,
                                    double energy_end) {
  work_ += command_work;
  AddTick(h, rest_start, rest_end, energy_end);
}

void EnergyBalance::AddTick(double h, double power_start, double power_end, double energy_end) {
  work_ += 0.5 * h * (power_start + power_end);
  energy_ = energy_end;
  const double slope = (power_end - power_start) / h;
  if (ticks_ >= 1 && slope_known_) {
    // h³/12 |P''| with P'' from the two slopes; the first tick takes the second's estimate.
    const double second_derivative = std::abs(slope - last_slope_) / (0.5 * (h + last_h_));
    quadrature_bound_ += h * h * h / 12.0 * second_derivative;
    if (ticks_ == 1) quadrature_bound_ += last_h_ * last_h_ * last_h_ / 12.0 * second_derivative;
  }
  last_slope_ = slope;
  last_h_ = h;
  slope_known_ = true;
  ++ticks_;
}

}  // namespace lagrange
