#pragma once
// The external controller: the law is a user's program on the bus.
//
// Law:    tau = tau_ext [+ G(q)], tau_ext the latest torque streamed over LCM
//         (torque_t, validated by the daemon's receiver), held until the next
//         one; G(q) from the controller's model when compensate_gravity is on
//         (the client then commands the torque beyond gravity, as with
//         Franka's FCI).
// Inputs: q (for G); the setpoint is not used.
// Output: tau (n), within the torque limits.
// State:  tau_ext, zero after Reset() and until the first SetTorque.
// Gains:  none.

#include <memory>

#include "controllers/controller.hpp"

namespace lagrange {

class ExternalController final : public Controller {
 public:
  // `model` may be null when compensate_gravity is off.
  ExternalController(std::vector<JointType> joints, VectorXd torque_limits, std::shared_ptr<const Dynamics> model,
                     bool compensate_gravity);
  std::string_view name() const override { return "external"; }
  void Reset() override { tau_ext_.setZero(); }

  // The latest streamed torque (n), N·m or N; no allocation.
  void SetTorque(ConstVecRef tau) { tau_ext_ = tau; }
  const VectorXd& torque() const { return tau_ext_; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;

 private:
  std::shared_ptr<const Dynamics> model_;  // shared, immutable (plant/dynamics.hpp)
  std::unique_ptr<DynamicsData> data_;     // this controller's data for it
  bool compensate_gravity_;
  VectorXd tau_ext_, g_;
};

}  // namespace lagrange
