// Derivation cost of the 3-D robots (issue: URDF robots): time per evaluation
// of M, C, C qd, G, ∂T/∂q, inverse and forward dynamics by both methods that
// a RigidTree has, Lagrangian (LagrangianDynamics<RigidTree>, automatic
// differentiation of the energies) and recursive (SpatialDynamics: CRBA, RNEA,
// ABA), for the shipped robots (config/robots/panda.urdf, ur5.urdf) and for
// random spatial chains of 2 to 64 links (bench/bench_plants.hpp); plus the
// machine baseline (calib/sincos) in the same run. dynamics_bench does the
// same for the planar plants; bench/report.py puts both in one section.
//
// Benchmark names: derive/<plant>/<method>/<term>, plant one of panda, ur5,
// spatial<n>; term one of M, C, Cqd, G, dTdq, ID, FD (see DynamicsTerm).
// Each call cycles through 16 seeded random states.

#include <memory>
#include <string>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "plant/lagrangian.hpp"
#include "plant/spatial_dynamics.hpp"

namespace lagrange::bench {
namespace {

std::unique_ptr<Dynamics> MakeTreeDynamics(const RigidTree& tree, Method method) {
  if (method == Method::kLagrangian) return std::make_unique<LagrangianDynamics<RigidTree>>(tree);
  return std::make_unique<SpatialDynamics>(tree);
}

void TimeTreeTerm(benchmark::State& bm, const RigidTree& tree, Method method, DynamicsTerm term) {
  const std::unique_ptr<Dynamics> d = MakeTreeDynamics(tree, method);
  TimeTerm(bm, *d, term);
}

void RegisterTree(const NamedTree& robot) {
  for (Method method : {Method::kLagrangian, Method::kRecursive}) {
    for (DynamicsTerm term : kAllDynamicsTerms) {
      const std::string name =
          "derive/" + robot.name + "/" + std::string(ToString(method)) + "/" + std::string(TermName(term));
      benchmark::RegisterBenchmark(name.c_str(), [tree = robot.tree, method, term](benchmark::State& bm) {
        TimeTreeTerm(bm, tree, method, term);
      });
    }
  }
}

void RegisterAll() {
  for (const std::string& name : ShippedRobotNames()) RegisterTree(LoadShippedRobot(name));
  for (int links : SpatialChainSizes()) RegisterTree(RandomSpatialChain(links));
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::RegisterAll); }
