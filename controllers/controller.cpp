#include "controllers/controller.hpp"

#include <cmath>
#include <numbers>

namespace lagrange {

double JointError(JointType type, double desired, double measured) {
  const double e = desired - measured;
  if (type != JointType::kRevolute) return e;
  // Wrap to (−π, π]; exact for |e| within a few turns, and correct at any size.
  double w = std::remainder(e, 2.0 * std::numbers::pi);
  if (w <= -std::numbers::pi) w += 2.0 * std::numbers::pi;
  return w;
}

Controller::Controller(std::vector<JointType> joints, VectorXd torque_limits)
    : joints_(std::move(joints)), torque_limits_(std::move(torque_limits)) {}

bool Controller::Compute(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  ComputeLaw(t, q, qd, sp, tau);
  if (!tau.allFinite()) {
    tau.setZero();
    return false;
  }
  tau = tau.cwiseMax(-torque_limits_).cwiseMin(torque_limits_);
  return true;
}

bool Controller::SetGains(const Gains&) { return false; }

bool ValidJointGains(const Gains& g, int n) {
  return g.kp.size() == n && g.kd.size() == n && g.kp.allFinite() && g.kd.allFinite() &&
         (g.kp.array() >= 0.0).all() && (g.kd.array() >= 0.0).all();
}

std::optional<std::string> CheckJointGains(const Gains& g, int n) {
  for (const auto& [key, v] : {std::pair{"kp", &g.kp}, std::pair{"kd", &g.kd}}) {
    if (v->size() != n) {
      return std::string(key) + ": expected " + std::to_string(n) + " gains (one per joint), got " +
             std::to_string(v->size());
    }
    if (!v->allFinite() || (v->array() < 0.0).any()) {
      return std::string(key) + ": expected finite gains >= 0";
    }
  }
  return std::nullopt;
}

}  // namespace lagrange
