#pragma once
// Plants every physics test runs over, and seeded random states.

#include <functional>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "plant/effects.hpp"
#include "plant/plant_factory.hpp"

namespace lagrange::testing {

struct PlantCase {
  std::string name;
  PlantSpec spec;
};
// GoogleTest prints a case by its name.
inline void PrintTo(const PlantCase& c, std::ostream* os) { *os << c.name; }

// Pendulum (point and rod), arm2, cart-pole, and chains of 1, 2, 3 and 7
// links with seeded random, unequal link parameters.
std::vector<PlantCase> AllPlantCases();

// The chain of tests/fixtures/urdf/planar_chain.urdf (its comment says so):
// base angle 0.3 rad, four links, the third prismatic.
ChainParams PlanarChainOfTheFixture();

// The derivation methods a plant type has (closed-form, lagrangian, recursive), in that order.
std::vector<Method> MethodsOf(PlantType type);

// q uniform in [−π, π] for revolute joints and [−2, 2] m for prismatic ones;
// qd uniform in [−3, 3].
struct RandomState {
  VectorXd q, qd;
};
RandomState RandomStateFor(const std::vector<JointType>& joints, std::mt19937& rng);
VectorXd RandomVector(int n, double lo, double hi, std::mt19937& rng);

// Every effect on, sized for n joints: damping 0.3, Coulomb friction 0.2 (v_s 0.1),
// stops at ±1 (k 500, d 5), saturation 4, and a push of 0.7 from t = 0 to 10 s.
EffectsConfig AllEffectsOn(int n);

// G(q) and M(q) of `spec` by `method`, from a model and data made for the
// call: for tests that need one value.
VectorXd GravityOf(const PlantSpec& spec, Method method, const VectorXd& q);
MatrixXd MassMatrixOf(const PlantSpec& spec, Method method, const VectorXd& q);

// Relative difference ‖a − b‖ / max(‖a‖, ‖b‖, floor).
double RelativeDifference(const MatrixXd& a, const MatrixXd& b, double floor = 1.0);

// The Jacobian (m x n) of f: Rⁿ → Rᵐ at x by central differences, each step
// `step` × max(1, |x_j|).
MatrixXd CentralDifferences(const std::function<void(const VectorXd&, VectorXd&)>& f, const VectorXd& x, int m,
                            double step);

}  // namespace lagrange::testing
