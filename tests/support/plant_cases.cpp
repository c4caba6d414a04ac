#include "tests/support/plant_cases.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lagrange::testing {

std::vector<Method> MethodsOf(PlantType type) {
  std::vector<Method> methods;
  for (Method m : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
    if (HasMethod(type, m)) methods.push_back(m);
  }
  return methods;
}

std::vector<PlantCase> AllPlantCases() {
  std::vector<PlantCase> cases;
  cases.push_back({"pendulum_point", DefaultPlantSpec(PlantType::kPendulum)});
  PendulumParams rod;
  rod.body = PendulumBody::kRod;
  rod.m = 2.0;
  rod.L = 0.7;
  cases.push_back({"pendulum_rod", {rod}});
  cases.push_back({"arm2", DefaultPlantSpec(PlantType::kArm2)});
  cases.push_back({"cartpole", DefaultPlantSpec(PlantType::kCartPole)});
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> mass(0.3, 2.0), length(0.2, 1.0), frac(0.1, 0.9);
  for (int links : {1, 2, 3, 7}) {
    ChainParams p;
    p.links.resize(static_cast<std::size_t>(links));
    for (ChainLink& l : p.links) {
      l.m = mass(rng);
      l.L = length(rng);
      l.com = frac(rng) * l.L;
      l.I = 0.5 * l.m * l.L * l.L / 12.0;
    }
    p.base_angle = -0.3;
    cases.push_back({"chain" + std::to_string(links), {p}});
  }
  return cases;
}

VectorXd RandomVector(int n, double lo, double hi, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(lo, hi);
  VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = u(rng);
  return v;
}

RandomState RandomStateFor(const std::vector<JointType>& joints, std::mt19937& rng) {
  const int n = static_cast<int>(joints.size());
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), pos(-2.0, 2.0);
  RandomState s{VectorXd(n), RandomVector(n, -3.0, 3.0, rng)};
  for (int i = 0; i < n; ++i) s.q[i] = joints[i] == JointType::kRevolute ? angle(rng) : pos(rng);
  return s;
}

EffectsConfig AllEffectsOn(int n) {
  EffectsConfig c;
  c.damping = VectorXd::Constant(n, 0.3);
  c.friction = CoulombFriction{VectorXd::Constant(n, 0.2), 0.1};
  c.limits = JointLimits{VectorXd::Constant(n, -1.0), VectorXd::Constant(n, 1.0), 500.0, 5.0};
  c.saturation = VectorXd::Constant(n, 4.0);
  c.disturbance = {Push{0.0, 10.0, VectorXd::Constant(n, 0.7)}};
  return c;
}

MatrixXd CentralDifferences(const std::function<void(const VectorXd&, VectorXd&)>& f, const VectorXd& x, int m,
                            double step) {
  MatrixXd J(m, x.size());
  VectorXd xs = x, plus(m), minus(m);
  for (int j = 0; j < x.size(); ++j) {
    const double h = step * std::max(1.0, std::abs(x[j]));
    xs[j] = x[j] + h;
    f(xs, plus);
    xs[j] = x[j] - h;
    f(xs, minus);
    xs[j] = x[j];
    J.col(j) = (plus - minus) / (2.0 * h);
  }
  return J;
}

double RelativeDifference(const MatrixXd& a, const MatrixXd& b, double floor) {
  return (a - b).norm() / std::max({a.norm(), b.norm(), floor});
}

VectorXd GravityOf(const PlantSpec& spec, Method method, const VectorXd& q) {
  const std::unique_ptr<Dynamics> model = MakeDynamics(spec, method);
  VectorXd G(model->num_dofs());
  model->ComputeGravityForce(*model->MakeData(), q, G);
  return G;
}

MatrixXd MassMatrixOf(const PlantSpec& spec, Method method, const VectorXd& q) {
  const std::unique_ptr<Dynamics> model = MakeDynamics(spec, method);
  MatrixXd M(model->num_dofs(), model->num_dofs());
  model->ComputeMassMatrix(*model->MakeData(), q, M);
  return M;
}

ChainParams PlanarChainOfTheFixture() {
  ChainParams p;
  p.base_angle = 0.3;
  p.links = {{1.2, 0.5, 0.2, 0.03, JointType::kRevolute},
             {0.8, 0.4, 0.2, 0.011, JointType::kRevolute},
             {0.5, 0.3, 0.1, 0.004, JointType::kPrismatic},
             {0.3, 0.25, 0.125, 0.002, JointType::kRevolute}};
  return p;
}

}  // namespace lagrange::testing
