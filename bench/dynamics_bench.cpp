// Derivation cost (issue 6, item 3): time per evaluation of M, C, C qd, G and
// forward dynamics by each method, for the pendulum, the arm, the cart-pole
// and chains of 2 to 64 links; plus the machine baseline every figure is
// compared with in the report (one sin and one cos).
//
// Benchmark names: derive/<plant>/<method>/<term>, term one of
//   M    ComputeMassMatrix           q => M (n x n)
//   C    ComputeCoriolisMatrix       (q, qd) => C (n x n)
//   Cqd  ComputeCoriolisForce        (q, qd) => C qd (n)
//   G    ComputeGravityForce         q => G (n)
//   FD   ComputeForwardDynamics      (q, qd, tau) => qdd (n), gravity and Coriolis on
// and calib/sincos. Each call cycles through 16 seeded random states.

#include <functional>
#include <memory>
#include <string>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"

namespace lagrange::bench {
namespace {

constexpr int kStates = 16;  // states cycled through, so no call sees a constant input

enum class Term { kM, kC, kCqd, kG, kFD };

std::string_view ToString(Term term) {
  switch (term) {
    case Term::kM: return "M";
    case Term::kC: return "C";
    case Term::kCqd: return "Cqd";
    case Term::kG: return "G";
    case Term::kFD: return "FD";
  }
  return "?";
}

// One call of `term` on state s; results land in M or v.
void Evaluate(Dynamics& d, Term term, const State& s, MatrixXd& M, VectorXd& v) {
  switch (term) {
    case Term::kM: d.ComputeMassMatrix(s.q, M); break;
    case Term::kC: d.ComputeCoriolisMatrix(s.q, s.qd, M); break;
    case Term::kCqd: d.ComputeCoriolisForce(s.q, s.qd, v); break;
    case Term::kG: d.ComputeGravityForce(s.q, v); break;
    case Term::kFD: d.ComputeForwardDynamics(s.q, s.qd, s.tau, DynamicsTerms{}, v); break;
  }
}

void TimeTerm(benchmark::State& bm, const PlantSpec& spec, Method method, Term term) {
  std::unique_ptr<Dynamics> d = MakeDynamics(spec, method);
  std::mt19937 rng{42};
  const std::vector<State> states = RandomStates(d->joint_types(), kStates, rng);
  const int n = d->num_dofs();
  MatrixXd M(n, n);
  VectorXd v(n);
  int k = 0;
  for (auto _ : bm) {
    Evaluate(*d, term, states[k], M, v);
    benchmark::DoNotOptimize(M.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = n;
}

void RegisterPlant(const NamedPlant& plant) {
  for (Method method : MethodsOf(plant.spec.type())) {
    for (Term term : {Term::kM, Term::kC, Term::kCqd, Term::kG, Term::kFD}) {
      const std::string name =
          "derive/" + plant.name + "/" + std::string(lagrange::ToString(method)) + "/" + std::string(ToString(term));
      benchmark::RegisterBenchmark(
          name.c_str(), [spec = plant.spec, method, term](benchmark::State& bm) { TimeTerm(bm, spec, method, term); });
    }
  }
}

void RegisterAll() {
  for (const NamedPlant& p : FixedPlants()) RegisterPlant(p);
  for (int links : ChainSizes()) RegisterPlant(Chain(links));
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::RegisterAll); }
