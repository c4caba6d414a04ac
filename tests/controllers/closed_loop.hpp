#pragma once
// A plant and a controller in closed loop for controller tests: the
// controller runs once per tick (zero-order hold), the plant integrates
// with RK4 over the tick.

#include <functional>
#include <memory>

#include "controllers/controller.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"

namespace lagrange::testing {

struct ClosedLoop {
  ClosedLoop(const PlantSpec& plant, std::unique_ptr<Controller> c, const VectorXd& q0, EffectsConfig effects = {},
             int substeps = 1)
      : model(MakeDynamics(plant, FastestMethod(plant.type())), std::move(effects)),
        controller(std::move(c)),
        q(q0),
        qd(VectorXd::Zero(q0.size())),
        tau(VectorXd::Zero(q0.size())),
        setpoint(static_cast<int>(q0.size())) {
    IntegratorConfig config;
    config.substeps = substeps;
    integrator = MakeIntegrator(config, static_cast<int>(q0.size()));
    setpoint.q = q0;
  }

  // Runs for `duration` s at tick `h`; `trajectory` (if given) sets the
  // setpoint before each tick; `observe` sees the state after each tick.
  // Returns false on a controller fault.
  bool Run(double duration, double h, const std::function<void(double, Setpoint&)>& trajectory = nullptr,
           const std::function<void(double)>& observe = nullptr) {
    const auto ticks = static_cast<long>(std::lround(duration / h));
    for (long k = 0; k < ticks; ++k) {
      if (trajectory) trajectory(t, setpoint);
      if (!controller->Compute(t, q, qd, setpoint, tau)) return false;
      integrator->Advance(model, t, h, tau, q, qd);
      t = static_cast<double>(k + 1) * h;
      if (observe) observe(t);
    }
    return true;
  }

  PlantModel model;
  std::unique_ptr<Controller> controller;
  std::unique_ptr<Integrator> integrator;
  VectorXd q, qd, tau;
  Setpoint setpoint;
  double t = 0.0;
};

}  // namespace lagrange::testing
