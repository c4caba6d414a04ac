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
//
// And mass/<plant>/<kernel>: the planar chains' two exact mass-matrix kernels
// (RecursiveDynamics::MassMatrixKernel: carried, the old, and base_frame, the
// default since issue 37) on the same states, old beside new in one run; and
// the spatial ones (SpatialDynamics::MassMatrixKernel: body_frame, the old,
// and world_frame, the default since issue 37) on the shipped robots (panda,
// ur5), a random branching tree of 12 bodies with prismatic joints (mixed12)
// and random chains of 12 and 64 (spatial12, spatial64; the body-frame
// kernel's deep-tree form runs at 64).

#include <memory>
#include <string>
#include <utility>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "plant/random_tree.hpp"
#include "plant/recursive_dynamics.hpp"
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

// mass/<plant>/<kernel> for each of the planar chain's mass-matrix kernels.
void RegisterMassKernels(const NamedPlant& plant) {
  using K = RecursiveDynamics::MassMatrixKernel;
  auto d = std::make_shared<const RecursiveDynamics>(*PlanarChainOf(MakeRigidTree(plant.spec)));
  for (const auto& [kernel, label] : {std::pair{K::kCarried, "carried"}, std::pair{K::kBaseFrame, "base_frame"}}) {
    const std::string name = "mass/" + plant.name + "/" + label;
    benchmark::RegisterBenchmark(name.c_str(), [d, kernel](benchmark::State& bm) {
      TimeCall(bm, *d, [&d, kernel](DynamicsData& data, const State& s, MatrixXd& M, VectorXd&) {
        d->ComputeMassMatrix(data, kernel, s.q, M);
      });
    });
  }
}

// mass/<robot>/<kernel> for each of the spatial mass-matrix kernels.
void RegisterSpatialMassKernels(const NamedTree& robot) {
  using K = SpatialDynamics::MassMatrixKernel;
  auto d = std::make_shared<const SpatialDynamics>(robot.tree);
  for (const auto& [kernel, label] :
       {std::pair{K::kBodyFrame, "body_frame"}, std::pair{K::kWorldFrame, "world_frame"}}) {
    const std::string name = "mass/" + robot.name + "/" + label;
    benchmark::RegisterBenchmark(name.c_str(), [d, kernel](benchmark::State& bm) {
      TimeCall(bm, *d, [&d, kernel](DynamicsData& data, const State& s, MatrixXd& M, VectorXd&) {
        d->ComputeMassMatrix(data, kernel, s.q, M);
      });
    });
  }
}

// A random branching tree of 12 bodies, 30 % of its joints prismatic.
NamedTree MixedTree() {
  std::mt19937 rng{42};
  return {"mixed12", RandomRigidTree({.bodies = 12, .chain = false, .prismatic_fraction = 0.3}, rng)};
}

void RegisterAll() {
  for (const NamedPlant& p : FixedPlants()) RegisterPlant(p);
  for (int links : ChainSizes()) RegisterPlant(Chain(links));
  for (int links : ChainSizes()) RegisterMassKernels(Chain(links));
  for (const std::string& robot : ShippedRobotNames()) RegisterSpatialMassKernels(LoadShippedRobot(robot));
  RegisterSpatialMassKernels(MixedTree());
  for (int links : {12, 64}) RegisterSpatialMassKernels(RandomSpatialChain(links, 42, 0.3));
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::RegisterAll); }
