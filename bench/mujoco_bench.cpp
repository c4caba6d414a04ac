// MuJoCo (Debian libmujoco-dev 2.2.2) as a same-run peer for the 3-D robots,
// as kdl_bench is with KDL: the shipped URDF robots (config/robots/panda.urdf,
// ur5.urdf) loaded by MuJoCo's own URDF import with lagrange's exact inertias
// (LoadMujocoPlant, plant/mujoco_plant.hpp), and the same dynamics timed by
// both libraries in one process, with the machine baseline (calib/sincos).
//
// MuJoCo's cheapest pipeline pieces for each term (no collision, constraint,
// passive force or sensor stage: what lagrange computes, nothing more):
//   term  MuJoCo                                                  lagrange (SpatialDynamics, recursive)
//   M     mj_kinematics, mj_comPos, mj_crb, mj_fullM (dense)      ComputeMassMatrix
//   G     mj_kinematics, mj_comPos, mj_comVel, mj_rne at qd = 0   ComputeGravityForce
//   ID    mj_kinematics, mj_comPos, mj_comVel, mj_rne (with qdd)  ComputeInverseDynamics (gravity and Coriolis on)
//   FD    mj_kinematics, mj_comPos, mj_crb, mj_factorM, mj_comVel,
//         mj_rne (bias), mj_solveM (tau − bias)                   ComputeForwardDynamics (gravity and Coriolis on)
//
// Benchmark names: mujoco/<robot>/<library>/<term>, library mujoco or lagrange.
// Each call cycles through 16 seeded random states (bench/bench_plants.hpp),
// the same for both.
//
// Before timing, both evaluate every term on 8 seeded random states of each
// robot; the largest difference, absolute and relative to 1 + max |MuJoCo's
// value|, goes to stderr (and to --agreement_csv=FILE). Above kAgreement
// relative the program exits 1 without timing.

#include <mujoco/mujoco.h>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "bench/kdl_chain.hpp"  // ReportAgreement, AgreementRow
#include "plant/mujoco_plant.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/urdf.hpp"

namespace lagrange::bench {
namespace {

constexpr int kStates = 16;           // states cycled through while timing, as TimeTerm does
constexpr int kCheckStates = 8;       // states the agreement check compares
constexpr double kAgreement = 1e-12;  // largest |lagrange − MuJoCo| / (1 + max |MuJoCo|) accepted

constexpr DynamicsTerm kPeerTerms[] = {DynamicsTerm::kFD, DynamicsTerm::kM, DynamicsTerm::kID, DynamicsTerm::kG};

// One robot in MuJoCo, its data made once.
class MujocoPeer {
 public:
  explicit MujocoPeer(const std::string& name)
      : robot_(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + name + ".urdf")),
        model_(Load(robot_)),
        m_(model_->mj_model()),
        d_(mj_makeData(m_)),
        n_(m_->nv),
        bias_(n_),
        rhs_(n_) {}
  ~MujocoPeer() { mj_deleteData(d_); }
  MujocoPeer(const MujocoPeer&) = delete;
  MujocoPeer& operator=(const MujocoPeer&) = delete;

  int num_dofs() const { return n_; }

  // One call of `term` at `s`: a matrix lands in M (n x n), a vector in out (n).
  void Evaluate(DynamicsTerm term, const State& s, MatrixXd& M, VectorXd& out) {
    mju_copy(d_->qpos, s.q.data(), n_);
    mj_kinematics(m_, d_);
    mj_comPos(m_, d_);
    switch (term) {
      case DynamicsTerm::kM:
        mj_crb(m_, d_);
        mj_fullM(m_, M.data(), d_->qM);  // symmetric: its row-major layout is column-major too
        return;
      case DynamicsTerm::kG:
        mju_zero(d_->qvel, n_);
        mj_comVel(m_, d_);
        mj_rne(m_, d_, 0, out.data());
        return;
      case DynamicsTerm::kID:
        mju_copy(d_->qvel, s.qd.data(), n_);
        mju_copy(d_->qacc, s.qdd.data(), n_);
        mj_comVel(m_, d_);
        mj_rne(m_, d_, 1, out.data());
        return;
      case DynamicsTerm::kFD:
        mj_crb(m_, d_);
        mj_factorM(m_, d_);
        mju_copy(d_->qvel, s.qd.data(), n_);
        mj_comVel(m_, d_);
        mj_rne(m_, d_, 0, bias_.data());
        rhs_ = s.tau - bias_;
        mj_solveM(m_, d_, out.data(), rhs_.data(), 1);
        return;
      default: throw std::logic_error("no MuJoCo peer for " + std::string(TermName(term)));
    }
  }
  const RigidTree& tree() const { return robot_.tree; }

 private:
  static std::shared_ptr<const MujocoPlantModel> Load(const UrdfRobot& robot) {
    MujocoOptions o;
    o.exact_inertia = &robot.tree;
    return LoadMujocoPlant(robot.file, o);
  }
  UrdfRobot robot_;
  std::shared_ptr<const MujocoPlantModel> model_;
  const mjModel* m_;
  mjData* d_;
  int n_;
  VectorXd bias_, rhs_;
};

Difference Compare(const MatrixXd& ours, const MatrixXd& theirs) {
  const double gap = (ours - theirs).cwiseAbs().maxCoeff();
  return {gap, gap / (1.0 + theirs.cwiseAbs().maxCoeff()), true};
}

bool Agree(const std::string& csv_path) {
  std::vector<AgreementRow> rows;
  for (const std::string& name : ShippedRobotNames()) {
    MujocoPeer peer(name);
    const SpatialDynamics d(peer.tree());
    const std::unique_ptr<DynamicsData> data = d.MakeData();
    std::mt19937 rng{7};
    const std::vector<State> states = RandomStates(peer.tree().joint_types(), kCheckStates, rng);
    const int n = d.num_dofs();
    for (DynamicsTerm term : kPeerTerms) {
      Difference worst;
      for (const State& s : states) {
        MatrixXd M(n, n), Mj(n, n);
        VectorXd v(n), vj(n);
        EvaluateTerm(d, *data, term, s, M, v);
        peer.Evaluate(term, s, Mj, vj);
        const Difference diff = term == DynamicsTerm::kM ? Compare(M, Mj) : Compare(v, vj);
        worst.absolute = std::max(worst.absolute, diff.absolute);
        worst.relative = std::max(worst.relative, diff.relative);
        worst.compared = true;
      }
      rows.push_back({name, "recursive", std::string(TermName(term)), worst});
    }
  }
  return ReportAgreement("mujoco_bench",
                         "lagrange against MuJoCo " + MujocoVersion() + ", " + std::to_string(kCheckStates) +
                             " random states each",
                         "method", "term", rows, kAgreement, csv_path);
}

void TimeMujoco(benchmark::State& bm, const std::string& robot, DynamicsTerm term) {
  MujocoPeer peer(robot);
  std::mt19937 rng{42};
  const std::vector<State> states = RandomStates(peer.tree().joint_types(), kStates, rng);
  const int n = peer.num_dofs();
  MatrixXd M(n, n);
  VectorXd v(n);
  int k = 0;
  for (auto _ : bm) {
    peer.Evaluate(term, states[k], M, v);
    benchmark::DoNotOptimize(M.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = n;
}

void RegisterAll() {
  for (const std::string& robot : ShippedRobotNames()) {
    const RigidTree tree = LoadShippedRobot(robot).tree;
    for (DynamicsTerm term : kPeerTerms) {
      benchmark::RegisterBenchmark(PeerBenchmarkName("mujoco", robot, "mujoco", TermName(term)).c_str(),
                                   [robot, term](benchmark::State& bm) { TimeMujoco(bm, robot, term); });
      benchmark::RegisterBenchmark(PeerBenchmarkName("mujoco", robot, "lagrange", TermName(term)).c_str(),
                                   [tree, term](benchmark::State& bm) {
                                     const SpatialDynamics d(tree);
                                     TimeTerm(bm, d, term);
                                   });
    }
  }
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) {
  using namespace lagrange::bench;
  const std::string csv = TakeFlag(argc, argv, "--agreement_csv=");
  try {
    if (!Agree(csv)) {
      std::fprintf(stderr, "mujoco_bench: lagrange and MuJoCo disagree; not timing\n");
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mujoco_bench: %s\n", e.what());
    return 1;
  }
  benchmark::AddCustomContext("mujoco_version", lagrange::MujocoVersion());
  return RunBenchmarks(argc, argv, RegisterAll);
}
