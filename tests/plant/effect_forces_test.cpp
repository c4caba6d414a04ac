// Each term of the equation of motion, separately (PlantModel::ComputeEffectForces):
// the terms add up to M q̈ as ComputeAcceleration integrates it, each is its
// own effect's force, and an effect that is off is neither computed nor non-zero.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "plant/plant_factory.hpp"
#include "plant/plant_model.hpp"
#include "plant/urdf.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

constexpr double kSumTol = 1e-12;      // relative to the sum of the terms' norms
constexpr double kFormulaTol = 1e-14;  // one formula evaluated two ways
constexpr double kPushActive = 1.0;    // s: AllEffectsOn's push acts on [0, 10)
constexpr double kPushOver = 11.0;     // s
constexpr int kStatesPerConfig = 20;

VectorXd Vec(std::initializer_list<double> xs) {
  VectorXd v(static_cast<int>(xs.size()));
  int i = 0;
  for (double x : xs) v[i++] = x;
  return v;
}

// The arm, the cart-pole and a robot from config/robots/.
std::vector<testing::PlantCase> Plants() {
  std::vector<testing::PlantCase> cases{{"arm2", DefaultPlantSpec(PlantType::kArm2)},
                                        {"cartpole", DefaultPlantSpec(PlantType::kCartPole)}};
  const std::string panda = std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf";
  cases.push_back({"panda", UrdfPlantSpec(std::make_shared<const UrdfRobot>(LoadUrdf(panda)))});
  return cases;
}

// One effect: its kind, its flag, its stage counter, its term, and how to leave it out of a config.
struct Effect {
  std::string name;
  EffectKind kind;
  bool EffectFlags::*flag;
  std::int64_t StageCounts::*count;
  VectorXd EffectForces::*term;  // null: saturation, whose "term" is tau_applied − tau_cmd
  std::function<void(EffectsConfig&)> switch_off;
};

const std::vector<Effect>& EffectTable() {
  static const std::vector<Effect> effects = {
      {"gravity", EffectKind::kGravity, &EffectFlags::gravity, &StageCounts::gravity, &EffectForces::gravity,
       [](EffectsConfig& c) { c.gravity = false; }},
      {"coriolis", EffectKind::kCoriolis, &EffectFlags::coriolis, &StageCounts::coriolis, &EffectForces::coriolis,
       [](EffectsConfig& c) { c.coriolis = false; }},
      {"damping", EffectKind::kDamping, &EffectFlags::damping, &StageCounts::damping, &EffectForces::damping,
       [](EffectsConfig& c) { c.damping.reset(); }},
      {"friction", EffectKind::kFriction, &EffectFlags::friction, &StageCounts::friction, &EffectForces::friction,
       [](EffectsConfig& c) { c.friction.reset(); }},
      {"limits", EffectKind::kLimits, &EffectFlags::limits, &StageCounts::limits, &EffectForces::limits,
       [](EffectsConfig& c) { c.limits.reset(); }},
      {"disturbance", EffectKind::kDisturbance, &EffectFlags::disturbance, &StageCounts::disturbance,
       &EffectForces::disturbance, [](EffectsConfig& c) { c.disturbance.clear(); }},
      {"saturation", EffectKind::kSaturation, &EffectFlags::saturation, &StageCounts::saturation, nullptr,
       [](EffectsConfig& c) { c.saturation.reset(); }},
  };
  return effects;
}

// Every effect on, then each one off in turn.
std::vector<std::pair<std::string, EffectsConfig>> Configs(int n) {
  std::vector<std::pair<std::string, EffectsConfig>> configs{{"all on", testing::AllEffectsOn(n)}};
  for (const Effect& e : EffectTable()) {
    EffectsConfig c = testing::AllEffectsOn(n);
    e.switch_off(c);
    configs.emplace_back(e.name + " off", std::move(c));
  }
  return configs;
}

double MaxAbs(const VectorXd& v) { return v.lpNorm<Eigen::Infinity>(); }

// Every term EffectForces holds.
constexpr VectorXd EffectForces::*kAllTerms[] = {
    &EffectForces::gravity,     &EffectForces::coriolis, &EffectForces::damping,
    &EffectForces::friction,    &EffectForces::limits,   &EffectForces::limit_springs,
    &EffectForces::disturbance, &EffectForces::tau_cmd,  &EffectForces::tau_applied};

// Exact equality, element by element: two models that run the same
// operations on the same numbers agree to the last bit, and a switch that
// changed anything else (another stage, another order) would show here.
bool BitIdentical(const VectorXd& a, const VectorXd& b) {
  return a.size() == b.size() && (a.array() == b.array()).all();
}

// M q̈ = tau_applied + disturbance + damping + friction + limits − C q̇ − G, with
// q̈ from ComputeAcceleration and M from the dynamics, on every plant, method
// and configuration; the effects that are off ran no stage and left zeros.
TEST(EffectForces, TermsAddUpToMassTimesTheIntegratedAcceleration) {
  std::mt19937 rng{42};
  for (const testing::PlantCase& plant : Plants()) {
    const int n = plant.spec.num_dofs();
    for (Method method : testing::MethodsOf(plant.spec.type())) {
      for (const auto& [config_name, config] : Configs(n)) {
        PlantModel model(MakeDynamics(plant.spec, method), config);
        EffectForces forces(n);
        VectorXd qdd(n), net(n), Mqdd(n);
        MatrixXd M(n, n);
        for (int k = 0; k < kStatesPerConfig; ++k) {
          const std::string where =
              plant.name + " " + std::string(ToString(method)) + " " + config_name + " state " + std::to_string(k);
          // Half the states past a stop (at ±1), and half the time outside the push.
          const double span = k % 2 == 0 ? 0.9 : 1.3;
          const VectorXd q = testing::RandomVector(n, -span, span, rng);
          const VectorXd qd = testing::RandomVector(n, -3.0, 3.0, rng);
          const VectorXd tau_cmd = testing::RandomVector(n, -6.0, 6.0, rng);
          const double t = k % 4 < 2 ? kPushActive : kPushOver;

          const StageCounts before = model.counts();
          model.ComputeEffectForces(t, q, qd, tau_cmd, forces);
          const StageCounts after = model.counts();
          for (const Effect& e : EffectTable()) {
            const bool on = model.effects().flags().*e.flag;
            EXPECT_EQ(forces.active.*e.flag, on) << where << ": " << e.name;
            EXPECT_EQ(after.*e.count - before.*e.count, on ? 1 : 0) << where << ": " << e.name << " stage runs";
            if (!on && e.term != nullptr) {
              EXPECT_EQ(MaxAbs(forces.*e.term), 0.0) << where << ": " << e.name;
            }
          }

          model.ComputeAcceleration(t, q, qd, tau_cmd, qdd);
          model.dynamics().ComputeMassMatrix(model.data(), q, M);
          Mqdd.noalias() = M * qdd;
          forces.NetForce(net);
          const double scale = forces.tau_applied.norm() + forces.disturbance.norm() + forces.damping.norm() +
                               forces.friction.norm() + forces.limits.norm() + forces.coriolis.norm() +
                               forces.gravity.norm();
          ASSERT_LE((Mqdd - net).norm(), kSumTol * scale) << where;
        }
      }
    }
  }
}

TEST(EffectForces, EachTermIsItsOwnEffectsForce) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  const EffectsConfig config = testing::AllEffectsOn(2);  // b 0.3, Fc 0.2, v_s 0.1, stops ±1 (k 500, d 5), sat 4
  PlantModel model(MakeDynamics(spec, Method::kClosedForm), config);
  auto reference = MakeDynamics(spec, Method::kLagrangian);
  const std::unique_ptr<DynamicsData> reference_data = reference->MakeData();
  const VectorXd q = Vec({1.02, -0.5}), qd = Vec({0.4, -0.05}), tau_cmd = Vec({-7.0, 1.5});
  EffectForces f(2);
  model.ComputeEffectForces(kPushActive, q, qd, tau_cmd, f);

  VectorXd G(2);
  MatrixXd C(2, 2);
  reference->ComputeGravityForce(*reference_data, q, G);
  reference->ComputeCoriolisMatrix(*reference_data, q, qd, C);
  EXPECT_LE(MaxAbs(f.gravity - G), kFormulaTol * (1.0 + MaxAbs(G)));
  EXPECT_LE(MaxAbs(f.coriolis - C * qd), kFormulaTol * (1.0 + MaxAbs(C * qd)));
  EXPECT_LE(MaxAbs(f.damping - Vec({-0.3 * 0.4, 0.3 * 0.05})), kFormulaTol);
  EXPECT_LE(MaxAbs(f.friction - Vec({-0.2 * std::tanh(4.0), 0.2 * std::tanh(0.5)})), kFormulaTol);
  // Joint 1 is 0.02 past its upper stop, moving out: spring and damper push back.
  EXPECT_LE(MaxAbs(f.limits - Vec({-500.0 * 0.02 - 5.0 * 0.4, 0.0})), 1e-12);
  EXPECT_LE(MaxAbs(f.limit_springs - Vec({-500.0 * 0.02, 0.0})), 1e-12);
  EXPECT_LE(MaxAbs(f.disturbance - Vec({0.7, 0.7})), kFormulaTol);
  EXPECT_LE(MaxAbs(f.tau_cmd - tau_cmd), kFormulaTol);
  EXPECT_LE(MaxAbs(f.tau_applied - Vec({-4.0, 1.5})), kFormulaTol);

  model.ComputeEffectForces(kPushOver, q, qd, tau_cmd, f);
  EXPECT_EQ(MaxAbs(f.disturbance), 0.0);  // the stage runs, no push acts
  EXPECT_TRUE(f.active.disturbance);
}

TEST(EffectForces, EffectsThatAreOffAreNeverEvaluatedAndReadZeroInAReusedStruct) {
  constexpr int kCalls = 25;
  const PlantSpec spec = DefaultPlantSpec(PlantType::kCartPole);
  EffectsConfig none;
  none.gravity = false;
  none.coriolis = false;
  PlantModel all(MakeDynamics(spec, Method::kClosedForm), testing::AllEffectsOn(2));
  PlantModel bare(MakeDynamics(spec, Method::kClosedForm), none);
  const VectorXd q = Vec({0.3, 1.2}), qd = Vec({-1.0, 2.0}), tau_cmd = Vec({5.0, -0.5});
  EffectForces f(2);
  for (int k = 0; k < kCalls; ++k) {
    all.ComputeEffectForces(kPushActive, q, qd, tau_cmd, f);   // every term non-zero here ...
    bare.ComputeEffectForces(kPushActive, q, qd, tau_cmd, f);  // ... and none after this
  }
  for (const Effect& e : EffectTable()) {
    EXPECT_EQ(bare.counts().*e.count, 0) << e.name;
    EXPECT_EQ(all.counts().*e.count, kCalls) << e.name;
    EXPECT_FALSE(f.active.*e.flag) << e.name;
    if (e.term != nullptr) {
      EXPECT_EQ(MaxAbs(f.*e.term), 0.0) << e.name;
    }
  }
  EXPECT_EQ(MaxAbs(f.limit_springs), 0.0);
  EXPECT_EQ(MaxAbs(f.tau_applied - tau_cmd), 0.0);  // no saturation: the command as it is
}

// A law that returns a fixed torque.
class ConstantLaw final : public ControlLaw {
 public:
  explicit ConstantLaw(VectorXd tau) : tau_(std::move(tau)) {}
  void Compute(double, ConstVecRef, ConstVecRef, VecRef tau_cmd) override { tau_cmd = tau_; }

 private:
  VectorXd tau_;
};

TEST(EffectForces, WithALawTheCommandIsTheLawsOutput) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  PlantModel model(MakeDynamics(spec, Method::kClosedForm), testing::AllEffectsOn(2));
  const VectorXd q = Vec({0.2, -0.1}), qd = Vec({0.5, 0.5}), law_tau = Vec({9.0, -1.0});
  const VectorXd ignored = VectorXd::Constant(2, std::nan(""));  // tau_cmd is not read when a law is passed
  ConstantLaw law(law_tau);
  EffectForces f(2);
  model.ComputeEffectForces(&law, kPushActive, q, qd, ignored, f);
  EXPECT_LE(MaxAbs(f.tau_cmd - law_tau), kFormulaTol);
  EXPECT_LE(MaxAbs(f.tau_applied - Vec({4.0, -1.0})), kFormulaTol);
  VectorXd net(2), qdd(2), Mqdd(2);
  MatrixXd M(2, 2);
  f.NetForce(net);
  model.ComputeAcceleration(&law, kPushActive, q, qd, ignored, qdd);
  model.dynamics().ComputeMassMatrix(model.data(), q, M);
  Mqdd = M * qdd;
  EXPECT_LE((Mqdd - net).norm(), kSumTol * (1.0 + net.norm()));
}

// Switching an effect off at run time stops its stage (its count stays flat
// over forces and accelerations), zeroes its term, and leaves exactly the
// plant a scene without that effect would build.
TEST(EffectForces, AnEffectSwitchedOffIsNeverEvaluatedAndItsTermIsZero) {
  constexpr int kCalls = 10;
  std::mt19937 rng{42};
  for (const testing::PlantCase& plant : Plants()) {
    const int n = plant.spec.num_dofs();
    for (Method method : testing::MethodsOf(plant.spec.type())) {
      for (const Effect& e : EffectTable()) {
        const std::string where = plant.name + " " + std::string(ToString(method)) + " " + e.name;
        PlantModel switched(MakeDynamics(plant.spec, method), testing::AllEffectsOn(n));
        EffectsConfig without = testing::AllEffectsOn(n);
        e.switch_off(without);
        PlantModel built(MakeDynamics(plant.spec, method), without);
        ASSERT_TRUE(switched.effects().SetEnabled(e.kind, false)) << where;
        EXPECT_FALSE(switched.effects().flags().*e.flag) << where;

        EffectForces f(n), expected(n);
        VectorXd qdd(n), expected_qdd(n);
        const StageCounts before = switched.counts();
        for (int k = 0; k < kCalls; ++k) {
          const VectorXd q = testing::RandomVector(n, -1.3, 1.3, rng);
          const VectorXd qd = testing::RandomVector(n, -3.0, 3.0, rng);
          const VectorXd tau_cmd = testing::RandomVector(n, -6.0, 6.0, rng);
          switched.ComputeEffectForces(kPushActive, q, qd, tau_cmd, f);
          built.ComputeEffectForces(kPushActive, q, qd, tau_cmd, expected);
          for (VectorXd EffectForces::*term : kAllTerms) {
            ASSERT_TRUE(BitIdentical(f.*term, expected.*term)) << where << " state " << k;
          }
          if (e.term != nullptr) {
            ASSERT_EQ(MaxAbs(f.*e.term), 0.0) << where;
          } else {
            ASSERT_TRUE(BitIdentical(f.tau_applied, tau_cmd)) << where;  // saturation off: the command as it is
          }
          switched.ComputeAcceleration(kPushActive, q, qd, tau_cmd, qdd);
          built.ComputeAcceleration(kPushActive, q, qd, tau_cmd, expected_qdd);
          ASSERT_TRUE(BitIdentical(qdd, expected_qdd)) << where << " state " << k;
        }
        const StageCounts after = switched.counts();
        for (const Effect& other : EffectTable()) {
          const std::int64_t runs = after.*other.count - before.*other.count;
          // Every other stage ran once per force call and once per acceleration.
          EXPECT_EQ(runs, other.name == e.name ? 0 : 2 * kCalls) << where << ": " << other.name << " stage runs";
        }
      }
    }
  }
}

TEST(EffectForces, AnEffectSwitchedBackOnGivesExactlyTheForcesOfAPlantBuiltWithIt) {
  std::mt19937 rng{7};
  for (const testing::PlantCase& plant : Plants()) {
    const int n = plant.spec.num_dofs();
    for (Method method : testing::MethodsOf(plant.spec.type())) {
      PlantModel switched(MakeDynamics(plant.spec, method), testing::AllEffectsOn(n));
      PlantModel built(MakeDynamics(plant.spec, method), testing::AllEffectsOn(n));
      for (const Effect& e : EffectTable()) {
        const std::string where = plant.name + " " + std::string(ToString(method)) + " " + e.name;
        ASSERT_TRUE(switched.effects().SetEnabled(e.kind, false)) << where;
        ASSERT_TRUE(switched.effects().SetEnabled(e.kind, true)) << where;
        const VectorXd q = testing::RandomVector(n, -1.3, 1.3, rng);
        const VectorXd qd = testing::RandomVector(n, -3.0, 3.0, rng);
        const VectorXd tau_cmd = testing::RandomVector(n, -6.0, 6.0, rng);
        EffectForces f(n), expected(n);
        switched.ComputeEffectForces(kPushActive, q, qd, tau_cmd, f);
        built.ComputeEffectForces(kPushActive, q, qd, tau_cmd, expected);
        EXPECT_TRUE(f.active.*e.flag) << where;
        for (VectorXd EffectForces::*term : kAllTerms) EXPECT_TRUE(BitIdentical(f.*term, expected.*term)) << where;
        VectorXd qdd(n), expected_qdd(n);
        switched.ComputeAcceleration(kPushActive, q, qd, tau_cmd, qdd);
        built.ComputeAcceleration(kPushActive, q, qd, tau_cmd, expected_qdd);
        EXPECT_TRUE(BitIdentical(qdd, expected_qdd)) << where;
        EXPECT_EQ(switched.Energy(q, qd), built.Energy(q, qd)) << where;
      }
    }
  }
}

// conservative = false, for the energy balance: G and C qd are neither
// evaluated nor counted, and every other term is the full call's.
TEST(EffectForces, NonConservativeCallLeavesGravityAndCoriolisOutAndEveryOtherTermAsIs) {
  std::mt19937 rng{11};
  for (const testing::PlantCase& plant : Plants()) {
    const int n = plant.spec.num_dofs();
    for (Method method : testing::MethodsOf(plant.spec.type())) {
      const std::string where = plant.name + " " + std::string(ToString(method));
      PlantModel model(MakeDynamics(plant.spec, method), testing::AllEffectsOn(n));
      EffectForces full(n), partial(n);
      for (int k = 0; k < kStatesPerConfig; ++k) {
        const VectorXd q = testing::RandomVector(n, -1.3, 1.3, rng);
        const VectorXd qd = testing::RandomVector(n, -3.0, 3.0, rng);
        const VectorXd tau_cmd = testing::RandomVector(n, -6.0, 6.0, rng);
        const double t = k % 2 == 0 ? kPushActive : kPushOver;
        model.ComputeEffectForces(nullptr, t, q, qd, tau_cmd, full, true);
        const StageCounts before = model.counts();
        model.ComputeEffectForces(nullptr, t, q, qd, tau_cmd, partial, false);
        const StageCounts after = model.counts();
        EXPECT_EQ(after.gravity, before.gravity) << where;
        EXPECT_EQ(after.coriolis, before.coriolis) << where;
        EXPECT_EQ(MaxAbs(partial.gravity), 0.0) << where;
        EXPECT_EQ(MaxAbs(partial.coriolis), 0.0) << where;
        ASSERT_GT(MaxAbs(full.gravity), 0.0) << where;  // so the zeros above were left out, not computed
        for (VectorXd EffectForces::*term : kAllTerms) {
          if (term == &EffectForces::gravity || term == &EffectForces::coriolis) continue;
          ASSERT_TRUE(BitIdentical(partial.*term, full.*term)) << where << " state " << k;
        }
        // Every other stage still ran once.
        for (const Effect& e : EffectTable()) {
          if (e.kind == EffectKind::kGravity || e.kind == EffectKind::kCoriolis) continue;
          EXPECT_EQ(after.*e.count - before.*e.count, 1) << where << ": " << e.name;
        }
      }
    }
  }
}

}  // namespace
}  // namespace lagrange
