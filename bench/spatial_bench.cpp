// Cost of the spatial rigid-tree algorithms (plant/spatial_dynamics.hpp) per
// call, against the machine baseline calib/sincos (bench/gbench.hpp): a 7-DOF
// arm with the Franka Panda's geometry, and random chains of 2 to 64 links to
// show the O(n) growth.
//
// Benchmark names: spatial/<plant>/<term>, term one of
//   ID       ComputeInverseDynamics      (q, qd, qdd) => tau, gravity and Coriolis on
//   FD       ComputeForwardDynamics      (q, qd, tau) => qdd, the algorithm chosen for the size
//   FD_aba   ... by the articulated-body algorithm
//   FD_crba  ... by CRBA + the tree-sparse Lᵀ D L solve
//   M        ComputeMassMatrix           q => M (n x n)
//   C        ComputeCoriolisMatrix       (q, qd) => C (n x n)
//   Cqd      ComputeCoriolisForce        (q, qd) => C qd (n)
//   G        ComputeGravityForce         q => G (n)
//   dTdq     ComputeKineticEnergyGradient
//   T, V     the energies
// Each call cycles through 16 seeded random states. Also calib/sincos7_libm and
// calib/sincos7_batch: the sines and cosines of 7 angles by the C library and
// by plant/spatial_sincos.hpp.

#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "bench/gbench.hpp"
#include "plant/random_tree.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/spatial_sincos.hpp"

namespace lagrange::bench {
namespace {

constexpr int kStates = 16;

// The Panda's kinematics by its modified Denavit–Hartenberg parameters
// (a_{i−1}, d_i, α_{i−1}): joint i sits at Rx(α) Tx(a) Tz(d) from joint i−1
// and turns about its z. Link masses are the published identified ones;
// centres of mass and inertias are seeded random and physically valid.
RigidTree PandaLikeArm() {
  constexpr double kPi = std::numbers::pi;
  const double dh[7][3] = {{0, 0.333, 0},        {0, 0, -kPi / 2},           {0, 0.316, kPi / 2},
                           {0.0825, 0, kPi / 2}, {-0.0825, 0.384, -kPi / 2}, {0, 0, kPi / 2},
                           {0.088, 0, kPi / 2}};
  const double mass[7] = {4.97, 0.646, 3.228, 3.587, 1.225, 1.666, 0.735};
  std::mt19937 rng{42};
  RigidTree tree = RandomRigidTree({.bodies = 7, .chain = true, .prismatic_fraction = 0.0}, rng);
  for (int i = 0; i < 7; ++i) {
    const auto [a, d, alpha] = dh[i];
    const Eigen::Matrix3d Rx = Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()).toRotationMatrix();
    tree.joints[i].rotation = Rx;
    tree.joints[i].position = Eigen::Vector3d(a, 0.0, 0.0) + Rx * Eigen::Vector3d(0.0, 0.0, d);
    tree.joints[i].axis = Eigen::Vector3d::UnitZ();
    tree.bodies[i].mass = mass[i];
    tree.bodies[i].com *= 0.5;
  }
  tree.gravity = Eigen::Vector3d(0.0, 0.0, -kStandardGravity);
  return tree;
}

RigidTree RandomChain(int links) {
  std::mt19937 rng{static_cast<std::uint32_t>(links)};
  return RandomRigidTree({.bodies = links, .chain = true, .prismatic_fraction = 0.0}, rng);
}

struct State {
  VectorXd q, qd, qdd, tau;
};

enum class Term { kID, kFD, kFDAba, kFDCrba, kM, kC, kCqd, kG, kdTdq, kT, kV };
constexpr std::pair<Term, const char*> kTerms[] = {
    {Term::kID, "ID"},     {Term::kFD, "FD"}, {Term::kFDAba, "FD_aba"}, {Term::kFDCrba, "FD_crba"},
    {Term::kM, "M"},       {Term::kC, "C"},   {Term::kCqd, "Cqd"},      {Term::kG, "G"},
    {Term::kdTdq, "dTdq"}, {Term::kT, "T"},   {Term::kV, "V"}};

// kStates seeded random states of n joints: q in ±π, qd, qdd and tau in ±2.
std::vector<State> SeededStates(int n) {
  std::mt19937 rng{7};
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), rate(-2.0, 2.0);
  std::vector<State> states(kStates);
  for (State& s : states) {
    s.q = s.qd = s.qdd = s.tau = VectorXd(n);
    for (int i = 0; i < n; ++i) {
      s.q[i] = angle(rng);
      s.qd[i] = rate(rng);
      s.qdd[i] = rate(rng);
      s.tau[i] = rate(rng);
    }
  }
  return states;
}

void TimeTerm(benchmark::State& bm, const RigidTree& tree, Term term) {
  const SpatialDynamics d(tree);
  const std::unique_ptr<DynamicsData> d_data = d.MakeData();
  const int n = d.num_dofs();
  const std::vector<State> states = SeededStates(n);
  MatrixXd M(n, n);
  VectorXd v(n);
  double x = 0.0;
  using FA = SpatialDynamics::ForwardAlgorithm;
  int k = 0;
  for (auto _ : bm) {
    const State& s = states[k];
    switch (term) {
      case Term::kID: d.ComputeInverseDynamics(*d_data, s.q, s.qd, s.qdd, DynamicsTerms{}, v); break;
      case Term::kFD: d.ComputeForwardDynamics(*d_data, s.q, s.qd, s.tau, DynamicsTerms{}, v); break;
      case Term::kFDAba: d.ComputeForwardDynamics(*d_data, FA::kArticulatedBody, s.q, s.qd, s.tau, DynamicsTerms{}, v); break;
      case Term::kFDCrba:
        d.ComputeForwardDynamics(*d_data, FA::kCompositeRigidBody, s.q, s.qd, s.tau, DynamicsTerms{}, v);
        break;
      case Term::kM: d.ComputeMassMatrix(*d_data, s.q, M); break;
      case Term::kC: d.ComputeCoriolisMatrix(*d_data, s.q, s.qd, M); break;
      case Term::kCqd: d.ComputeCoriolisForce(*d_data, s.q, s.qd, v); break;
      case Term::kG: d.ComputeGravityForce(*d_data, s.q, v); break;
      case Term::kdTdq: d.ComputeKineticEnergyGradient(*d_data, s.q, s.qd, v); break;
      case Term::kT: x += d.ComputeKineticEnergy(*d_data, s.q, s.qd); break;
      case Term::kV: x += d.ComputePotentialEnergy(*d_data, s.q); break;
    }
    benchmark::DoNotOptimize(M.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::DoNotOptimize(x);
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = n;
}

// 7 sines and cosines of changing angles, by the C library or in one batch.
template <bool kBatch>
void TimeSinCos7(benchmark::State& bm) {
  std::mt19937 rng{3};
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
  double x[kStates][7], c[7], s[7];
  for (auto& row : x) {
    for (double& xi : row) xi = angle(rng);
  }
  int k = 0;
  for (auto _ : bm) {
    if (kBatch) {
      spatial::SinCos(x[k], c, s, 7);
    } else {
      for (int i = 0; i < 7; ++i) {
        c[i] = std::cos(x[k][i]);
        s[i] = std::sin(x[k][i]);
      }
    }
    benchmark::DoNotOptimize(c);
    benchmark::DoNotOptimize(s);
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
}

void Register(const std::string& name, const RigidTree& tree, std::initializer_list<Term> terms) {
  for (const auto& [term, label] : kTerms) {
    if (std::find(terms.begin(), terms.end(), term) == terms.end()) continue;
    const std::string full = "spatial/" + name + "/" + label;
    benchmark::RegisterBenchmark(full.c_str(), [tree, term = term](benchmark::State& bm) { TimeTerm(bm, tree, term); });
  }
}

void RegisterAll() {
  benchmark::RegisterBenchmark("calib/sincos7_libm", TimeSinCos7<false>);
  benchmark::RegisterBenchmark("calib/sincos7_batch", TimeSinCos7<true>);
  const auto all = {Term::kID,  Term::kFD, Term::kFDAba, Term::kFDCrba, Term::kM, Term::kC,
                    Term::kCqd, Term::kG,  Term::kdTdq,  Term::kT,      Term::kV};
  Register("panda", PandaLikeArm(), all);
  for (int links : {2, 4, 8, 16, 32, 64}) {
    Register("chain" + std::to_string(links), RandomChain(links),
             {Term::kID, Term::kFDAba, Term::kFDCrba, Term::kM, Term::kC, Term::kG});
  }
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::RegisterAll); }
