#pragma once
// One running plant instance: its model, integrator and state, built from an
// InstanceConfig. Everything is allocated in the constructor; Step allocates
// nothing.

#include <memory>

#include "daemon/scene.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_model.hpp"

namespace lagrange {

class Instance {
 public:
  explicit Instance(const InstanceConfig& config);

  const InstanceConfig& config() const { return config_; }
  const std::string& name() const { return config_.name; }
  int num_dofs() const { return model_.num_dofs(); }

  double t() const { return t_; }           // simulated time, s
  const VectorXd& q() const { return q_; }
  const VectorXd& qd() const { return qd_; }
  const VectorXd& tau() const { return tau_; }  // applied generalized force (after saturation) of the last step

  // (tau_cmd) => (q, qd) at t + dt. False when the integrator failed its tolerance.
  bool Step(double dt, ConstVecRef tau_cmd);
  // Back to the initial state at t = 0.
  void Reset();

  double KineticEnergy() { return model_.KineticEnergy(q_, qd_); }
  double PotentialEnergy() { return model_.PotentialEnergy(q_); }

  PlantModel& model() { return model_; }
  const Integrator& integrator() const { return *integrator_; }

 private:
  InstanceConfig config_;
  PlantModel model_;
  std::unique_ptr<Integrator> integrator_;
  double t_ = 0.0;
  std::int64_t steps_ = 0;
  VectorXd q_, qd_, tau_;
};

}  // namespace lagrange
