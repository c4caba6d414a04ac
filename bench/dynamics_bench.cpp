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
//   ID   ComputeInverseDynamics      (q, qd, qdd) => tau (n), gravity and Coriolis on
//   FD   ComputeForwardDynamics      (q, qd, tau) => qdd (n), gravity and Coriolis on
// and calib/sincos. Each call cycles through 16 seeded random states. The
// method "spatial" is the spatial algorithms (plant/spatial_dynamics.hpp) on
// the plant's tree, beside its recursive path (the planar algorithms on the
// same tree folded to 2-D): the measurement that keeps the planar ones.

#include <memory>
#include <string>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "plant/spatial_dynamics.hpp"

namespace lagrange::bench {
namespace {

constexpr DynamicsTerm kTerms[] = {DynamicsTerm::kM, DynamicsTerm::kC, DynamicsTerm::kCqd, DynamicsTerm::kG,
                                   DynamicsTerm::kID, DynamicsTerm::kFD};

void RegisterPlant(const NamedPlant& plant) {
  for (Method method : MethodsOf(plant.spec.type())) {
    for (DynamicsTerm term : kTerms) {
      const std::string name =
          "derive/" + plant.name + "/" + std::string(lagrange::ToString(method)) + "/" + std::string(TermName(term));
      benchmark::RegisterBenchmark(name.c_str(), [spec = plant.spec, method, term](benchmark::State& bm) {
        TimeTerm(bm, *MakeDynamics(spec, method), term);
      });
    }
  }
  for (DynamicsTerm term : kTerms) {
    const std::string name = "derive/" + plant.name + "/spatial/" + std::string(TermName(term));
    benchmark::RegisterBenchmark(name.c_str(), [spec = plant.spec, term](benchmark::State& bm) {
      TimeTerm(bm, SpatialDynamics(MakeRigidTree(spec)), term);
    });
  }
}

void RegisterAll() {
  for (const NamedPlant& p : FixedPlants()) RegisterPlant(p);
  for (int links : ChainSizes()) RegisterPlant(Chain(links));
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::RegisterAll); }
