#pragma once
// The native module _lagrange, one Bind function per part, each in its own
// translation unit (module.cpp calls them in this order).

#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <string>

namespace lagrange {
class Dynamics;
enum class IntegratorType : std::uint8_t;  // base/vocabulary.hpp
enum class PlantType : std::uint8_t;       // plant/plant_factory.hpp
}  // namespace lagrange

namespace lagrange::python {

// lagrange.Model: dynamics and kinematics of one plant, single states and batches (model.cpp).
void BindModel(pybind11::module_& m);
// The dynamics of a lagrange.Model object (model.cpp), for calls bound in other files; TypeError for another object.
std::shared_ptr<const Dynamics> ModelDynamics(pybind11::handle model);
// The plant type of a lagrange.Model object (model.cpp): the cart-pole's cart is the default actuated joint.
PlantType ModelPlantType(pybind11::handle model);
// The integrator `name` names, one with step derivatives (explicit-euler, semi-implicit-euler, rk4), or
// ValueError naming the argument `integrator` (derivatives.cpp).
IntegratorType StepIntegrator(const std::string& name);
// lagrange.Model's derivative calls, added to the class BindModel made (derivatives.cpp).
void BindDerivatives(pybind11::module_& m);
// lagrange.optimize_trajectory: the box-DDP solver of model-predictive control, offline (trajectory.cpp).
void BindTrajectory(pybind11::module_& m);
// lagrange.simulate and the stepping interface: scenes run by the daemon's Instance code (simulate.cpp).
void BindSimulate(pybind11::module_& m);
// lagrange.Client and lagrange.read_log: the project's bus, client and log reader (bus.cpp).
void BindBus(pybind11::module_& m);

}  // namespace lagrange::python
