// Model and data apart (plant/dynamics.hpp): one immutable Dynamics model
// evaluated from several threads at once, each with its own DynamicsData,
// gives every thread exactly what one thread alone gets. Built as its own
// executable so that scripts/test-tsan runs it under ThreadSanitizer, which
// fails it on any write a query makes to the shared model.

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

constexpr int kThreads = 2;
constexpr int kStates = 200;

// Everything one state's queries produce, flattened.
VectorXd EvaluateAll(const Dynamics& model, DynamicsData& data, const VectorXd& q, const VectorXd& qd) {
  const int n = model.num_dofs();
  MatrixXd M(n, n), C(n, n);
  VectorXd c(n), G(n), dTdq(n), qdd(n), tau(n);
  model.ComputeMassMatrix(data, q, M);
  model.ComputeCoriolisMatrix(data, q, qd, C);
  model.ComputeCoriolisForce(data, q, qd, c);
  model.ComputeGravityForce(data, q, G);
  model.ComputeKineticEnergyGradient(data, q, qd, dTdq);
  model.ComputeForwardDynamics(data, q, qd, qd, DynamicsTerms{}, qdd);
  model.ComputeInverseDynamics(data, q, qd, qdd, DynamicsTerms{}, tau);
  VectorXd out(2 * n * n + 5 * n + 2);
  out << M.reshaped(), C.reshaped(), c, G, dTdq, qdd, tau, model.ComputeKineticEnergy(data, q, qd),
      model.ComputePotentialEnergy(data, q);
  return out;
}

struct Case {
  std::string name;
  PlantSpec spec;
  Method method;
};

std::vector<Case> Cases() {
  const auto panda = std::make_shared<const UrdfRobot>(LoadUrdf(LAGRANGE_SOURCE_DIR "/config/robots/panda.urdf"));
  ChainParams chain;
  chain.links.resize(7);
  return {
      {"arm2 closed form", DefaultPlantSpec(PlantType::kArm2), Method::kClosedForm},
      {"arm2 lagrangian", DefaultPlantSpec(PlantType::kArm2), Method::kLagrangian},
      {"chain7 recursive (planar)", PlantSpec{chain}, Method::kRecursive},
      {"chain7 lagrangian", PlantSpec{chain}, Method::kLagrangian},
      {"panda recursive (spatial)", UrdfPlantSpec(panda), Method::kRecursive},
      {"panda lagrangian", UrdfPlantSpec(panda), Method::kLagrangian},
  };
}

// kThreads threads evaluate `evaluate` at `count` seeded random states of
// `model` at once, each through its own data and in its own order so that
// they overlap on different states: each gets, bit for bit, what one thread
// alone gets (the same code on the same inputs, whatever else runs).
template <class Evaluate>
void ExpectEveryThreadGetsWhatOneThreadGets(const Dynamics& model, int count, unsigned seed, Evaluate evaluate) {
  std::mt19937 rng{seed};
  std::vector<testing::RandomState> states;
  for (int k = 0; k < count; ++k) states.push_back(testing::RandomStateFor(model.joint_types(), rng));
  std::vector<VectorXd> expected;
  const std::unique_ptr<DynamicsData> alone = model.MakeData();
  for (const auto& s : states) expected.push_back(evaluate(model, *alone, s.q, s.qd));
  std::vector<std::vector<VectorXd>> got(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      const std::unique_ptr<DynamicsData> data = model.MakeData();
      got[t].resize(states.size());
      for (int k = 0; k < count; ++k) {
        const int i = t % 2 == 0 ? k : count - 1 - k;
        got[t][i] = evaluate(model, *data, states[i].q, states[i].qd);
      }
    });
  }
  for (std::thread& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) {
    for (int k = 0; k < count; ++k) ASSERT_EQ(got[t][k], expected[k]) << "thread " << t << " state " << k;
  }
}

TEST(ModelData, ThreadsSharingOneModelEachWithItsOwnDataGetWhatOneThreadGets) {
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.name);
    const std::shared_ptr<const Dynamics> model = MakeDynamics(c.spec, c.method);
    ExpectEveryThreadGetsWhatOneThreadGets(*model, kStates, 42, EvaluateAll);
  }
}

// Every derivative one state's queries produce (∂FD, ∂ID at that qdd, ∂G), flattened.
VectorXd EvaluateDerivatives(const Dynamics& model, DynamicsData& data, const VectorXd& q, const VectorXd& qd) {
  const int n = model.num_dofs();
  VectorXd qdd(n);
  MatrixXd a(n, n), b(n, n), c(n, n), d(n, n), e(n, n), f(n, n), g(n, n);
  model.ComputeForwardDynamicsDerivatives(data, q, qd, qd, DynamicsTerms{}, qdd, a, b, c);
  model.ComputeInverseDynamicsDerivatives(data, q, qd, qdd, DynamicsTerms{}, d, e, f);
  model.ComputeGravityDerivatives(data, q, g);
  VectorXd out(7 * n * n + n);
  out << a.reshaped(), b.reshaped(), c.reshaped(), d.reshaped(), e.reshaped(), f.reshaped(), g.reshaped(), qdd;
  return out;
}

TEST(ModelData, ThreadsSharingOneModelGetTheDerivativesOneThreadGets) {
  constexpr int kDerivativeStates = 40;  // the Lagrangian path's are costly under ThreadSanitizer
  std::vector<Case> cases = Cases();
  cases.push_back({"panda with hand recursive (mimic)",
                   UrdfPlantSpec(std::make_shared<const UrdfRobot>(
                       LoadUrdf(LAGRANGE_SOURCE_DIR "/config/robots/panda_hand.urdf"))),
                   Method::kRecursive});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::shared_ptr<const Dynamics> model = MakeDynamics(c.spec, c.method);
    ExpectEveryThreadGetsWhatOneThreadGets(*model, kDerivativeStates, 7, EvaluateDerivatives);
  }
}

// Every frame's pose, Jacobians and biases, flattened.
VectorXd EvaluateFrames(const Kinematics& model, KinematicsData& data, const VectorXd& q, const VectorXd& qd) {
  model.ComputeFrameKinematics(data, q, qd);
  const int n = model.num_dofs();
  VectorXd out(model.num_frames() * (12 + 24 * n + 12));
  int at = 0;
  for (int k = 0; k < model.num_frames(); ++k) {
    out.segment(at, 9) = data.rotation(k).reshaped();
    out.segment(at + 9, 3) = data.position(k);
    at += 12;
    for (FrameAxes axes : {FrameAxes::kWorldAligned, FrameAxes::kLocal}) {
      out.segment(at, 6 * n) = data.jacobian(k, axes).reshaped();
      out.segment(at + 6 * n, 6) = data.bias_acceleration(k, axes);
      at += 6 * n + 6;
    }
  }
  return out.head(at);
}

TEST(ModelData, ThreadsSharingOneKinematicsModelEachWithItsOwnDataGetWhatOneThreadGets) {
  const Kinematics model(LoadUrdf(LAGRANGE_SOURCE_DIR "/config/robots/panda.urdf").tree);
  std::mt19937 rng{42};
  std::vector<testing::RandomState> states;
  for (int k = 0; k < kStates; ++k) {
    states.push_back(testing::RandomStateFor(std::vector<JointType>(7, JointType::kRevolute), rng));
  }
  std::vector<VectorXd> expected;
  const std::unique_ptr<KinematicsData> alone = model.MakeData();
  for (const auto& s : states) expected.push_back(EvaluateFrames(model, *alone, s.q, s.qd));
  std::vector<std::vector<VectorXd>> got(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      const std::unique_ptr<KinematicsData> data = model.MakeData();
      got[t].resize(states.size());
      for (int k = 0; k < kStates; ++k) {
        const int i = t % 2 == 0 ? k : kStates - 1 - k;
        got[t][i] = EvaluateFrames(model, *data, states[i].q, states[i].qd);
      }
    });
  }
  for (std::thread& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) {
    for (int k = 0; k < kStates; ++k) ASSERT_EQ(got[t][k], expected[k]) << "thread " << t << " state " << k;
  }
}

TEST(ModelData, EachDataCountsOnlyItsOwnEvaluations) {
  const std::shared_ptr<const Dynamics> model = MakeDynamics(DefaultPlantSpec(PlantType::kArm2), Method::kRecursive);
  const std::unique_ptr<DynamicsData> a = model->MakeData(), b = model->MakeData();
  const VectorXd q = VectorXd::Constant(2, 0.3), qd = VectorXd::Constant(2, -0.2);
  VectorXd qdd(2);
  for (int k = 0; k < 3; ++k) model->ComputeForwardDynamics(*a, q, qd, q, DynamicsTerms{}, qdd);
  model->ComputeForwardDynamics(*b, q, qd, q, DynamicsTerms{.gravity = true, .coriolis = false}, qdd);
  EXPECT_EQ(a->counts().gravity, 3);
  EXPECT_EQ(a->counts().coriolis, 3);
  EXPECT_EQ(b->counts().gravity, 1);
  EXPECT_EQ(b->counts().coriolis, 0);
  EXPECT_EQ(&a->model(), model.get());
}

}  // namespace
}  // namespace lagrange
