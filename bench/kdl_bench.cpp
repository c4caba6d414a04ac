// Orocos KDL (Debian liborocos-kdl-dev) as a same-run peer for the 3-D robots:
// the shipped URDF robots (config/robots/panda.urdf, ur5.urdf) loaded by
// LoadUrdf, converted to a KDL::Chain, and the same dynamics timed by both
// libraries, with the machine baseline (calib/sincos) in the same run.
//
//   term  KDL                                  lagrange (SpatialDynamics, recursive)
//   M     ChainDynParam::JntToMass             ComputeMassMatrix
//   G     ChainDynParam::JntToGravity          ComputeGravityForce
//   Cqd   ChainDynParam::JntToCoriolis         ComputeCoriolisForce
//   ID    ChainIdSolver_RNE::CartToJnt         ComputeInverseDynamics (gravity and Coriolis on)
//   FD    ChainFdSolver_RNE::CartToJnt         ComputeForwardDynamics (gravity and Coriolis on)
//
// Benchmark names: kdl/<robot>/<library>/<term>, library kdl or lagrange.
// Each call cycles through 16 seeded random states (bench/bench_plants.hpp),
// converted to KDL's JntArray before timing.
//
// Before timing, both libraries evaluate every term on 8 seeded random states
// of each robot and of a random 12-link chain with prismatic joints (which the
// robots lack), and lagrange's two methods (recursive and Lagrangian) are each
// compared with KDL: the largest difference, absolute and relative to
// 1 + max |KDL's value|, goes to stderr (and to --agreement_csv=FILE). Above
// kAgreement relative the program exits 1 without timing: a conversion
// mistake on either side, or a wrong algorithm, shows there.

#include <kdl/config.h>
#include <kdl/chaindynparam.hpp>
#include <kdl/chainfdsolver_recursive_newton_euler.hpp>
#include <kdl/chainidsolver_recursive_newton_euler.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "bench/kdl_chain.hpp"
#include "bench/kdl_main.hpp"
#include "plant/lagrangian.hpp"
#include "plant/spatial_dynamics.hpp"

namespace lagrange::bench {
namespace {

constexpr int kStates = 16;          // states cycled through while timing, as bench_plants.hpp TimeTerm does
constexpr int kCheckStates = 8;      // states the agreement check compares
constexpr double kAgreement = 1e-9;  // largest |lagrange − KDL| / (1 + max |KDL|) accepted

// The terms both libraries have.
constexpr DynamicsTerm kPeerTerms[] = {DynamicsTerm::kM, DynamicsTerm::kG, DynamicsTerm::kCqd, DynamicsTerm::kID,
                                       DynamicsTerm::kFD};

// KDL's solvers for one chain, and their scratch. The solvers keep a
// reference to the chain, so a KdlPeer never moves.
class KdlPeer {
 public:
  explicit KdlPeer(const RigidTree& tree)
      : chain_(ToKdlChain(tree)),
        gravity_(ToKdl(tree.gravity)),
        dyn_(chain_, gravity_),
        id_(chain_, gravity_),
        fd_(chain_, gravity_),
        H_(chain_.getNrOfJoints()),
        f_ext_(chain_.getNrOfSegments(), KDL::Wrench::Zero()) {}
  KdlPeer(const KdlPeer&) = delete;
  KdlPeer& operator=(const KdlPeer&) = delete;

  unsigned int num_joints() const { return chain_.getNrOfJoints(); }

  // One call of `term`; a matrix lands in H (n x n), a vector in out (n). KDL's error code.
  int Evaluate(DynamicsTerm term, const KDL::JntArray& q, const KDL::JntArray& qd, const KDL::JntArray& qdd,
               const KDL::JntArray& tau, KDL::JntSpaceInertiaMatrix& H, KDL::JntArray& out) {
    switch (term) {
      case DynamicsTerm::kM: return dyn_.JntToMass(q, H);
      case DynamicsTerm::kG: return dyn_.JntToGravity(q, out);
      case DynamicsTerm::kCqd: return dyn_.JntToCoriolis(q, qd, out);
      case DynamicsTerm::kID: return id_.CartToJnt(q, qd, qdd, f_ext_, out);
      case DynamicsTerm::kFD: return fd_.CartToJnt(q, qd, tau, f_ext_, out);
      default: throw std::logic_error("KDL has no " + std::string(TermName(term)));
    }
  }
  KDL::JntSpaceInertiaMatrix& H() { return H_; }

 private:
  KDL::Chain chain_;  // first: the solvers below refer to it
  KDL::Vector gravity_;
  KDL::ChainDynParam dyn_;
  KDL::ChainIdSolver_RNE id_;
  KDL::ChainFdSolver_RNE fd_;
  KDL::JntSpaceInertiaMatrix H_;
  KDL::Wrenches f_ext_;  // no external wrenches
};

// A State as KDL's joint arrays.
struct KdlState {
  KDL::JntArray q, qd, qdd, tau;
};

std::vector<KdlState> ToKdl(const std::vector<State>& states) {
  std::vector<KdlState> out;
  for (const State& s : states)
    out.push_back({ToJntArray(s.q), ToJntArray(s.qd), ToJntArray(s.qdd), ToJntArray(s.tau)});
  return out;
}

// ---- agreement ---------------------------------------------------------------

Difference Compare(const MatrixXd& ours, const MatrixXd& theirs) {
  const double gap = (ours - theirs).cwiseAbs().maxCoeff();
  return {gap, gap / (1.0 + theirs.cwiseAbs().maxCoeff())};
}

// Every peer term of `tree` by lagrange's `method` against KDL, over kCheckStates states.
std::vector<AgreementRow> CheckAgreement(const NamedTree& robot, Method method) {
  std::unique_ptr<Dynamics> d;
  if (method == Method::kLagrangian) {
    d = std::make_unique<LagrangianDynamics<RigidTree>>(robot.tree);
  } else {
    d = std::make_unique<SpatialDynamics>(robot.tree);
  }
  KdlPeer kdl(robot.tree);
  std::mt19937 rng{7};
  const std::vector<State> states = RandomStates(robot.tree.joint_types(), kCheckStates, rng);
  const std::vector<KdlState> kstates = ToKdl(states);
  const int n = d->num_dofs();
  const std::unique_ptr<DynamicsData> data = d->MakeData();
  if (static_cast<int>(kdl.num_joints()) != n) throw std::logic_error("ToKdlChain lost joints");
  std::vector<AgreementRow> rows;
  for (DynamicsTerm term : kPeerTerms) {
    Difference worst;
    for (int k = 0; k < kCheckStates; ++k) {
      MatrixXd M(n, n);
      VectorXd v(n);
      EvaluateTerm(*d, *data, term, states[k], M, v);
      KDL::JntArray out(static_cast<unsigned int>(n));
      const KdlState& s = kstates[k];
      const int rc = kdl.Evaluate(term, s.q, s.qd, s.qdd, s.tau, kdl.H(), out);
      if (rc != 0) throw std::runtime_error("KDL " + std::string(TermName(term)) + ": error " + std::to_string(rc));
      const Difference diff = term == DynamicsTerm::kM ? Compare(M, kdl.H().data) : Compare(v, out.data);
      worst.absolute = std::max(worst.absolute, diff.absolute);
      worst.relative = std::max(worst.relative, diff.relative);
    }
    rows.push_back({robot.name, std::string(ToString(method)), std::string(TermName(term)), worst});
  }
  return rows;
}

// The robots both libraries are compared on: the shipped ones and a random
// chain with prismatic joints.
std::vector<NamedTree> CheckedRobots() {
  std::vector<NamedTree> robots;
  for (const std::string& name : ShippedRobotNames()) robots.push_back(LoadShippedRobot(name));
  NamedTree mixed = RandomSpatialChain(12, 42, 0.3);
  mixed.name += "-prismatic";
  robots.push_back(std::move(mixed));
  return robots;
}

// Prints the agreement table to stderr (and CSV to `csv_path` if not empty); false if any row is off.
bool Agree(const std::string& csv_path) {
  std::vector<AgreementRow> rows;
  for (const NamedTree& robot : CheckedRobots()) {
    for (Method method : {Method::kRecursive, Method::kLagrangian}) {
      for (AgreementRow& row : CheckAgreement(robot, method)) rows.push_back(std::move(row));
    }
  }
  return ReportAgreement("kdl_bench", "lagrange against KDL, " + std::to_string(kCheckStates) + " random states each",
                         "method", "term", rows, kAgreement, csv_path);
}

// ---- timing ------------------------------------------------------------------

void TimeKdl(benchmark::State& bm, const RigidTree& tree, DynamicsTerm term) {
  KdlPeer kdl(tree);
  std::mt19937 rng{42};
  const std::vector<KdlState> states = ToKdl(RandomStates(tree.joint_types(), kStates, rng));
  KDL::JntSpaceInertiaMatrix H(kdl.num_joints());
  KDL::JntArray out(kdl.num_joints());
  int k = 0;
  for (auto _ : bm) {
    const KdlState& s = states[k];
    int rc = kdl.Evaluate(term, s.q, s.qd, s.qdd, s.tau, H, out);
    benchmark::DoNotOptimize(rc);
    benchmark::DoNotOptimize(H.data.data());
    benchmark::DoNotOptimize(out.data.data());
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = kdl.num_joints();
}

// The same states as TimeKdl's (TimeTerm: 16 states from seed 42).
void TimeLagrange(benchmark::State& bm, const RigidTree& tree, DynamicsTerm term) {
  const SpatialDynamics d(tree);
  TimeTerm(bm, d, term);
}

// kdl/<robot>/<library>/<term>
std::string BenchmarkName(const std::string& robot, std::string_view library, DynamicsTerm term) {
  return PeerBenchmarkName("kdl", robot, library, TermName(term));
}

void RegisterAll() {
  for (const std::string& robot : ShippedRobotNames()) {
    const RigidTree tree = LoadShippedRobot(robot).tree;
    for (DynamicsTerm term : kPeerTerms) {
      benchmark::RegisterBenchmark(BenchmarkName(robot, "kdl", term).c_str(),
                                   [tree, term](benchmark::State& bm) { TimeKdl(bm, tree, term); });
      benchmark::RegisterBenchmark(BenchmarkName(robot, "lagrange", term).c_str(),
                                   [tree, term](benchmark::State& bm) { TimeLagrange(bm, tree, term); });
    }
  }
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) {
  using namespace lagrange::bench;
  return RunAfterAgreement(argc, argv, "kdl_bench", Agree, RegisterAll);
}
