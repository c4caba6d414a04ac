// Each effect's generalized force matches its formula; an effect a scene
// leaves out is never evaluated; energy balances power in and dissipation.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "plant/plant_factory.hpp"
#include "plant/plant_model.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

constexpr double kTol = 1e-14;
constexpr int kEvaluations = 25;

VectorXd Vec(std::initializer_list<double> xs) {
  VectorXd v(static_cast<int>(xs.size()));
  int i = 0;
  for (double x : xs) v[i++] = x;
  return v;
}

VectorXd Force(Effects& e, double t, const VectorXd& q, const VectorXd& qd, const VectorXd& tau_cmd) {
  VectorXd tau(q.size());
  e.ComputeGeneralizedForce(t, q, qd, tau_cmd, tau);
  return tau;
}

TEST(Effects, DampingIsMinusCoefficientTimesVelocity) {
  EffectsConfig c;
  c.damping = Vec({0.5, 2.0});
  Effects e(c, 2);
  const VectorXd tau = Force(e, 0.0, Vec({0.1, 0.2}), Vec({3.0, -1.5}), Vec({0.0, 0.0}));
  EXPECT_NEAR(tau[0], -1.5, kTol);
  EXPECT_NEAR(tau[1], 3.0, kTol);
}

TEST(Effects, CoulombFrictionIsRegularisedByTanhOfVelocityOverScale) {
  EffectsConfig c;
  c.friction = CoulombFriction{Vec({2.0, 1.0}), 0.05};
  Effects e(c, 2);
  const VectorXd tau = Force(e, 0.0, Vec({0.0, 0.0}), Vec({0.05, -10.0}), Vec({0.0, 0.0}));
  EXPECT_NEAR(tau[0], -2.0 * std::tanh(1.0), kTol);  // 76 % of Fc at |qd| = v_s
  EXPECT_NEAR(tau[1], 1.0, 1e-12);                   // saturates at Fc far from zero
  const VectorXd at_rest = Force(e, 0.0, Vec({0.0, 0.0}), Vec({0.0, 0.0}), Vec({0.0, 0.0}));
  EXPECT_EQ(at_rest.norm(), 0.0);  // smooth through zero velocity: no force at rest
}

TEST(Effects, JointLimitsPushOutPastTheStopAndNeverPullIn) {
  EffectsConfig c;
  c.limits = JointLimits{Vec({-1.0, -1.0}), Vec({1.0, 1.0}), 1000.0, 10.0};
  Effects e(c, 2);
  const VectorXd zero = Vec({0.0, 0.0});
  // Inside the range: no force.
  EXPECT_EQ(Force(e, 0.0, Vec({0.99, -0.99}), Vec({5.0, -5.0}), zero).norm(), 0.0);
  // Past the upper stop moving out: spring plus damper, pushing back.
  VectorXd tau = Force(e, 0.0, Vec({1.01, 0.0}), Vec({0.5, 0.0}), zero);
  EXPECT_NEAR(tau[0], -1000.0 * 0.01 - 10.0 * 0.5, 1e-12);
  // Past the lower stop: pushes up.
  tau = Force(e, 0.0, Vec({0.0, -1.02}), Vec({0.0, 0.0}), zero);
  EXPECT_NEAR(tau[1], 1000.0 * 0.02, 1e-12);
  // Leaving the stop fast: the damper would pull the joint in; the stop only releases.
  tau = Force(e, 0.0, Vec({1.001, 0.0}), Vec({-5.0, 0.0}), zero);
  EXPECT_EQ(tau[0], 0.0);
}

TEST(Effects, SaturationClampsCommandedTorque) {
  EffectsConfig c;
  c.saturation = Vec({1.0, 2.0});
  Effects e(c, 2);
  const VectorXd tau = Force(e, 0.0, Vec({0.0, 0.0}), Vec({0.0, 0.0}), Vec({-5.0, 1.5}));
  EXPECT_EQ(tau[0], -1.0);
  EXPECT_EQ(tau[1], 1.5);
}

TEST(Effects, DisturbanceActsOnlyDuringItsWindow) {
  EffectsConfig c;
  c.disturbance = {Push{1.0, 0.1, Vec({3.0, -1.0})}, Push{1.05, 0.1, Vec({1.0, 1.0})}};
  Effects e(c, 2);
  const VectorXd z = Vec({0.0, 0.0});
  EXPECT_EQ(Force(e, 0.999, z, z, z).norm(), 0.0);
  EXPECT_NEAR((Force(e, 1.0, z, z, z) - Vec({3.0, -1.0})).norm(), 0.0, kTol);
  EXPECT_NEAR((Force(e, 1.07, z, z, z) - Vec({4.0, 0.0})).norm(), 0.0, kTol);  // overlapping pushes add
  EXPECT_NEAR((Force(e, 1.1, z, z, z) - Vec({1.0, 1.0})).norm(), 0.0, kTol);   // first ended at 1.1
  EXPECT_EQ(Force(e, 1.2, z, z, z).norm(), 0.0);
}

TEST(Effects, ValidationNamesTheKeyAndWhatWasExpected) {
  EffectsConfig c;
  c.damping = Vec({0.1});
  auto err = ValidateEffects(c, 2);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->key, "damping");
  EXPECT_EQ(err->message, "expected 2 values (one per joint), got 1");
  c.damping.reset();
  c.limits = JointLimits{Vec({1.0, 0.0}), Vec({0.0, 1.0}), 100.0, 1.0};
  err = ValidateEffects(c, 2);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->key, "limits");
  c.limits.reset();
  c.friction = CoulombFriction{Vec({1.0, 1.0}), 0.0};
  err = ValidateEffects(c, 2);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->key, "friction.velocity_scale");
}

TEST(EffectKinds, NamesRoundTripInTableOrder) {
  EXPECT_EQ(EffectKindNames(), "gravity|coriolis|damping|friction|limits|saturation|disturbance");
  for (int k = 0; k < kNumEffectKinds; ++k) {
    const auto kind = static_cast<EffectKind>(k);
    EXPECT_EQ(ParseEffectKind(ToString(kind)), kind);
  }
  EXPECT_FALSE(ParseEffectKind("Gravity"));
  EXPECT_FALSE(ParseEffectKind(""));
}

TEST(EffectKinds, FlagsOnReadsTheFlagOfEachKind) {
  for (int k = 0; k < kNumEffectKinds; ++k) {
    EffectFlags only;
    const auto kind = static_cast<EffectKind>(k);
    bool* const flags[] = {&only.gravity, &only.coriolis,   &only.damping,    &only.friction,
                           &only.limits,  &only.saturation, &only.disturbance};  // EffectKind order
    *flags[k] = true;
    for (int j = 0; j < kNumEffectKinds; ++j) {
      EXPECT_EQ(only.on(static_cast<EffectKind>(j)), j == k) << ToString(kind) << " asked of " << j;
    }
  }
}

TEST(Effects, SetEnabledRefusesAnEffectWithoutParametersAndChangesNothing) {
  EffectsConfig c;
  c.damping = Vec({0.5, 2.0});
  Effects e(c, 2);
  const VectorXd q = Vec({0.1, 0.2}), qd = Vec({3.0, -1.5}), tau_cmd = Vec({9.0, -9.0});
  const VectorXd before = Force(e, 0.0, q, qd, tau_cmd);
  for (EffectKind kind :
       {EffectKind::kFriction, EffectKind::kLimits, EffectKind::kSaturation, EffectKind::kDisturbance}) {
    EXPECT_FALSE(e.Configured(kind)) << ToString(kind);
    EXPECT_FALSE(e.SetEnabled(kind, true)) << ToString(kind);
    EXPECT_FALSE(e.flags().on(kind)) << ToString(kind);
  }
  EXPECT_FALSE(e.SetEnabled(static_cast<EffectKind>(kNumEffectKinds), false));  // out of range, as from the wire
  EXPECT_TRUE(e.Configured(EffectKind::kGravity));
  EXPECT_TRUE(e.Configured(EffectKind::kCoriolis));
  EXPECT_TRUE(e.Configured(EffectKind::kDamping));
  EXPECT_FALSE(e.passes_command_through());
  EXPECT_TRUE(e.terms().gravity);
  EXPECT_TRUE(e.terms().coriolis);
  EXPECT_EQ((Force(e, 0.0, q, qd, tau_cmd) - before).norm(), 0.0);
  EXPECT_EQ(e.counts().saturation, 0);  // the refused stages never ran
  EXPECT_EQ(e.counts().friction, 0);
}

TEST(Effects, EffectsListedOffStartOffAndSwitchOn) {
  EffectsConfig c;
  c.damping = Vec({0.5, 2.0});
  c.off = {EffectKind::kDamping, EffectKind::kGravity};
  Effects e(c, 2);
  const VectorXd q = Vec({0.1, 0.2}), qd = Vec({3.0, -1.5}), tau_cmd = Vec({1.0, 1.0});
  EXPECT_FALSE(e.flags().damping);
  EXPECT_FALSE(e.terms().gravity);
  EXPECT_TRUE(e.terms().coriolis);
  EXPECT_TRUE(e.passes_command_through());
  EXPECT_EQ((Force(e, 0.0, q, qd, tau_cmd) - tau_cmd).norm(), 0.0);
  EXPECT_EQ(e.counts().damping, 0);

  ASSERT_TRUE(e.SetEnabled(EffectKind::kDamping, true));
  ASSERT_TRUE(e.SetEnabled(EffectKind::kGravity, true));
  EXPECT_TRUE(e.terms().gravity);
  EXPECT_FALSE(e.passes_command_through());
  const VectorXd tau = Force(e, 0.0, q, qd, tau_cmd);
  EXPECT_NEAR(tau[0], 1.0 - 1.5, kTol);
  EXPECT_NEAR(tau[1], 1.0 + 3.0, kTol);
  EXPECT_EQ(e.counts().damping, 1);
}

TEST(Effects, ValidationRefusesOffForAnEffectWithoutParameters) {
  EffectsConfig c;
  c.off = {EffectKind::kFriction};
  const auto err = ValidateEffects(c, 2);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->key, "off");
  EXPECT_EQ(err->message, "expected effects whose parameters are given, got friction");
  c.off = {EffectKind::kGravity, EffectKind::kCoriolis};
  EXPECT_FALSE(ValidateEffects(c, 2));
}

// Dissipation and the stops' stored energy are the switched-on stages' only.
TEST(Effects, DissipatedPowerAndLimitEnergyFollowTheFlags) {
  const VectorXd q = Vec({1.2, -1.1}), qd = Vec({0.7, -0.4});  // both joints past a stop (±1), moving out
  Effects switched(testing::AllEffectsOn(2), 2);
  const double all_power = switched.DissipatedPower(q, qd);
  const double all_energy = switched.LimitPotentialEnergy(q);
  ASSERT_GT(all_energy, 0.0);
  for (EffectKind kind : {EffectKind::kDamping, EffectKind::kFriction, EffectKind::kLimits}) {
    ASSERT_TRUE(switched.SetEnabled(kind, false));
  }
  EXPECT_EQ(switched.DissipatedPower(q, qd), 0.0);
  EXPECT_EQ(switched.LimitPotentialEnergy(q), 0.0);

  // Limits alone: the power of the stops' dampers, as a scene with limits only.
  ASSERT_TRUE(switched.SetEnabled(EffectKind::kLimits, true));
  EffectsConfig limits_only;
  limits_only.limits = testing::AllEffectsOn(2).limits;
  const Effects reference(limits_only, 2);
  EXPECT_EQ(switched.DissipatedPower(q, qd), reference.DissipatedPower(q, qd));
  EXPECT_EQ(switched.LimitPotentialEnergy(q), all_energy);

  ASSERT_TRUE(switched.SetEnabled(EffectKind::kDamping, true));
  ASSERT_TRUE(switched.SetEnabled(EffectKind::kFriction, true));
  EXPECT_EQ(switched.DissipatedPower(q, qd), all_power);
}

class EveryMethod : public ::testing::TestWithParam<Method> {};

TEST_P(EveryMethod, EffectsLeftOutAreNeverEvaluated) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  const VectorXd q = Vec({0.3, -0.4}), qd = Vec({1.0, 2.0}), tau = Vec({0.5, -0.5});
  VectorXd qdd(2);

  EffectsConfig none;
  none.gravity = false;
  none.coriolis = false;
  PlantModel bare(MakeDynamics(spec, GetParam()), none);
  for (int k = 0; k < kEvaluations; ++k) bare.ComputeAcceleration(0.0, q, qd, tau, qdd);
  const StageCounts zero = bare.counts();
  for (std::int64_t count :
       {zero.gravity, zero.coriolis, zero.damping, zero.friction, zero.limits, zero.saturation, zero.disturbance}) {
    EXPECT_EQ(count, 0);
  }

  // Switching one effect on runs that stage, and only that stage, once per evaluation.
  const EffectsConfig all = testing::AllEffectsOn(2);
  using Member = std::int64_t StageCounts::*;
  const std::pair<Member, std::function<void(EffectsConfig&)>> one_on[] = {
      {&StageCounts::gravity, [](EffectsConfig& c) { c.gravity = true; }},
      {&StageCounts::coriolis, [](EffectsConfig& c) { c.coriolis = true; }},
      {&StageCounts::damping, [&](EffectsConfig& c) { c.damping = all.damping; }},
      {&StageCounts::friction, [&](EffectsConfig& c) { c.friction = all.friction; }},
      {&StageCounts::limits, [&](EffectsConfig& c) { c.limits = all.limits; }},
      {&StageCounts::saturation, [&](EffectsConfig& c) { c.saturation = all.saturation; }},
      {&StageCounts::disturbance, [&](EffectsConfig& c) { c.disturbance = all.disturbance; }},
  };
  const Member members[] = {&StageCounts::gravity,    &StageCounts::coriolis, &StageCounts::damping,
                            &StageCounts::friction,   &StageCounts::limits,   &StageCounts::saturation,
                            &StageCounts::disturbance};
  for (const auto& [on, enable] : one_on) {
    EffectsConfig c = none;
    enable(c);
    PlantModel model(MakeDynamics(spec, GetParam()), c);
    for (int k = 0; k < kEvaluations; ++k) model.ComputeAcceleration(0.0, q, qd, tau, qdd);
    const StageCounts counts = model.counts();
    for (Member m : members) EXPECT_EQ(counts.*m, m == on ? kEvaluations : 0);
  }
}

TEST_P(EveryMethod, GravityAndCoriolisOffLeaveExactlyTheirTermsOut) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kCartPole);
  auto reference = MakeDynamics(spec, Method::kLagrangian);
  const std::unique_ptr<DynamicsData> reference_data = reference->MakeData();
  auto d = MakeDynamics(spec, GetParam());
  const std::unique_ptr<DynamicsData> d_data = d->MakeData();
  const VectorXd q = Vec({0.4, 2.0}), qd = Vec({-1.0, 3.0}), tau = Vec({1.0, 0.2});
  MatrixXd M(2, 2);
  VectorXd c(2), G(2), qdd(2);
  reference->ComputeMassMatrix(*reference_data, q, M);
  reference->ComputeCoriolisForce(*reference_data, q, qd, c);
  reference->ComputeGravityForce(*reference_data, q, G);
  for (const DynamicsTerms terms :
       {DynamicsTerms{false, true}, DynamicsTerms{true, false}, DynamicsTerms{false, false}}) {
    const StageCounts before = d_data->counts();
    d->ComputeForwardDynamics(*d_data, q, qd, tau, terms, qdd);
    const VectorXd expected =
        M.llt().solve(tau - (terms.coriolis ? c : VectorXd::Zero(2)) - (terms.gravity ? G : VectorXd::Zero(2)));
    EXPECT_LE((qdd - expected).norm(), 1e-12 * expected.norm());
    EXPECT_EQ(d_data->counts().gravity - before.gravity, terms.gravity ? 1 : 0);
    EXPECT_EQ(d_data->counts().coriolis - before.coriolis, terms.coriolis ? 1 : 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, EveryMethod,
                         ::testing::Values(Method::kClosedForm, Method::kLagrangian, Method::kRecursive),
                         [](const auto& param_info) {
                           std::string name(ToString(param_info.param));
                           std::erase(name, '-');
                           return name;
                         });

// dE/dt along the vector field = qdᵀ (sat(tau_cmd) + pushes) − dissipated power.
TEST(EnergyBalance, EnergyRateEqualsInputPowerMinusDissipation) {
  std::mt19937 rng{42};
  constexpr double kStep = 1e-6;  // central difference along the flow
  for (const auto& plant : testing::AllPlantCases()) {
    const int n = plant.spec.num_dofs();
    PlantModel model(MakeDynamics(plant.spec, FastestMethod(plant.spec.type())), testing::AllEffectsOn(n));
    VectorXd qdd(n), sat(n);
    for (int k = 0; k < 100; ++k) {
      // Half the states past a limit, to exercise the stop's spring and damper.
      const double span = k % 2 == 0 ? 0.9 : 1.3;
      const VectorXd q = testing::RandomVector(n, -span, span, rng);
      const VectorXd qd = testing::RandomVector(n, -3.0, 3.0, rng);
      const VectorXd tau_cmd = testing::RandomVector(n, -6.0, 6.0, rng);
      const double t = 1.0;
      model.ComputeAcceleration(t, q, qd, tau_cmd, qdd);
      const double e_plus = model.Energy(q + kStep * qd, qd + kStep * qdd);
      const double e_minus = model.Energy(q - kStep * qd, qd - kStep * qdd);
      const double rate = (e_plus - e_minus) / (2.0 * kStep);
      sat = tau_cmd.cwiseMax(-4.0).cwiseMin(4.0);
      const double expected = Power(qd, sat + VectorXd::Constant(n, 0.7)) - model.effects().DissipatedPower(q, qd);
      ASSERT_NEAR(rate, expected, 1e-5 * (1.0 + std::abs(expected))) << plant.name << " state " << k;
    }
  }
}

TEST(EnergyBalance, DissipationIsNeverNegative) {
  std::mt19937 rng{5};
  Effects e(testing::AllEffectsOn(3), 3);
  for (int k = 0; k < 1000; ++k) {
    const VectorXd q = testing::RandomVector(3, -2.0, 2.0, rng);
    const VectorXd qd = testing::RandomVector(3, -5.0, 5.0, rng);
    ASSERT_GE(e.DissipatedPower(q, qd), 0.0);
  }
}

}  // namespace
}  // namespace lagrange
