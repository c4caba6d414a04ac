// Stepping a plant allocates nothing once it is built: every plant type,
// every derivation method, every integrator, every effect on; nor does
// reading each effect's force and the energy balance, nor switching effects,
// methods and integrator settings at run time.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "plant/energy_balance.hpp"
#include "plant/floating_integrator.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"
#include "plant/random_tree.hpp"
#include "plant/urdf.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

// A continuous-time law: PD towards zero, evaluated at every stage.
class PdLaw final : public ControlLaw {
 public:
  void Compute(double, ConstVecRef q, ConstVecRef qd, VecRef tau_cmd) override { tau_cmd = -5.0 * q - 0.5 * qd; }
};

TEST(NoAllocation, SteppingAPlantAllocatesNothing) {
  for (PlantType type : {PlantType::kPendulum, PlantType::kArm2, PlantType::kCartPole, PlantType::kChain}) {
    const PlantSpec spec = DefaultPlantSpec(type);
    const int n = spec.num_dofs();
    const EffectsConfig effects = testing::AllEffectsOn(n);
    for (Method method : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
      if (!HasMethod(type, method)) continue;
      for (IntegratorType it : {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler,
                                IntegratorType::kRk4, IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
        PlantModel model(MakeDynamics(spec, method), effects);
        IntegratorConfig config;
        config.type = it;
        config.substeps = 2;
        auto integrator = MakeIntegrator(config, n);
        VectorXd q = VectorXd::Constant(n, 0.4), qd = VectorXd::Constant(n, 0.3), tau = VectorXd::Constant(n, 0.2);
        VectorXd M(n), scratch(n);
        PdLaw law;
        std::int64_t allocations = 0;
        {
          testing::AllocationCounter counter;
          for (int k = 0; k < 50; ++k) {
            integrator->Advance(model, k * 1e-3, 1e-3, tau, q, qd);
            integrator->Advance(model, &law, k * 1e-3, 1e-3, tau, q, qd);
            model.Energy(q, qd);
            model.dynamics().ComputeGravityForce(model.data(), q, scratch);
          }
          allocations = counter.count();
        }
        EXPECT_EQ(allocations, 0) << ToString(type) << " " << ToString(method) << " " << ToString(it);
        EXPECT_TRUE(q.allFinite());
      }
    }
  }
}

// Each effect's force, the power and the energy balance, as a tick would
// read them: every plant type (a URDF robot too), every method, every effect on.
TEST(NoAllocation, ComputingEachEffectsForceAndTheEnergyBalanceAllocatesNothing) {
  std::vector<PlantSpec> specs;
  for (PlantType type : {PlantType::kPendulum, PlantType::kArm2, PlantType::kCartPole, PlantType::kChain}) {
    specs.push_back(DefaultPlantSpec(type));
  }
  specs.push_back(UrdfPlantSpec(
      std::make_shared<const UrdfRobot>(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf"))));
  for (const PlantSpec& spec : specs) {
    const int n = spec.num_dofs();
    for (Method method : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
      if (!HasMethod(spec.type(), method)) continue;
      PlantModel model(MakeDynamics(spec, method), testing::AllEffectsOn(n));
      EffectForces forces(n);
      EnergyBalance balance;
      VectorXd q = VectorXd::Constant(n, 1.1), qd = VectorXd::Constant(n, 0.3), tau = VectorXd::Constant(n, 5.0);
      PdLaw law;
      std::int64_t allocations = 0;
      {
        testing::AllocationCounter counter;
        balance.Reset(model.Energy(q, qd));
        for (int k = 0; k < 50; ++k) {
          model.ComputeEffectForces(k * 1e-3, q, qd, tau, forces);
          const double start = NonConservativePower(qd, forces);
          model.ComputeEffectForces(&law, (k + 1) * 1e-3, q, qd, tau, forces);
          balance.AddTick(1e-3, start, NonConservativePower(qd, forces), model.Energy(q, qd));
        }
        allocations = counter.count();
      }
      EXPECT_EQ(allocations, 0) << ToString(spec.type()) << " " << ToString(method);
      EXPECT_TRUE(std::isfinite(balance.residual()));
    }
  }
}

// Run-time switching, as the commands a tick takes would do it: every effect
// off and on again, every held method, new integrator numbers (taken and
// refused), and the non-conservative forces the energy balance reads.
TEST(NoAllocation, SwitchingEffectsMethodsAndIntegratorSettingsAllocatesNothing) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  const int n = spec.num_dofs();
  const Method methods[] = {Method::kClosedForm, Method::kLagrangian, Method::kRecursive};
  for (IntegratorType it : {IntegratorType::kRk4, IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
    PlantModel model(MakeDynamics(spec, Method::kClosedForm), testing::AllEffectsOn(n));
    model.AddDynamics(MakeDynamics(spec, Method::kLagrangian));
    model.AddDynamics(MakeDynamics(spec, Method::kRecursive));
    IntegratorConfig config;
    config.type = it;
    auto integrator = MakeIntegrator(config, n);
    IntegratorConfig other = config;
    other.substeps = 4;
    other.rtol = 1e-6;
    other.atol = 1e-9;
    other.newton_tol = 1e-12;
    IntegratorConfig bad = config;
    bad.substeps = 0;
    IntegratorConfig wrong_type = config;
    wrong_type.type = IntegratorType::kExplicitEuler;
    EffectForces forces(n);
    VectorXd q = VectorXd::Constant(n, 0.4), qd = VectorXd::Constant(n, 0.3), tau = VectorXd::Constant(n, 0.2);
    std::int64_t allocations = 0;
    int refused = 0;
    {
      testing::AllocationCounter counter;
      for (int k = 0; k < 20; ++k) {
        for (int e = 0; e < kNumEffectKinds; ++e) {
          const auto kind = static_cast<EffectKind>(e);
          // The variational integrator needs the Coriolis terms: leave them on for it.
          const bool off = k % 2 == 0 && !(it == IntegratorType::kVariational && kind == EffectKind::kCoriolis);
          model.effects().SetEnabled(kind, !off);
        }
        model.SelectMethod(methods[k % 3]);
        integrator->Reconfigure(k % 2 == 0 ? other : config);
        if (integrator->Reconfigure(bad) != nullptr) ++refused;
        if (integrator->Reconfigure(wrong_type) != nullptr) ++refused;
        integrator->Advance(model, k * 1e-3, 1e-3, tau, q, qd);
        model.ComputeEffectForces(nullptr, k * 1e-3, q, qd, tau, forces, false);
        model.Energy(q, qd);
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0) << ToString(it);
    EXPECT_EQ(refused, 40) << ToString(it);
    EXPECT_TRUE(q.allFinite()) << ToString(it);
  }
}

// The exact derivatives (plant/dynamics.hpp) and a step's (StepDerivatives):
// every plant type, URDF robots with a prismatic finger and a mimic, every
// method, every effect on, every integrator that has them, sub-steps.
TEST(NoAllocation, ComputingDerivativesAllocatesNothing) {
  std::vector<PlantSpec> specs;
  for (PlantType type : {PlantType::kPendulum, PlantType::kArm2, PlantType::kCartPole, PlantType::kChain}) {
    specs.push_back(DefaultPlantSpec(type));
  }
  for (const char* file : {"/config/robots/panda.urdf", "/config/robots/panda_hand.urdf"}) {
    specs.push_back(UrdfPlantSpec(std::make_shared<const UrdfRobot>(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + file))));
  }
  for (const PlantSpec& spec : specs) {
    const int n = spec.num_dofs();
    for (Method method : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
      if (!HasMethod(spec.type(), method)) continue;
      PlantModel model(MakeDynamics(spec, method), testing::AllEffectsOn(n));
      const Dynamics& dynamics = model.dynamics();
      StepDerivatives euler(IntegratorType::kExplicitEuler, n), semi(IntegratorType::kSemiImplicitEuler, n),
          rk4(IntegratorType::kRk4, n);
      VectorXd q = VectorXd::Constant(n, 0.4), qd = VectorXd::Constant(n, 0.3), tau = VectorXd::Constant(n, 0.2);
      VectorXd qdd(n);
      MatrixXd a(n, n), b(n, n), c(n, n), A(2 * n, 2 * n), B(2 * n, n);
      std::int64_t allocations = 0;
      {
        testing::AllocationCounter counter;
        for (int k = 0; k < 3; ++k) {
          dynamics.ComputeForwardDynamicsDerivatives(model.data(), q, qd, tau, DynamicsTerms{}, qdd, a, b, c);
          dynamics.ComputeForwardDynamicsDerivatives(model.data(), q, qd, tau, {.gravity = true, .coriolis = false},
                                                     qdd, a, b, c);
          dynamics.ComputeInverseDynamicsDerivatives(model.data(), q, qd, qdd, DynamicsTerms{}, a, b, c);
          dynamics.ComputeGravityDerivatives(model.data(), q, a);
          model.ComputeAccelerationDerivatives(k * 1e-3, q, qd, tau, qdd, a, b, c);
          euler.Step(model, k * 1e-3, 1e-3, q, qd, tau, A, B);
          semi.Step(model, k * 1e-3, 1e-3, q, qd, tau, A, B);
          rk4.Advance(model, k * 1e-3, 1e-3, 2, q, qd, tau, A, B);
        }
        allocations = counter.count();
      }
      EXPECT_EQ(allocations, 0) << ToString(spec.type()) << " " << n << " " << ToString(method);
      EXPECT_TRUE(A.allFinite() && B.allFinite());
    }
  }
}

// A floating base's variational step (Newton, its Jacobian built, kept and
// rebuilt), under gravity and joint torques, every sub-step after construction.
TEST(NoAllocation, SteppingAFloatingBaseVariationallyAllocatesNothing) {
  std::mt19937 rng{42};
  RandomTreeOptions options;
  options.bodies = 5;
  const FloatingDynamics model(RandomFloatingTree(options, rng));
  IntegratorConfig config;
  config.type = IntegratorType::kVariational;
  FloatingIntegrator integrator(config, model);
  VectorXd q = VectorXd::Zero(model.num_q()), v = VectorXd::Constant(model.num_v(), 0.3);
  q[6] = 1.0;
  VectorXd tau = VectorXd::Constant(model.num_v(), 0.2);
  tau.head<kFreeFlyerNv>().setZero();
  std::int64_t allocations = 0;
  {
    testing::AllocationCounter counter;
    for (int k = 0; k < 50; ++k) {
      integrator.Step(k < 25 ? 1e-3 : 5e-4, tau, {}, q, v);  // a new h rebuilds the Jacobian
      if (k == 40) integrator.Reconfigure(config);           // and so does a reconfiguration
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(integrator.stats().failures, 0);
  EXPECT_TRUE(q.allFinite() && v.allFinite());
}

TEST(NoAllocation, TheCounterSeesEigenAndStandardAllocations) {
  testing::AllocationCounter counter;
  VectorXd v(1000);
  auto p = std::make_unique<int>(3);
  EXPECT_GE(counter.count(), 2);
  EXPECT_EQ(v.size() + *p, 1003);
}

}  // namespace
}  // namespace lagrange
