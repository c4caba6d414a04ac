#pragma once
// Plants, robots, states and models shared by the benchmark programs.
//
// Every state comes from a seeded generator (std::mt19937{42}), so two runs
// time the same arithmetic. Units as in plant/types.hpp: q in rad or m,
// qd in rad/s or m/s, qdd in rad/s² or m/s², tau in N·m or N.

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <benchmark/benchmark.h>

#include "plant/effects.hpp"
#include "plant/plant_factory.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange::bench {

// A plant to time, with the name the report uses ("arm2", "chain30").
struct NamedPlant {
  std::string name;
  PlantSpec spec;
};

// pendulum, arm2 and cartpole with their default parameters.
std::vector<NamedPlant> FixedPlants();
// Chains of the report's sizes: n = 2, 4, 7, 12, 20, 30, 50, 64 default links (64: kMaxDofs is tested up to 64).
std::vector<int> ChainSizes();
NamedPlant Chain(int links);

// The methods a plant type has, closed form first.
std::vector<Method> MethodsOf(PlantType type);

// A 3-D robot to time, with the name the report uses ("panda", "spatial12").
struct NamedTree {
  std::string name;
  RigidTree tree;
};

// The robots shipped in config/robots/, by file name: panda (7 DOF), ur5 (6 DOF).
std::vector<std::string> ShippedRobotNames();
// config/robots/<name>.urdf of this source tree, loaded by LoadUrdf (plant/urdf.hpp);
// throws UrdfError when it does not load.
NamedTree LoadShippedRobot(const std::string& name);

// The same robot as a urdf plant (UrdfPlantSpec), named `name`.
NamedPlant ShippedRobotPlant(const std::string& name);

// Sizes of the random spatial chains: the planar chains' sizes.
std::vector<int> SpatialChainSizes();

// A random serial chain of `links` bodies, "spatial<links>": RandomRigidTree
// (plant/random_tree.hpp) from std::mt19937{seed} with every parent the joint
// before (random origins, axes, masses, full inertias, gravity direction) and
// a joint prismatic with probability `prismatic_fraction`.
NamedTree RandomSpatialChain(int links, std::uint32_t seed = 42, double prismatic_fraction = 0.0);

// One state and command for a plant of n dofs.
struct State {
  VectorXd q, qd, tau, qdd;
};

// `count` random states: q uniform in ±π (±1 m for a prismatic joint), qd in
// ±2 rad/s (m/s), tau in ±1 N·m (N), qdd in ±1 rad/s² (m/s²). q, qd and tau
// are drawn state by state first, qdd after them all.
std::vector<State> RandomStates(const std::vector<JointType>& joints, int count, std::mt19937& rng);

// Gravity and Coriolis terms on, every optional effect off.
EffectsConfig DefaultEffects();

// One evaluation a derivation-cost benchmark times, by its Dynamics call:
//   M     ComputeMassMatrix              q => M (n x n)
//   C     ComputeCoriolisMatrix          (q, qd) => C (n x n)
//   Cqd   ComputeCoriolisForce           (q, qd) => C qd (n)
//   G     ComputeGravityForce            q => G (n)
//   dTdq  ComputeKineticEnergyGradient   (q, qd) => ∂T/∂q (n)
//   ID    ComputeInverseDynamics         (q, qd, qdd) => tau (n), gravity and Coriolis on
//   FD    ComputeForwardDynamics         (q, qd, tau) => qdd (n), gravity and Coriolis on
enum class DynamicsTerm : std::uint8_t { kM, kC, kCqd, kG, kdTdq, kID, kFD };
inline constexpr DynamicsTerm kAllDynamicsTerms[] = {DynamicsTerm::kM, DynamicsTerm::kC,    DynamicsTerm::kCqd,
                                                     DynamicsTerm::kG, DynamicsTerm::kdTdq, DynamicsTerm::kID,
                                                     DynamicsTerm::kFD};
std::string_view TermName(DynamicsTerm term);
// One call of `term` on state s through `data` (d's); a matrix lands in M (n x n), a vector in v (n).
void EvaluateTerm(const Dynamics& d, DynamicsData& data, DynamicsTerm term, const State& s, MatrixXd& M,
                  VectorXd& v);
// Times `term` of `d` under Google Benchmark, cycling through 16 seeded random
// states so no call sees a constant input; sets the counter "dofs".
void TimeTerm(benchmark::State& bm, const Dynamics& d, DynamicsTerm term);

// Times call(data, state, M, v) the way TimeTerm times a term (the same 16
// states, M n x n and v n as the outputs): for calls TimeTerm has no name for,
// such as one kernel of several.
template <class Call>
void TimeCall(benchmark::State& bm, const Dynamics& d, Call&& call) {
  const std::unique_ptr<DynamicsData> d_data = d.MakeData();
  constexpr int kStates = 16;
  std::mt19937 rng{42};
  const std::vector<State> states = RandomStates(d.joint_types(), kStates, rng);
  const int n = d.num_dofs();
  MatrixXd M(n, n);
  VectorXd v(n);
  int k = 0;
  for (auto _ : bm) {
    call(*d_data, states[k], M, v);
    benchmark::DoNotOptimize(M.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = n;
}

}  // namespace lagrange::bench
