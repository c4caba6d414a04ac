#include "controllers/cartpole_pd.hpp"

#include <stdexcept>

namespace lagrange {

CartPolePdController::CartPolePdController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains)
    : Controller(std::move(joints), std::move(torque_limits)), gains_(std::move(gains)) {
  GainBounds any_sign = GainBounds::Unbounded(num_dofs());
  any_sign.any_sign = true;
  if (num_dofs() != 2) throw std::invalid_argument("cartpole-pd: expected a cart-pole (2 joints)");
  if (auto fault = FindGainFault(gains_, any_sign))
    throw std::invalid_argument(DescribeGainFault(*fault, gains_, any_sign));
  set_gain_bounds(std::move(any_sign));
}

void CartPolePdController::ApplyGains(const Gains& gains) {
  gains_.kp = gains.kp;
  gains_.kd = gains.kd;
}

void CartPolePdController::ComputeLaw(double, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  double u = 0.0;
  for (int i = 0; i < 2; ++i) {
    u += gains_.kp[i] * Error(i, sp.q[i], q[i]) + gains_.kd[i] * (sp.qd[i] - qd[i]);
  }
  tau[0] = u;
  tau[1] = 0.0;
}

}  // namespace lagrange
