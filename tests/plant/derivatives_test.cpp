// Exact first derivatives of the dynamics (plant/dynamics.hpp): ∂tau/∂(q, qd,
// qdd) of inverse dynamics, ∂qdd/∂(q, qd, tau) of forward dynamics and ∂G/∂q,
// for every plant and every method. Each is held against central differences
// of the call it differentiates, and the derivations against each other: the
// recursive sweeps (SpatialDynamics, MimicDynamics, and the planar chains'
// through their trees), nested duals of the energies (LagrangianDynamics) and
// the closed forms, at random states of random trees (prismatic, branching,
// mimic), of the shipped robots, near a singular M and at high speed; and the
// facts every such derivative obeys.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "plant/eigenvalues.hpp"
#include "plant/lagrangian.hpp"
#include "plant/mimic_dynamics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/random_tree.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/urdf.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::CentralDifferences;
using testing::RelativeDifference;

constexpr double kDifferenceTol = 1e-6;   // against central differences, relative
constexpr double kDerivationTol = 1e-10;  // between derivations, relative
constexpr double kIdentityTol = 1e-12;    // ∂qdd/∂tau · M − I, on well-conditioned M
constexpr double kStep = 1e-5;            // central-difference step, × max(1, |x|)

// Every derivative of one model at one state: inverse dynamics' at qdd = FD.
struct Derivatives {
  VectorXd qdd;
  MatrixXd dqdd_dq, dqdd_dqd, dqdd_dtau;  // forward dynamics
  MatrixXd dtau_dq, dtau_dqd, M;          // inverse dynamics
  MatrixXd dG_dq;
};

Derivatives DerivativesOf(const Dynamics& model, const VectorXd& q, const VectorXd& qd, const VectorXd& tau,
                          DynamicsTerms terms = {}) {
  const int n = model.num_dofs();
  const std::unique_ptr<DynamicsData> data = model.MakeData();
  Derivatives d{VectorXd(n),        MatrixXd(n, n), MatrixXd(n, n), MatrixXd(n, n),
                MatrixXd(n, n),     MatrixXd(n, n), MatrixXd(n, n), MatrixXd(n, n)};
  model.ComputeForwardDynamicsDerivatives(*data, q, qd, tau, terms, d.qdd, d.dqdd_dq, d.dqdd_dqd, d.dqdd_dtau);
  model.ComputeInverseDynamicsDerivatives(*data, q, qd, d.qdd, terms, d.dtau_dq, d.dtau_dqd, d.M);
  model.ComputeGravityDerivatives(*data, q, d.dG_dq);
  return d;
}

// The same by central differences of the calls they differentiate.
Derivatives DifferencesOf(const Dynamics& model, const VectorXd& q, const VectorXd& qd, const VectorXd& tau,
                          DynamicsTerms terms = {}) {
  const int n = model.num_dofs();
  const std::unique_ptr<DynamicsData> data = model.MakeData();
  Derivatives d;
  d.qdd.resize(n);
  model.ComputeForwardDynamics(*data, q, qd, tau, terms, d.qdd);
  const auto fd = [&](const VectorXd& qs, const VectorXd& qds, const VectorXd& taus, VectorXd& out) {
    model.ComputeForwardDynamics(*data, qs, qds, taus, terms, out);
  };
  const auto id = [&](const VectorXd& qs, const VectorXd& qds, const VectorXd& qdds, VectorXd& out) {
    model.ComputeInverseDynamics(*data, qs, qds, qdds, terms, out);
  };
  d.dqdd_dq = CentralDifferences([&](const VectorXd& x, VectorXd& out) { fd(x, qd, tau, out); }, q, n, kStep);
  d.dqdd_dqd = CentralDifferences([&](const VectorXd& x, VectorXd& out) { fd(q, x, tau, out); }, qd, n, kStep);
  d.dqdd_dtau = CentralDifferences([&](const VectorXd& x, VectorXd& out) { fd(q, qd, x, out); }, tau, n, kStep);
  d.dtau_dq = CentralDifferences([&](const VectorXd& x, VectorXd& out) { id(x, qd, d.qdd, out); }, q, n, kStep);
  d.dtau_dqd = CentralDifferences([&](const VectorXd& x, VectorXd& out) { id(q, x, d.qdd, out); }, qd, n, kStep);
  d.M = CentralDifferences([&](const VectorXd& x, VectorXd& out) { id(q, qd, x, out); }, d.qdd, n, kStep);
  d.dG_dq = CentralDifferences([&](const VectorXd& x, VectorXd& out) { model.ComputeGravityForce(*data, x, out); }, q,
                               n, kStep);
  return d;
}

// Every matrix of `a` within `tol` of `b`, relative (a floor of 1 in each matrix's units).
void ExpectAgree(const Derivatives& a, const Derivatives& b, double tol, const std::string& what) {
  const std::pair<const char*, std::pair<const MatrixXd*, const MatrixXd*>> pairs[] = {
      {"dqdd_dq", {&a.dqdd_dq, &b.dqdd_dq}},    {"dqdd_dqd", {&a.dqdd_dqd, &b.dqdd_dqd}},
      {"dqdd_dtau", {&a.dqdd_dtau, &b.dqdd_dtau}}, {"dtau_dq", {&a.dtau_dq, &b.dtau_dq}},
      {"dtau_dqd", {&a.dtau_dqd, &b.dtau_dqd}}, {"M", {&a.M, &b.M}},
      {"dG_dq", {&a.dG_dq, &b.dG_dq}},
  };
  for (const auto& [name, m] : pairs) EXPECT_LT(RelativeDifference(*m.first, *m.second), tol) << what << " " << name;
}

VectorXd RandomTau(int n, std::mt19937& rng) { return testing::RandomVector(n, -2.0, 2.0, rng); }

std::string Describe(const std::string& plant, Method method, int state) {
  return plant + " " + std::string(ToString(method)) + " state " + std::to_string(state);
}

TEST(Derivatives, MatchCentralDifferencesForEveryPlantAndMethod) {
  std::mt19937 rng(42);
  for (const testing::PlantCase& c : testing::AllPlantCases()) {
    for (Method method : testing::MethodsOf(c.spec.type())) {
      const std::unique_ptr<Dynamics> model = MakeDynamics(c.spec, method);
      for (int k = 0; k < 3; ++k) {
        const testing::RandomState s = testing::RandomStateFor(model->joint_types(), rng);
        const VectorXd tau = RandomTau(model->num_dofs(), rng);
        ExpectAgree(DerivativesOf(*model, s.q, s.qd, tau), DifferencesOf(*model, s.q, s.qd, tau), kDifferenceTol,
                    Describe(c.name, method, k));
      }
    }
  }
}

TEST(Derivatives, ClosedFormLagrangianAndRecursiveDerivationsAgree) {
  std::mt19937 rng(7);
  for (const testing::PlantCase& c : testing::AllPlantCases()) {
    const std::vector<Method> methods = testing::MethodsOf(c.spec.type());
    std::vector<std::unique_ptr<Dynamics>> models;
    for (Method method : methods) models.push_back(MakeDynamics(c.spec, method));
    for (int k = 0; k < 5; ++k) {
      const testing::RandomState s = testing::RandomStateFor(models[0]->joint_types(), rng);
      const VectorXd tau = RandomTau(models[0]->num_dofs(), rng);
      const Derivatives first = DerivativesOf(*models[0], s.q, s.qd, tau);
      for (std::size_t m = 1; m < models.size(); ++m) {
        ExpectAgree(DerivativesOf(*models[m], s.q, s.qd, tau), first, kDerivationTol,
                    Describe(c.name, methods[m], k) + " against " + std::string(ToString(methods[0])));
      }
    }
  }
}

// Random trees: chains and branching, a third of the joints prismatic, random
// axes and inertias; every second one with mimic joints (every other joint
// following an earlier one, multiplier in ±2).
RigidTree RandomTree(int k, std::mt19937& rng) {
  RandomTreeOptions options;
  options.bodies = 2 + k % 7;
  options.chain = k % 2 == 0;
  RigidTree tree = RandomRigidTree(options, rng);
  if (k % 4 >= 2) AddRandomMimics(tree, rng);
  return tree;
}

// The recursive model of a tree, reduced when it has mimics (as MakeDynamics builds a URDF's).
std::unique_ptr<Dynamics> Recursive(const RigidTree& tree) {
  if (!tree.has_mimics()) return std::make_unique<SpatialDynamics>(tree);
  return std::make_unique<MimicDynamics>(tree, std::make_shared<const SpatialDynamics>(tree.WithEveryJointFree()));
}

TEST(Derivatives, OnRandomTreesTheRecursiveAndLagrangianDerivationsAgreeAndMatchDifferences) {
  std::mt19937 rng(2018);
  for (int k = 0; k < 16; ++k) {
    const RigidTree tree = RandomTree(k, rng);
    const std::unique_ptr<Dynamics> recursive = Recursive(tree);
    const LagrangianDynamics<RigidTree> lagrangian(tree);
    const testing::RandomState s = testing::RandomStateFor(tree.joint_types(), rng);
    const VectorXd tau = RandomTau(tree.num_dofs(), rng);
    const Derivatives r = DerivativesOf(*recursive, s.q, s.qd, tau);
    const std::string what = "tree " + std::to_string(k) + (tree.has_mimics() ? " (mimics)" : "");
    ExpectAgree(DerivativesOf(lagrangian, s.q, s.qd, tau), r, kDerivationTol, what + " lagrangian");
    ExpectAgree(r, DifferencesOf(*recursive, s.q, s.qd, tau), kDifferenceTol, what + " differences");
  }
}

// The shipped robots: the Panda, the UR5 and the Panda with its hand (a
// prismatic finger and its mimic), both methods, at three states each.
TEST(Derivatives, ShippedRobotsBothDerivationsAgreeAndMatchDifferences) {
  std::mt19937 rng(5);
  for (const char* file : {"panda.urdf", "ur5.urdf", "panda_hand.urdf"}) {
    const PlantSpec spec = UrdfPlantSpec(
        std::make_shared<const UrdfRobot>(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + file)));
    const std::unique_ptr<Dynamics> recursive = MakeDynamics(spec, Method::kRecursive);
    const std::unique_ptr<Dynamics> lagrangian = MakeDynamics(spec, Method::kLagrangian);
    for (int k = 0; k < 3; ++k) {
      testing::RandomState s = testing::RandomStateFor(recursive->joint_types(), rng);
      for (int i = 0; i < s.q.size(); ++i) {
        if (recursive->joint_types()[i] == JointType::kPrismatic) s.q[i] *= 0.01;  // a finger's stroke, m
      }
      const VectorXd tau = RandomTau(recursive->num_dofs(), rng);
      const Derivatives r = DerivativesOf(*recursive, s.q, s.qd, tau);
      ExpectAgree(DerivativesOf(*lagrangian, s.q, s.qd, tau), r, kDerivationTol, std::string(file) + " lagrangian");
      ExpectAgree(r, DifferencesOf(*recursive, s.q, s.qd, tau), kDifferenceTol, std::string(file) + " differences");
    }
  }
}

// ∂qdd/∂tau = M⁻¹: times M it is the identity, and it is symmetric.
TEST(Derivatives, DqddDtauTimesTheMassMatrixIsTheIdentity) {
  std::mt19937 rng(3);
  for (const testing::PlantCase& c : testing::AllPlantCases()) {
    for (Method method : testing::MethodsOf(c.spec.type())) {
      const std::unique_ptr<Dynamics> model = MakeDynamics(c.spec, method);
      const int n = model->num_dofs();
      const testing::RandomState s = testing::RandomStateFor(model->joint_types(), rng);
      const Derivatives d = DerivativesOf(*model, s.q, s.qd, RandomTau(n, rng));
      const MatrixXd I = MatrixXd::Identity(n, n);
      EXPECT_LT((d.dqdd_dtau * d.M - I).norm(), kIdentityTol * n) << Describe(c.name, method, 0);
      EXPECT_LT((d.dqdd_dtau - d.dqdd_dtau.transpose()).norm(), kIdentityTol * d.dqdd_dtau.norm())
          << Describe(c.name, method, 0);
    }
  }
}

// The velocity terms are quadratic in qd: at rest, with no damping in the
// dynamics, inverse dynamics does not change with qd to first order.
TEST(Derivatives, DtauDqdIsZeroAtRest) {
  std::mt19937 rng(11);
  for (const testing::PlantCase& c : testing::AllPlantCases()) {
    for (Method method : testing::MethodsOf(c.spec.type())) {
      const std::unique_ptr<Dynamics> model = MakeDynamics(c.spec, method);
      const int n = model->num_dofs();
      const testing::RandomState s = testing::RandomStateFor(model->joint_types(), rng);
      const Derivatives d = DerivativesOf(*model, s.q, VectorXd::Zero(n), RandomTau(n, rng));
      EXPECT_LT(d.dtau_dqd.norm(), 1e-13 * std::max(1.0, d.M.norm())) << Describe(c.name, method, 0);
      EXPECT_LT(d.dqdd_dqd.norm(), 1e-12) << Describe(c.name, method, 0);
    }
  }
}

// ∂G/∂q is the Hessian of V (symmetric), and the inverse-dynamics derivative
// at rest with zero acceleration.
TEST(Derivatives, GravityDerivativeIsTheSymmetricHessianOfVAndIdsAtRest) {
  std::mt19937 rng(13);
  for (const testing::PlantCase& c : testing::AllPlantCases()) {
    for (Method method : testing::MethodsOf(c.spec.type())) {
      const std::unique_ptr<Dynamics> model = MakeDynamics(c.spec, method);
      const std::unique_ptr<DynamicsData> data = model->MakeData();
      const int n = model->num_dofs();
      const testing::RandomState s = testing::RandomStateFor(model->joint_types(), rng);
      MatrixXd dG(n, n), dq(n, n), dqd(n, n), M(n, n);
      model->ComputeGravityDerivatives(*data, s.q, dG);
      model->ComputeInverseDynamicsDerivatives(*data, s.q, VectorXd::Zero(n), VectorXd::Zero(n), DynamicsTerms{}, dq,
                                               dqd, M);
      EXPECT_LT(RelativeDifference(dG, dG.transpose()), kDerivationTol) << Describe(c.name, method, 0);
      EXPECT_LT(RelativeDifference(dG, dq), kDerivationTol) << Describe(c.name, method, 0);
    }
  }
}

// A term that is off is not differentiated: without Coriolis ∂tau/∂qd is zero
// and the rest is the derivative of M qdd + G; without gravity, of M qdd + C qd.
TEST(Derivatives, TermsThatAreOffAreLeftOutOfTheDerivatives) {
  std::mt19937 rng(17);
  for (const testing::PlantCase& c : testing::AllPlantCases()) {
    for (Method method : testing::MethodsOf(c.spec.type())) {
      const std::unique_ptr<Dynamics> model = MakeDynamics(c.spec, method);
      const int n = model->num_dofs();
      const testing::RandomState s = testing::RandomStateFor(model->joint_types(), rng);
      const VectorXd tau = RandomTau(n, rng);
      for (const DynamicsTerms terms : {DynamicsTerms{.gravity = true, .coriolis = false},
                                        DynamicsTerms{.gravity = false, .coriolis = true},
                                        DynamicsTerms{.gravity = false, .coriolis = false}}) {
        const Derivatives d = DerivativesOf(*model, s.q, s.qd, tau, terms);
        Derivatives differences = DifferencesOf(*model, s.q, s.qd, tau, terms);
        differences.dG_dq = d.dG_dq;  // G's own derivative does not depend on the terms
        const std::string what = Describe(c.name, method, 0) + " gravity " + std::to_string(terms.gravity) +
                                 " coriolis " + std::to_string(terms.coriolis);
        ExpectAgree(d, differences, kDifferenceTol, what);
        if (!terms.coriolis) {
          EXPECT_EQ(d.dtau_dqd.norm(), 0.0) << what;
        }
      }
    }
  }
}

// Near a singular M (a cart of 1e-4 kg under a point-mass pole, cond(M) ≈
// 1e5 at θ = 0.1; a chain whose last link is 1e-3 of the others) and at high
// speed (|qd| up to 50 rad/s): the derivations still agree, to the condition
// number's share of round-off for ∂qdd.
TEST(Derivatives, NearASingularMassMatrixAndAtHighSpeedTheDerivationsAgree) {
  CartPoleParams cart;
  cart.mc = 1e-4;
  cart.mp = 1.0;
  cart.I = 0.0;
  ChainParams chain;
  chain.links.resize(4);
  chain.links.back().m = 1e-3;  // its inertia m L²/12 with it
  std::mt19937 rng(19);
  for (const PlantSpec& spec : {PlantSpec{cart}, PlantSpec{chain}, DefaultPlantSpec(PlantType::kArm2)}) {
    const std::vector<Method> methods = testing::MethodsOf(spec.type());
    const int n = spec.num_dofs();
    for (int k = 0; k < 3; ++k) {
      testing::RandomState s = testing::RandomStateFor(JointTypesOf(spec), rng);
      if (spec.type() == PlantType::kCartPole) s.q[1] = 0.1;
      s.qd *= k == 2 ? 50.0 / 3.0 : 1.0;  // the last state at high speed
      const VectorXd tau = RandomTau(n, rng);
      const std::unique_ptr<Dynamics> reference = MakeDynamics(spec, methods.back());
      const Derivatives r = DerivativesOf(*reference, s.q, s.qd, tau);
      const auto eig = SymmetricEigenvalues(r.M);
      const double cond = eig.maxCoeff() / eig.minCoeff();
      for (std::size_t m = 0; m + 1 < methods.size(); ++m) {
        const Derivatives d = DerivativesOf(*MakeDynamics(spec, methods[m]), s.q, s.qd, tau);
        const std::string what = std::string(ToString(spec.type())) + " " + std::string(ToString(methods[m])) +
                                 " state " + std::to_string(k) + " cond(M) " + std::to_string(cond);
        EXPECT_LT(RelativeDifference(d.dtau_dq, r.dtau_dq), kDerivationTol) << what;
        EXPECT_LT(RelativeDifference(d.dtau_dqd, r.dtau_dqd), kDerivationTol) << what;
        const double tol = std::max(kDerivationTol, 1e-14 * cond);
        EXPECT_LT(RelativeDifference(d.dqdd_dq, r.dqdd_dq), tol) << what;
        EXPECT_LT(RelativeDifference(d.dqdd_dqd, r.dqdd_dqd), tol) << what;
        EXPECT_LT(RelativeDifference(d.dqdd_dtau, r.dqdd_dtau), tol) << what;
      }
    }
  }
}

}  // namespace
}  // namespace lagrange
