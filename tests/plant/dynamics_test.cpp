// The energy contract: for every plant and every method at seeded random
// states, M is symmetric positive definite, Ṁ − 2C is skew, T = ½ qdᵀ M qd,
// dE/dt = qdᵀ tau, and the closed form, the Lagrangian (automatic
// differentiation) and the recursive algorithms agree to 1e-12 relative. The
// built-in plants and the shipped URDF robots (config/robots/) alike.

#include <gtest/gtest.h>

#include <iostream>
#include <numbers>

#include "plant/eigenvalues.hpp"
#include "plant/lagrangian.hpp"
#include "plant/plant_factory.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/urdf.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::AllPlantCases;
using testing::RandomStateFor;
using testing::RelativeDifference;

constexpr int kStates = 100;
constexpr double kAgreeTol = 1e-12;            // between derivation methods, relative
constexpr double kSymmetryTol = 1e-14;         // M − Mᵀ, relative to ‖M‖
constexpr double kFiniteDifferenceTol = 1e-7;  // central differences with ε = 1e-6
constexpr double kEps = 1e-6;

struct Terms {
  MatrixXd M, C;
  VectorXd c, G, dTdq, qdd, tau;
  double T = 0.0, V = 0.0;
};

Terms Evaluate(const Dynamics& d, const VectorXd& q, const VectorXd& qd, const VectorXd& u) {
  const std::unique_ptr<DynamicsData> d_data = d.MakeData();
  const int n = d.num_dofs();
  Terms t{MatrixXd(n, n), MatrixXd(n, n), VectorXd(n), VectorXd(n), VectorXd(n), VectorXd(n), VectorXd(n)};
  d.ComputeMassMatrix(*d_data, q, t.M);
  d.ComputeCoriolisMatrix(*d_data, q, qd, t.C);
  d.ComputeCoriolisForce(*d_data, q, qd, t.c);
  d.ComputeGravityForce(*d_data, q, t.G);
  d.ComputeKineticEnergyGradient(*d_data, q, qd, t.dTdq);
  d.ComputeForwardDynamics(*d_data, q, qd, u, DynamicsTerms{}, t.qdd);
  d.ComputeInverseDynamics(*d_data, q, qd, u, DynamicsTerms{}, t.tau);
  t.T = d.ComputeKineticEnergy(*d_data, q, qd);
  t.V = d.ComputePotentialEnergy(*d_data, q);
  return t;
}

class EveryPlant : public ::testing::TestWithParam<testing::PlantCase> {};

TEST_P(EveryPlant, MassMatrixIsSymmetricPositiveDefinite) {
  const PlantSpec& spec = GetParam().spec;
  std::mt19937 rng{42};
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    const int n = d->num_dofs();
    MatrixXd M(n, n);
    for (int k = 0; k < kStates; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      d->ComputeMassMatrix(*d_data, s.q, M);
      ASSERT_LE((M - M.transpose()).norm(), kSymmetryTol * M.norm()) << ToString(method);
      const double min_eig = SymmetricEigenvalues(M).minCoeff();
      ASSERT_GT(min_eig, 0.0) << ToString(method) << " at state " << k;
    }
  }
}

TEST_P(EveryPlant, MassMatrixRateMinusTwoCoriolisIsSkewSymmetric) {
  const PlantSpec& spec = GetParam().spec;
  std::mt19937 rng{7};
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    const int n = d->num_dofs();
    MatrixXd Mp(n, n), Mm(n, n), C(n, n);
    for (int k = 0; k < kStates; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      d->ComputeMassMatrix(*d_data, s.q + kEps * s.qd, Mp);
      d->ComputeMassMatrix(*d_data, s.q - kEps * s.qd, Mm);
      const MatrixXd Mdot = (Mp - Mm) / (2.0 * kEps);  // Ṁ along qd
      d->ComputeCoriolisMatrix(*d_data, s.q, s.qd, C);
      const MatrixXd N = Mdot - 2.0 * C;
      ASSERT_LE((N + N.transpose()).norm(), kFiniteDifferenceTol * (Mp.norm() * s.qd.norm()))
          << ToString(method) << " at state " << k;
    }
  }
}

TEST_P(EveryPlant, KineticEnergyIsHalfVelocityMassVelocity) {
  const PlantSpec& spec = GetParam().spec;
  std::mt19937 rng{11};
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    MatrixXd M(d->num_dofs(), d->num_dofs());
    for (int k = 0; k < kStates; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      d->ComputeMassMatrix(*d_data, s.q, M);
      const double quadratic = 0.5 * s.qd.dot(M * s.qd);
      ASSERT_NEAR(d->ComputeKineticEnergy(*d_data, s.q, s.qd), quadratic, kAgreeTol * quadratic) << ToString(method);
    }
  }
}

TEST_P(EveryPlant, CoriolisForceAndEnergyGradientFollowFromTheCoriolisMatrix) {
  const PlantSpec& spec = GetParam().spec;
  std::mt19937 rng{13};
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    const int n = d->num_dofs();
    MatrixXd C(n, n), M(n, n);
    VectorXd c(n), dTdq(n);
    for (int k = 0; k < kStates; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      d->ComputeMassMatrix(*d_data, s.q, M);
      d->ComputeCoriolisMatrix(*d_data, s.q, s.qd, C);
      d->ComputeCoriolisForce(*d_data, s.q, s.qd, c);
      d->ComputeKineticEnergyGradient(*d_data, s.q, s.qd, dTdq);
      const double floor = M.norm() * s.qd.squaredNorm();
      ASSERT_LE(RelativeDifference(c, C * s.qd, floor), kAgreeTol) << ToString(method);
      ASSERT_LE(RelativeDifference(dTdq, C.transpose() * s.qd, floor), kAgreeTol) << ToString(method);
    }
  }
}

TEST_P(EveryPlant, ForwardDynamicsInvertsInverseDynamics) {
  const PlantSpec& spec = GetParam().spec;
  std::mt19937 rng{17};
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    const int n = d->num_dofs();
    VectorXd tau(n), qdd(n);
    for (const DynamicsTerms terms : {DynamicsTerms{true, true}, DynamicsTerms{false, true}, DynamicsTerms{true, false},
                                      DynamicsTerms{false, false}}) {
      for (int k = 0; k < kStates; ++k) {
        const auto s = RandomStateFor(d->joint_types(), rng);
        const VectorXd qdd0 = testing::RandomVector(n, -5.0, 5.0, rng);
        d->ComputeInverseDynamics(*d_data, s.q, s.qd, qdd0, terms, tau);
        d->ComputeForwardDynamics(*d_data, s.q, s.qd, tau, terms, qdd);
        ASSERT_LE(RelativeDifference(qdd, qdd0), 1e-10)
            << ToString(method) << " gravity " << terms.gravity << " coriolis " << terms.coriolis;
      }
    }
  }
}

TEST_P(EveryPlant, AllDerivationMethodsAgree) {
  const PlantSpec& spec = GetParam().spec;
  auto reference = MakeDynamics(spec, Method::kLagrangian);
  const int n = reference->num_dofs();
  std::mt19937 rng{23};
  for (Method method : testing::MethodsOf(spec.type())) {
    if (method == Method::kLagrangian) continue;
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    for (int k = 0; k < kStates; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      const VectorXd u = testing::RandomVector(n, -10.0, 10.0, rng);
      const Terms a = Evaluate(*reference, s.q, s.qd, u);
      const Terms b = Evaluate(*d, s.q, s.qd, u);
      const double m = a.M.norm();
      const double g = m * kStandardGravity;    // scale of gravity terms
      const double v = m * s.qd.squaredNorm();  // scale of velocity-product terms
      const char* name = ToString(method).data();
      ASSERT_LE(RelativeDifference(a.M, b.M), kAgreeTol) << name << " M at state " << k;
      ASSERT_LE(RelativeDifference(a.C, b.C, m * s.qd.norm()), kAgreeTol) << name << " C";
      ASSERT_LE(RelativeDifference(a.c, b.c, v), kAgreeTol) << name << " C qd";
      ASSERT_LE(RelativeDifference(a.G, b.G, g), kAgreeTol) << name << " G";
      ASSERT_LE(RelativeDifference(a.dTdq, b.dTdq, v), kAgreeTol) << name << " dT/dq";
      ASSERT_LE(RelativeDifference(a.tau, b.tau, g + v), kAgreeTol) << name << " inverse dynamics";
      ASSERT_LE(RelativeDifference(a.qdd, b.qdd, 1.0), 1e-11) << name << " forward dynamics";
      ASSERT_NEAR(a.T, b.T, kAgreeTol * std::max(1.0, a.T)) << name << " T";
      ASSERT_NEAR(a.V, b.V, kAgreeTol * g) << name << " V";
    }
  }
}

// The plant's tree is its one description: the spatial algorithms on it
// give what every derivation of the plant gives (for the built-in plants,
// whose recursive path folds the same tree into the planar algorithms).
TEST_P(EveryPlant, SpatialDynamicsOfThePlantsTreeAgreeWithItsDerivations) {
  const PlantSpec& spec = GetParam().spec;
  const SpatialDynamics spatial(MakeRigidTree(spec));
  const int n = spatial.num_dofs();
  ASSERT_EQ(spatial.joint_types(), JointTypesOf(spec));
  std::mt19937 rng{31};
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    for (int k = 0; k < kStates / 10; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      const VectorXd u = testing::RandomVector(n, -10.0, 10.0, rng);
      const Terms a = Evaluate(*d, s.q, s.qd, u);
      const Terms b = Evaluate(spatial, s.q, s.qd, u);
      const double m = a.M.norm(), g = m * kStandardGravity, v = m * s.qd.squaredNorm();
      const char* name = ToString(method).data();
      ASSERT_LE(RelativeDifference(a.M, b.M), kAgreeTol) << name << " M at state " << k;
      ASSERT_LE(RelativeDifference(a.C, b.C, m * s.qd.norm()), kAgreeTol) << name << " C";
      ASSERT_LE(RelativeDifference(a.G, b.G, g), kAgreeTol) << name << " G";
      ASSERT_LE(RelativeDifference(a.tau, b.tau, g + v), kAgreeTol) << name << " inverse dynamics";
      ASSERT_LE(RelativeDifference(a.qdd, b.qdd, 1.0), 1e-11) << name << " forward dynamics";
      ASSERT_NEAR(a.T, b.T, kAgreeTol * std::max(1.0, a.T)) << name << " T";
      ASSERT_NEAR(a.V, b.V, kAgreeTol * g) << name << " V";
    }
  }
}

TEST_P(EveryPlant, GravityIsTheGradientOfThePotential) {
  const PlantSpec& spec = GetParam().spec;
  std::mt19937 rng{29};
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    const int n = d->num_dofs();
    VectorXd G(n);
    for (int k = 0; k < kStates; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      d->ComputeGravityForce(*d_data, s.q, G);
      for (int i = 0; i < n; ++i) {
        VectorXd qp = s.q, qm = s.q;
        qp[i] += kEps;
        qm[i] -= kEps;
        const double fd =
            (d->ComputePotentialEnergy(*d_data, qp) - d->ComputePotentialEnergy(*d_data, qm)) / (2.0 * kEps);
        ASSERT_NEAR(G[i], fd, kFiniteDifferenceTol * std::max(1.0, G.norm())) << ToString(method);
      }
    }
  }
}

// Along the motion qdd = M⁻¹ (tau − C qd − G), E = T + V changes at the power
// of the applied force: dE/dt = qdᵀ tau. dE/dt by central differences of E
// along (qd, qdd), step ε: truncation O(ε²), round-off O(1e-16 E / ε).
TEST_P(EveryPlant, EnergyChangesAtThePowerOfTheAppliedForce) {
  const PlantSpec& spec = GetParam().spec;
  std::mt19937 rng{43};
  constexpr double kStep = 1e-5;
  for (Method method : testing::MethodsOf(spec.type())) {
    auto d = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    const int n = d->num_dofs();
    VectorXd qdd(n);
    for (int k = 0; k < kStates; ++k) {
      const auto s = RandomStateFor(d->joint_types(), rng);
      const VectorXd tau = testing::RandomVector(n, -10.0, 10.0, rng);
      d->ComputeForwardDynamics(*d_data, s.q, s.qd, tau, DynamicsTerms{}, qdd);
      auto energy = [&](double e) {
        const VectorXd q = s.q + e * s.qd, qd = s.qd + e * qdd;
        return d->ComputeKineticEnergy(*d_data, q, qd) + d->ComputePotentialEnergy(*d_data, q);
      };
      const double rate = (energy(kStep) - energy(-kStep)) / (2.0 * kStep);
      const double power = s.qd.dot(tau);
      const double scale = std::abs(energy(0.0)) + s.qd.norm() * (tau.norm() + 1.0);
      ASSERT_NEAR(rate, power, 1e-6 * scale) << ToString(method) << " at state " << k;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Plants, EveryPlant, ::testing::ValuesIn(AllPlantCases()),
                         [](const auto& param_info) { return param_info.param.name; });

// The robots shipped in config/robots/, with their files' gravity. A file that
// does not load gives a case without a robot, whose tests then fail naming why.
std::vector<testing::PlantCase> ShippedRobots() {
  std::vector<testing::PlantCase> cases;
  for (const char* name : {"panda", "ur5"}) {
    const std::string file = std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + name + ".urdf";
    try {
      cases.push_back({name, UrdfPlantSpec(std::make_shared<const UrdfRobot>(LoadUrdf(file)))});
    } catch (const std::exception& e) {
      std::cerr << e.what() << "\n";  // said before the tests run; they fail on the missing robot
      cases.push_back({name, DefaultPlantSpec(PlantType::kUrdf)});
    }
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Robots, EveryPlant, ::testing::ValuesIn(ShippedRobots()),
                         [](const auto& param_info) { return param_info.param.name; });

TEST(Robots, TheShippedRobotsHaveTheirJointCountsAndNoClosedForm) {
  const std::vector<testing::PlantCase> robots = ShippedRobots();
  ASSERT_EQ(robots.size(), 2u);
  EXPECT_EQ(robots[0].spec.num_dofs(), 7);
  EXPECT_EQ(robots[1].spec.num_dofs(), 6);
  EXPECT_FALSE(HasMethod(PlantType::kUrdf, Method::kClosedForm));
  EXPECT_EQ(FastestMethod(PlantType::kUrdf), Method::kRecursive);
  EXPECT_THROW(MakeDynamics(robots[0].spec, Method::kClosedForm), std::invalid_argument);
  // No default robot: the spec says what is missing.
  const std::optional<SpecError> err = ValidatePlantSpec(DefaultPlantSpec(PlantType::kUrdf));
  ASSERT_TRUE(err);
  EXPECT_EQ(err->key, "file");
  EXPECT_NE(err->message.find("no default robot"), std::string::npos) << err->message;
}

// gravity and mass_scale act as physics says: G scales with both, M with the mass.
TEST(Robots, GravityAndMassScaleScaleGravityAndMassMatrix) {
  const PlantSpec panda = ShippedRobots()[0].spec;
  PlantSpec heavier = panda;
  ASSERT_FALSE(SetPlantParam(heavier, "mass_scale", "1.5"));
  ASSERT_FALSE(SetPlantParam(heavier, "gravity", "0,0,-19.62"));
  const VectorXd q = (VectorXd(7) << 0.3, -0.5, -0.2, -2.0, 0.1, 1.6, 0.6).finished();
  MatrixXd M(7, 7), Mh(7, 7);
  VectorXd G(7), Gh(7);
  for (Method method : testing::MethodsOf(PlantType::kUrdf)) {
    auto d = MakeDynamics(panda, method), h = MakeDynamics(heavier, method);
    const std::unique_ptr<DynamicsData> h_data = h->MakeData();
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    d->ComputeMassMatrix(*d_data, q, M);
    h->ComputeMassMatrix(*h_data, q, Mh);
    d->ComputeGravityForce(*d_data, q, G);
    h->ComputeGravityForce(*h_data, q, Gh);
    EXPECT_LE(RelativeDifference(Mh, 1.5 * M), kAgreeTol) << ToString(method);
    EXPECT_LE(RelativeDifference(Gh, 3.0 * G), kAgreeTol) << ToString(method);
  }
  EXPECT_TRUE(SetPlantParam(heavier, "mass_scale", "0"));
  EXPECT_TRUE(SetPlantParam(heavier, "gravity", "0,0"));
  EXPECT_EQ(SetPlantParam(heavier, "gravity", "0,0,x")->message,
            "expected gx,gy,gz (three finite numbers, m/s², world frame), got '0,0,x'");
}

// Chain equivalences: one link is the rod pendulum (link along −y at q = 0),
// two links with the arm's parameters are the arm.
void ExpectSameDynamics(Dynamics& a, Dynamics& b, std::uint32_t seed) {
  std::mt19937 rng{seed};
  const int n = a.num_dofs();
  ASSERT_EQ(n, b.num_dofs());
  for (int k = 0; k < kStates; ++k) {
    const auto s = RandomStateFor(a.joint_types(), rng);
    const VectorXd u = testing::RandomVector(n, -10.0, 10.0, rng);
    const Terms x = Evaluate(a, s.q, s.qd, u);
    const Terms y = Evaluate(b, s.q, s.qd, u);
    ASSERT_LE(RelativeDifference(x.M, y.M), kAgreeTol);
    ASSERT_LE(RelativeDifference(x.C, y.C, x.M.norm() * s.qd.norm()), kAgreeTol);
    ASSERT_LE(RelativeDifference(x.G, y.G, x.M.norm() * kStandardGravity), kAgreeTol);
    ASSERT_LE(RelativeDifference(x.qdd, y.qdd), 1e-11);
    ASSERT_NEAR(x.T, y.T, kAgreeTol * std::max(1.0, x.T));
    ASSERT_NEAR(x.V, y.V, kAgreeTol * x.M.norm() * kStandardGravity);
  }
}

TEST(ChainEquivalence, OneLinkChainIsTheRodPendulum) {
  PendulumParams rod;
  rod.body = PendulumBody::kRod;
  rod.m = 1.3;
  rod.L = 0.9;
  ChainParams chain;
  chain.links = {ChainLink{.m = 1.3, .L = 0.9, .com = {}, .I = {}}};
  chain.base_angle = -std::numbers::pi / 2;
  for (Method method : {Method::kLagrangian, Method::kRecursive}) {
    auto pendulum = MakeDynamics({rod}, Method::kClosedForm);
    auto one_link = MakeDynamics({chain}, method);
    ExpectSameDynamics(*pendulum, *one_link, 31);
  }
}

TEST(ChainEquivalence, TwoLinkChainIsTheArm) {
  ChainParams chain;
  chain.links = {ChainLink{.m = 1.0, .L = 0.6, .com = {}, .I = {}}, ChainLink{.m = 0.8, .L = 0.5, .com = {}, .I = {}}};
  for (Method method : {Method::kLagrangian, Method::kRecursive}) {
    auto arm = MakeDynamics(DefaultPlantSpec(PlantType::kArm2), Method::kClosedForm);
    auto two_links = MakeDynamics({chain}, method);
    ExpectSameDynamics(*arm, *two_links, 37);
  }
}

TEST(ClosedForm, PendulumMatchesTheTextbookEquation) {
  // m L² θ̈ + m g L sin θ = τ for the point mass.
  auto d = MakeDynamics(DefaultPlantSpec(PlantType::kPendulum), Method::kClosedForm);
  const std::unique_ptr<DynamicsData> d_data = d->MakeData();
  VectorXd q(1), qd(1), tau(1), qdd(1);
  q << 0.7;
  qd << 1.1;
  tau << 0.3;
  d->ComputeForwardDynamics(*d_data, q, qd, tau, DynamicsTerms{}, qdd);
  EXPECT_NEAR(qdd[0], (0.3 - 1.0 * kStandardGravity * 1.0 * std::sin(0.7)) / 1.0, 1e-15);
}

TEST(ClosedForm, ArmMatchesTheArticleAtTheShoulderHorizontal) {
  // At q = (0, 0): M11 = m1L1²/3 + m2(L1² + L1L2 + L2²/3), G1 = g(m1 L1/2 + m2(L1 + L2/2)).
  auto d = MakeDynamics(DefaultPlantSpec(PlantType::kArm2), Method::kClosedForm);
  const std::unique_ptr<DynamicsData> d_data = d->MakeData();
  VectorXd q = VectorXd::Zero(2), G(2);
  MatrixXd M(2, 2);
  d->ComputeMassMatrix(*d_data, q, M);
  d->ComputeGravityForce(*d_data, q, G);
  const double m1 = 1.0, m2 = 0.8, L1 = 0.6, L2 = 0.5, g = kStandardGravity;
  EXPECT_NEAR(M(0, 0), m1 * L1 * L1 / 3 + m2 * (L1 * L1 + L1 * L2 + L2 * L2 / 3), 1e-15);
  EXPECT_NEAR(M(0, 1), m2 * (L1 * L2 / 2 + L2 * L2 / 3), 1e-15);
  EXPECT_NEAR(M(1, 1), m2 * L2 * L2 / 3, 1e-15);
  EXPECT_NEAR(G[0], g * (m1 * L1 / 2 + m2 * (L1 + L2 / 2)), 1e-13);
  EXPECT_NEAR(G[1], g * m2 * L2 / 2, 1e-14);
}

TEST(ClosedForm, ChainHasNoClosedForm) {
  EXPECT_FALSE(HasMethod(PlantType::kChain, Method::kClosedForm));
  EXPECT_THROW(MakeDynamics(DefaultPlantSpec(PlantType::kChain), Method::kClosedForm), std::invalid_argument);
  EXPECT_EQ(FastestMethod(PlantType::kChain), Method::kRecursive);
  EXPECT_EQ(FastestMethod(PlantType::kArm2), Method::kClosedForm);
}

TEST(Recursive, SixtyFourLinkChainMatchesTheLagrangianPath) {
  ChainParams p;
  p.links.resize(64);
  auto recursive = MakeDynamics({p}, Method::kRecursive);
  auto lagrangian = MakeDynamics({p}, Method::kLagrangian);
  std::mt19937 rng{41};
  for (int k = 0; k < 3; ++k) {
    const auto s = RandomStateFor(recursive->joint_types(), rng);
    const VectorXd u = testing::RandomVector(64, -1.0, 1.0, rng);
    const Terms a = Evaluate(*lagrangian, s.q, s.qd, u);
    const Terms b = Evaluate(*recursive, s.q, s.qd, u);
    EXPECT_LE(RelativeDifference(a.M, b.M), 1e-12);
    EXPECT_LE(RelativeDifference(a.C, b.C, a.M.norm() * s.qd.norm()), 1e-12);
    EXPECT_LE(RelativeDifference(a.G, b.G, a.M.norm() * kStandardGravity), 1e-12);
    // A 64-link M is ill-conditioned; compare accelerations through the residual M qdd − rhs.
    EXPECT_LE((a.M * b.qdd - a.M * a.qdd).norm(), 1e-9 * (a.M.norm() * a.qdd.norm()));
  }
}

#ifndef NDEBUG
// Debug builds check argument sizes at the top of every query; NDEBUG compiles the checks out.
TEST(SizeChecks, DebugBuildsRejectMisSizedArguments) {
  for (Method method : testing::MethodsOf(PlantType::kArm2)) {
    const auto d = MakeDynamics(DefaultPlantSpec(PlantType::kArm2), method);
    const std::unique_ptr<DynamicsData> d_data = d->MakeData();
    const VectorXd q2 = VectorXd::Zero(2), q3 = VectorXd::Zero(3);
    MatrixXd M2(2, 2), M3(3, 3);
    VectorXd out2(2), out3(3);
    EXPECT_DEATH(d->ComputeMassMatrix(*d_data, q3, M2), "HasDofSize") << ToString(method);
    EXPECT_DEATH(d->ComputeMassMatrix(*d_data, q2, M3), "HasDofSize") << ToString(method);
    EXPECT_DEATH(d->ComputeCoriolisForce(*d_data, q2, q3, out2), "HasDofSize") << ToString(method);
    EXPECT_DEATH(d->ComputeGravityForce(*d_data, q2, out3), "HasDofSize") << ToString(method);
    EXPECT_DEATH(d->ComputeForwardDynamics(*d_data, q2, q2, q3, DynamicsTerms{}, out2), "HasDofSize")
        << ToString(method);
    EXPECT_DEATH(d->ComputeInverseDynamics(*d_data, q2, q2, q2, DynamicsTerms{}, out3), "HasDofSize")
        << ToString(method);
    // Data belongs to the model that made it.
    const auto other = MakeDynamics(DefaultPlantSpec(PlantType::kArm2), method);
    EXPECT_DEATH(other->ComputeMassMatrix(*d_data, q2, M2), "another model") << ToString(method);
  }
}
#endif

}  // namespace
}  // namespace lagrange
