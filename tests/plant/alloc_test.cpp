// Stepping a plant allocates nothing once it is built: every plant type,
// every derivation method, every integrator, every effect on; nor does
// reading each effect's force and the energy balance.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "plant/energy_balance.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_spec.hpp"
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
            model.dynamics().ComputeGravityForce(q, scratch);
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

TEST(NoAllocation, TheCounterSeesEigenAndStandardAllocations) {
  testing::AllocationCounter counter;
  VectorXd v(1000);
  auto p = std::make_unique<int>(3);
  EXPECT_GE(counter.count(), 2);
  EXPECT_EQ(v.size() + *p, 1003);
}

}  // namespace
}  // namespace lagrange
