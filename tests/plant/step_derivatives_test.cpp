// Exact derivatives through the scene's effects (PlantModel::
// ComputeAccelerationDerivatives, plant/effects.hpp) and through one
// integrator step (StepDerivatives, plant/integrators.hpp): each against
// central differences of what the simulation itself computes (the effects'
// acceleration, Integrator::Step and Advance), the documented derivative at
// each kink, and the step's limit as h → 0.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <string>

#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::CentralDifferences;
using testing::RelativeDifference;

constexpr double kDifferenceTol = 1e-6;  // against central differences, relative
constexpr double kStep = 1e-6;           // central-difference step, × max(1, |x|)

// Smooth effects that act at this state: damping, friction, a stop pressed
// (joint 0 past its upper limit at 1, moving out), saturation not reached.
EffectsConfig SmoothEffects(int n) {
  EffectsConfig c;
  c.damping = VectorXd::Constant(n, 0.3);
  c.friction = CoulombFriction{VectorXd::Constant(n, 0.2), 0.5};
  c.limits = JointLimits{VectorXd::Constant(n, -1.0), VectorXd::Constant(n, 1.0), 100.0, 1.0};
  c.saturation = VectorXd::Constant(n, 40.0);
  c.disturbance = {Push{0.0, 10.0, VectorXd::Constant(n, 0.7)}};
  return c;
}

struct State {
  VectorXd q, qd, tau;
};
State StateFor(int n) {
  State s{VectorXd::LinSpaced(n, 1.05, -0.4), VectorXd::LinSpaced(n, -0.3, 0.6), VectorXd::LinSpaced(n, 0.5, -1.5)};
  return s;
}

std::vector<testing::PlantCase> Cases() {
  std::vector<testing::PlantCase> cases = testing::AllPlantCases();
  cases.push_back({"panda_hand", UrdfPlantSpec(std::make_shared<const UrdfRobot>(
                                     LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda_hand.urdf")))});
  return cases;
}

TEST(AccelerationDerivatives, WithEveryEffectOnMatchDifferencesOfTheSimulatedAcceleration) {
  for (const testing::PlantCase& c : Cases()) {
    for (Method method : testing::MethodsOf(c.spec.type())) {
      const int n = c.spec.num_dofs();
      PlantModel model(MakeDynamics(c.spec, method), SmoothEffects(n));
      const State s = StateFor(n);
      VectorXd qdd(n);
      MatrixXd dq(n, n), dqd(n, n), dtau(n, n);
      model.ComputeAccelerationDerivatives(0.5, s.q, s.qd, s.tau, qdd, dq, dqd, dtau);
      const auto acc = [&](const VectorXd& q, const VectorXd& qd, const VectorXd& tau, VectorXd& out) {
        model.ComputeAcceleration(0.5, q, qd, tau, out);
      };
      VectorXd expected(n);
      acc(s.q, s.qd, s.tau, expected);
      const std::string what = c.name + " " + std::string(ToString(method));
      EXPECT_LT((qdd - expected).norm(), 1e-12 * std::max(1.0, expected.norm())) << what;
      EXPECT_LT(
          RelativeDifference(
              dq, CentralDifferences([&](const VectorXd& x, VectorXd& o) { acc(x, s.qd, s.tau, o); }, s.q, n, kStep)),
          kDifferenceTol)
          << what;
      EXPECT_LT(
          RelativeDifference(
              dqd, CentralDifferences([&](const VectorXd& x, VectorXd& o) { acc(s.q, x, s.tau, o); }, s.qd, n, kStep)),
          kDifferenceTol)
          << what;
      EXPECT_LT(
          RelativeDifference(
              dtau, CentralDifferences([&](const VectorXd& x, VectorXd& o) { acc(s.q, s.qd, x, o); }, s.tau, n, kStep)),
          kDifferenceTol)
          << what;
    }
  }
}

// At the kinks of the non-smooth effects the derivative is that of the branch
// the force takes: a saturated command has none, nor a joint exactly on its
// stop, nor a stop whose damper would pull; a command exactly at its bound
// passes (derivative 1); a pressed stop adds −k and −d.
TEST(AccelerationDerivatives, AtAKinkTheDerivativeIsThatOfTheBranchTheForceTakes) {
  EffectsConfig c;
  c.limits = JointLimits{VectorXd::Constant(4, -1.0), VectorXd::Constant(4, 1.0), 500.0, 5.0};
  c.saturation = VectorXd::Constant(4, 2.0);
  Effects effects(c, 4);
  VectorXd q(4), qd(4), tau(4), dq(4), dqd(4), dcmd(4);
  q << 1.0, 1.2, 1.2, 0.0;    // on the stop; past it, moving out; past it, moving in fast; inside
  qd << 0.0, 0.5, -200.0, 0.0;  // joint 2's damper would pull: −k 0.2 − d (−200) > 0, so the force is 0
  tau << 2.0, -2.0, 3.0, -5.0;  // at the bound (both signs), beyond both
  effects.ComputeGeneralizedForceDerivatives(q, qd, tau, dq, dqd, dcmd);
  EXPECT_EQ(dq[0], 0.0);
  EXPECT_EQ(dq[1], -500.0);
  EXPECT_EQ(dqd[1], -5.0);
  EXPECT_EQ(dq[2], 0.0);
  EXPECT_EQ(dqd[2], 0.0);
  EXPECT_EQ(dq[3], 0.0);
  EXPECT_EQ(dcmd[0], 1.0);
  EXPECT_EQ(dcmd[1], 1.0);
  EXPECT_EQ(dcmd[2], 0.0);
  EXPECT_EQ(dcmd[3], 0.0);
}

// x⁺ = Φ(x, tau, h) of the integrator itself (Step), and of a tick in sub-steps (Advance).
void ExpectStepMatchesDifferences(const PlantSpec& spec, Method method, IntegratorType type, int substeps,
                                  const EffectsConfig& effects, const std::string& name) {
  const int n = spec.num_dofs();
  PlantModel model(MakeDynamics(spec, method), effects);
  IntegratorConfig config;
  config.type = type;
  config.substeps = substeps;
  auto integrator = MakeIntegrator(config, n);
  const State s = StateFor(n);
  const double dt = 0.002;  // short enough that no joint reaches a kink within it
  StepDerivatives derivatives(type, n);
  MatrixXd A(2 * n, 2 * n), B(2 * n, n);
  derivatives.Advance(model, 0.0, dt, substeps, s.q, s.qd, s.tau, A, B);
  const auto step = [&](const VectorXd& x, const VectorXd& tau, VectorXd& out) {
    VectorXd q = x.head(n), qd = x.tail(n);
    integrator->Advance(model, 0.0, dt, tau, q, qd);
    out << q, qd;
  };
  VectorXd x(2 * n), end(2 * n);
  x << s.q, s.qd;
  step(x, s.tau, end);
  const std::string what = name + " " + std::string(ToString(method)) + " " + std::string(ToString(type)) + " × " +
                           std::to_string(substeps);
  EXPECT_LT((derivatives.q_next() - end.head(n)).norm() + (derivatives.qd_next() - end.tail(n)).norm(),
            1e-12 * std::max(1.0, end.norm()))
      << what;
  EXPECT_LT(RelativeDifference(
                A, CentralDifferences([&](const VectorXd& y, VectorXd& o) { step(y, s.tau, o); }, x, 2 * n, kStep)),
            kDifferenceTol)
      << what;
  EXPECT_LT(RelativeDifference(
                B, CentralDifferences([&](const VectorXd& y, VectorXd& o) { step(x, y, o); }, s.tau, 2 * n, kStep)),
            kDifferenceTol)
      << what;
}

TEST(StepDerivatives, EachIntegratorsStepMatchesDifferencesOfTheStepItself) {
  for (const testing::PlantCase& c : Cases()) {
    if (c.name != "arm2" && c.name != "cartpole" && c.name != "chain3" && c.name != "panda_hand") continue;
    const int n = c.spec.num_dofs();
    for (IntegratorType type :
         {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4}) {
      ExpectStepMatchesDifferences(c.spec, FastestMethod(c.spec.type()), type, 1, EffectsConfig{}, c.name);
      ExpectStepMatchesDifferences(c.spec, FastestMethod(c.spec.type()), type, 3, SmoothEffects(n),
                                   c.name + " with effects");
    }
  }
}

// A = I + h F + O(h²), F = [[0, I], [∂qdd/∂q, ∂qdd/∂qd]]: (A − I)/h → F
// linearly in h (explicit Euler's A is I + h F exactly).
TEST(StepDerivatives, AsTheStepShrinksATendsToIdentityPlusHTimesTheLinearisedField) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  const int n = 2;
  PlantModel model(MakeDynamics(spec, Method::kClosedForm), SmoothEffects(n));
  const State s = StateFor(n);
  VectorXd qdd(n);
  MatrixXd dq(n, n), dqd(n, n), dtau(n, n);
  model.ComputeAccelerationDerivatives(0.0, s.q, s.qd, s.tau, qdd, dq, dqd, dtau);
  MatrixXd F = MatrixXd::Zero(2 * n, 2 * n);
  F.topRightCorner(n, n).setIdentity();
  F.bottomLeftCorner(n, n) = dq;
  F.bottomRightCorner(n, n) = dqd;
  for (IntegratorType type :
       {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4}) {
    StepDerivatives derivatives(type, n);
    MatrixXd A(2 * n, 2 * n), B(2 * n, n);
    double previous = 0.0;
    for (double h : {1e-2, 1e-3, 1e-4}) {
      derivatives.Step(model, 0.0, h, s.q, s.qd, s.tau, A, B);
      const double error = ((A - MatrixXd::Identity(2 * n, 2 * n)) / h - F).norm() / F.norm();
      EXPECT_LT(error, 50.0 * h) << ToString(type) << " h " << h;  // first order in h
      if (type == IntegratorType::kExplicitEuler) {
        EXPECT_LT(error, 1e-12) << " h " << h;
      } else if (previous > 0.0) {
        EXPECT_LT(error, 0.2 * previous) << ToString(type) << " h " << h;
      }
      previous = error;
      EXPECT_LT((B / h).bottomRows(n).cwiseAbs().maxCoeff(), 2.0 * dtau.cwiseAbs().maxCoeff());
    }
  }
}

TEST(StepDerivatives, IntegratorsWithoutThemAreRefusedNamingThoseThatHaveThem) {
  for (IntegratorType type : {IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
    try {
      StepDerivatives derivatives(type, 2);
      ADD_FAILURE() << ToString(type) << " was accepted";
    } catch (const std::invalid_argument& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(std::string(ToString(type))), std::string::npos) << message;
      EXPECT_NE(message.find("explicit-euler, semi-implicit-euler or rk4"), std::string::npos) << message;
    }
  }
}

}  // namespace
}  // namespace lagrange
