// A plant switched at run time is the plant a scene would have built that
// way: gravity and Coriolis switched off leave exactly their terms out (and
// gravity's potential), and a model holding several derivation methods gives
// each method's accelerations after every switch.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "plant/plant_factory.hpp"
#include "plant/plant_model.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

constexpr double kMethodTol = 1e-12;  // relative: one method's qdd before and after switches
constexpr int kStates = 20;

// Exact equality, element by element: the same operations on the same numbers.
bool BitIdentical(const VectorXd& a, const VectorXd& b) {
  return a.size() == b.size() && (a.array() == b.array()).all();
}

struct TermsCase {
  std::string name;
  bool gravity;
  bool coriolis;
};

TEST(PlantModel, GravityOrCoriolisSwitchedOffEqualsAModelBuiltWithout) {
  std::mt19937 rng{42};
  for (PlantType type : {PlantType::kPendulum, PlantType::kArm2, PlantType::kCartPole}) {
    const PlantSpec spec = DefaultPlantSpec(type);
    const int n = spec.num_dofs();
    for (Method method : testing::MethodsOf(type)) {
      for (const TermsCase& c : {TermsCase{"gravity off", false, true}, TermsCase{"coriolis off", true, false},
                                 TermsCase{"both off", false, false}}) {
        // Bare and with every force effect on: both ComputeAcceleration paths.
        for (bool with_effects : {false, true}) {
          const std::string where = std::string(ToString(type)) + " " + std::string(ToString(method)) + " " + c.name +
                                    (with_effects ? " with effects" : " bare");
          EffectsConfig config = with_effects ? testing::AllEffectsOn(n) : EffectsConfig{};
          PlantModel switched(MakeDynamics(spec, method), config);
          config.gravity = c.gravity;
          config.coriolis = c.coriolis;
          PlantModel built(MakeDynamics(spec, method), config);
          ASSERT_TRUE(switched.effects().SetEnabled(EffectKind::kGravity, c.gravity));
          ASSERT_TRUE(switched.effects().SetEnabled(EffectKind::kCoriolis, c.coriolis));
          EXPECT_EQ(switched.effects().terms().gravity, c.gravity) << where;
          EXPECT_EQ(switched.effects().terms().coriolis, c.coriolis) << where;
          VectorXd qdd(n), expected(n);
          for (int k = 0; k < kStates; ++k) {
            const testing::RandomState s = testing::RandomStateFor(JointTypesOf(spec), rng);
            const VectorXd tau = testing::RandomVector(n, -3.0, 3.0, rng);
            switched.ComputeAcceleration(1.0, s.q, s.qd, tau, qdd);
            built.ComputeAcceleration(1.0, s.q, s.qd, tau, expected);
            ASSERT_TRUE(BitIdentical(qdd, expected)) << where << " state " << k;
            ASSERT_EQ(switched.PotentialEnergy(s.q), built.PotentialEnergy(s.q)) << where;
          }
          EXPECT_EQ(switched.counts().gravity, built.counts().gravity) << where;
          EXPECT_EQ(switched.counts().coriolis, built.counts().coriolis) << where;
        }
      }
    }
  }
}

// V = gravity's potential while gravity is on, plus the stops' springs always.
TEST(PlantModel, PotentialEnergyFollowsGravitysFlag) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  PlantModel model(MakeDynamics(spec, Method::kClosedForm), testing::AllEffectsOn(2));
  VectorXd q(2);
  q << 1.3, 0.4;  // joint 1 past its stop at 1
  const double springs = model.effects().LimitPotentialEnergy(q);
  const double gravity = model.dynamics().ComputePotentialEnergy(model.data(), q);
  ASSERT_GT(springs, 0.0);
  ASSERT_NE(gravity, 0.0);
  EXPECT_EQ(model.PotentialEnergy(q), springs + gravity);
  ASSERT_TRUE(model.effects().SetEnabled(EffectKind::kGravity, false));
  EXPECT_EQ(model.PotentialEnergy(q), springs);
  ASSERT_TRUE(model.effects().SetEnabled(EffectKind::kGravity, true));
  EXPECT_EQ(model.PotentialEnergy(q), springs + gravity);
}

TEST(PlantModel, SelectMethodGivesEachHeldMethodsAcceleration) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  const Method methods[] = {Method::kClosedForm, Method::kLagrangian, Method::kRecursive};
  const EffectsConfig effects = testing::AllEffectsOn(2);
  PlantModel multi(MakeDynamics(spec, Method::kClosedForm), effects);
  multi.AddDynamics(MakeDynamics(spec, Method::kLagrangian));
  multi.AddDynamics(MakeDynamics(spec, Method::kRecursive));
  std::vector<std::unique_ptr<PlantModel>> single;
  for (Method m : methods) {
    EXPECT_TRUE(multi.HasMethod(m));
    single.push_back(std::make_unique<PlantModel>(MakeDynamics(spec, m), effects));
  }
  EXPECT_EQ(multi.method(), Method::kClosedForm);  // the constructor's until a switch

  std::mt19937 rng{3};
  VectorXd qdd(2), expected(2);
  // Every switch between every pair, there and back.
  const int order[] = {0, 1, 2, 0, 2, 1, 0};
  for (int i : order) {
    ASSERT_TRUE(multi.SelectMethod(methods[i]));
    EXPECT_EQ(multi.method(), methods[i]);
    EXPECT_EQ(multi.dynamics().method(), methods[i]);
    for (int k = 0; k < kStates; ++k) {
      const testing::RandomState s = testing::RandomStateFor(JointTypesOf(spec), rng);
      const VectorXd tau = testing::RandomVector(2, -3.0, 3.0, rng);
      multi.ComputeAcceleration(1.0, s.q, s.qd, tau, qdd);
      single[i]->ComputeAcceleration(1.0, s.q, s.qd, tau, expected);
      ASSERT_LE(testing::RelativeDifference(qdd, expected), kMethodTol) << ToString(methods[i]) << " state " << k;
      ASSERT_LE(std::abs(multi.Energy(s.q, s.qd) - single[i]->Energy(s.q, s.qd)),
                kMethodTol * (1.0 + std::abs(single[i]->Energy(s.q, s.qd))));
    }
  }
  // Every held method's gravity evaluations are counted, whichever ran them.
  std::int64_t gravity = 0;
  for (const auto& m : single) gravity += m->counts().gravity;
  EXPECT_EQ(multi.counts().gravity, gravity);
}

TEST(PlantModel, SelectMethodRefusesAMethodNotHeld) {
  const PlantSpec spec = DefaultPlantSpec(PlantType::kArm2);
  PlantModel model(MakeDynamics(spec, Method::kLagrangian), EffectsConfig{});
  EXPECT_TRUE(model.HasMethod(Method::kLagrangian));
  EXPECT_FALSE(model.HasMethod(Method::kRecursive));
  EXPECT_FALSE(model.SelectMethod(Method::kRecursive));
  EXPECT_FALSE(model.SelectMethod(Method::kClosedForm));
  EXPECT_EQ(model.method(), Method::kLagrangian);
}

TEST(PlantModel, AddDynamicsRefusesADuplicateMethodAndAWrongSize) {
  const PlantSpec arm = DefaultPlantSpec(PlantType::kArm2);
  PlantModel model(MakeDynamics(arm, Method::kClosedForm), EffectsConfig{});
  auto duplicate = MakeDynamics(arm, Method::kClosedForm);
  EXPECT_THROW(model.AddDynamics(std::move(duplicate)), std::invalid_argument);
  // A pendulum has one degree of freedom, the arm two.
  auto pendulum = MakeDynamics(DefaultPlantSpec(PlantType::kPendulum), Method::kRecursive);
  ASSERT_EQ(pendulum->num_dofs(), 1);
  EXPECT_THROW(model.AddDynamics(std::move(pendulum)), std::invalid_argument);
  EXPECT_THROW(model.AddDynamics(nullptr), std::invalid_argument);
  EXPECT_FALSE(model.HasMethod(Method::kRecursive));
  EXPECT_FALSE(model.HasMethod(Method::kLagrangian));
  EXPECT_EQ(model.method(), Method::kClosedForm);
  model.AddDynamics(MakeDynamics(arm, Method::kRecursive));
  EXPECT_TRUE(model.HasMethod(Method::kRecursive));
  EXPECT_EQ(model.method(), Method::kClosedForm);  // adding does not switch
}

}  // namespace
}  // namespace lagrange
