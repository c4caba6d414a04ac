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
//
// Floating base: the quadruped (config/robots/a1.urdf read floating by
// lagrange, FloatingDynamics; its MJCF twin a1.xml with a free joint in
// MuJoCo, lagrange's exact inertias), names mujoco/a1/<library>/<term>.
// MuJoCo is timed in its own coordinates (qpos, qvel, qacc, qfrc of each state
// converted once, before timing); the agreement check turns its results into
// lagrange's (plant/mujoco_free_joint.hpp: M = Sᵀ M_MuJoCo S, ...):
//   FD    as above                                                ComputeForwardDynamics
//   ID    as above                                                ComputeInverseDynamics
//   M     as above                                                ComputeMassMatrix
//   A_G   as M, then the free joint's six rows of M carried to the centre of
//         mass (MuJoCo 2.2.2 has no centroidal matrix; M's linear rows are
//         the linear momentum's, its angular rows the angular momentum about
//         the base origin in base axes): R rows 3..5 − [c − p]× rows 0..2   ComputeCentroidalMomentumMatrix

#include <mujoco/mujoco.h>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "bench/kdl_chain.hpp"  // ReportAgreement, AgreementRow
#include "plant/floating_dynamics.hpp"
#include "plant/mujoco_free_joint.hpp"
#include "plant/mujoco_plant.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/urdf.hpp"

namespace lagrange::bench {
namespace {

constexpr int kStates = 16;           // states cycled through while timing, as TimeTerm does
constexpr int kCheckStates = 8;       // states the agreement check compares
constexpr double kAgreement = 1e-12;  // largest |lagrange − MuJoCo| / (1 + max |MuJoCo|) accepted

constexpr DynamicsTerm kPeerTerms[] = {DynamicsTerm::kFD, DynamicsTerm::kM, DynamicsTerm::kID, DynamicsTerm::kG};

// MuJoCo's state of one call, in its own coordinates (nq, then nv each).
struct MujocoState {
  const double *qpos, *qvel, *qacc, *qfrc;
};

// One call of MuJoCo's pieces for `term` (the table above) at `s`: a matrix
// lands in M (nv x nv), a vector in out (nv); bias and rhs are scratch (nv).
void EvaluateMujoco(const mjModel* m, mjData* d, DynamicsTerm term, const MujocoState& s, MatrixXd& M, VectorXd& out,
                    VectorXd& bias, VectorXd& rhs) {
  const int nv = m->nv;
  mju_copy(d->qpos, s.qpos, m->nq);
  mj_kinematics(m, d);
  mj_comPos(m, d);
  switch (term) {
    case DynamicsTerm::kM:
      mj_crb(m, d);
      mj_fullM(m, M.data(), d->qM);  // symmetric: its row-major layout is column-major too
      return;
    case DynamicsTerm::kG:
      mju_zero(d->qvel, nv);
      mj_comVel(m, d);
      mj_rne(m, d, 0, out.data());
      return;
    case DynamicsTerm::kID:
      mju_copy(d->qvel, s.qvel, nv);
      mju_copy(d->qacc, s.qacc, nv);
      mj_comVel(m, d);
      mj_rne(m, d, 1, out.data());
      return;
    case DynamicsTerm::kFD:
      mj_crb(m, d);
      mj_factorM(m, d);
      mju_copy(d->qvel, s.qvel, nv);
      mj_comVel(m, d);
      mj_rne(m, d, 0, bias.data());
      rhs = Eigen::Map<const VectorXd>(s.qfrc, nv) - bias;
      mj_solveM(m, d, out.data(), rhs.data(), 1);
      return;
    default: throw std::logic_error("no MuJoCo peer for " + std::string(TermName(term)));
  }
}

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
    EvaluateMujoco(m_, d_, term, {s.q.data(), s.qd.data(), s.qdd.data(), s.tau.data()}, M, out, bias_, rhs_);
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

void AgreeFloating(std::vector<AgreementRow>& rows);  // the quadruped's rows (below)

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
  AgreeFloating(rows);
  return ReportAgreement("mujoco_bench",
                         "lagrange against MuJoCo " + MujocoVersion() + ", " + std::to_string(kCheckStates) +
                             " random states each",
                         "method", "term", rows, kAgreement, csv_path);
}

// ---- The floating quadruped ----

enum class FloatingTerm : std::uint8_t { kFD, kID, kM, kAG };
constexpr FloatingTerm kFloatingTerms[] = {FloatingTerm::kFD, FloatingTerm::kID, FloatingTerm::kM, FloatingTerm::kAG};
const char* FloatingTermName(FloatingTerm t) {
  switch (t) {
    case FloatingTerm::kFD: return "FD";
    case FloatingTerm::kID: return "ID";
    case FloatingTerm::kM: return "M";
    case FloatingTerm::kAG: return "A_G";
  }
  return "?";
}

// One state in both coordinates: lagrange's (q nq; v, a, tau nv) and MuJoCo's (qpos, qvel, qacc, qfrc).
struct FloatingState {
  VectorXd q, v, a, tau;
  VectorXd qpos, qvel, qacc, qfrc;
};

// The A1 in both libraries, MuJoCo's data made once.
class FloatingPeer {
 public:
  FloatingPeer()
      : robot_(LoadUrdf(Robot("a1.urdf"), UrdfOptions{.floating_base = true})),
        model_(Load(robot_)),
        dynamics_(robot_.tree),
        data_(dynamics_.MakeData()),
        m_(model_->mj_model()),
        d_(mj_makeData(m_)),
        nv_(m_->nv),
        bias_(nv_),
        rhs_(nv_),
        M_(nv_, nv_) {
    while (m_->jnt_type[base_] != mjJNT_FREE) ++base_;
    for (const TreeJoint& j : robot_.tree.joints) joint_.push_back(mj_name2id(m_, mjOBJ_JOINT, j.name.c_str()));
  }
  ~FloatingPeer() { mj_deleteData(d_); }
  FloatingPeer(const FloatingPeer&) = delete;
  FloatingPeer& operator=(const FloatingPeer&) = delete;

  int nv() const { return nv_; }
  FloatingDynamics& dynamics() { return dynamics_; }
  FloatingData& data() { return *data_; }

  // Seeded states: the base anywhere 10 m up (no contact), turned any way; joints inside their ranges.
  std::vector<FloatingState> States(int count, std::mt19937& rng) const {
    std::uniform_real_distribution<double> u(0.05, 0.95), w(-1.5, 1.5);
    std::normal_distribution<double> n(0.0, 1.0);
    const int nj = dynamics_.num_joints(), nq = dynamics_.num_q(), nv = dynamics_.num_v();
    std::vector<FloatingState> states;
    for (int k = 0; k < count; ++k) {
      FloatingState s{VectorXd(nq), VectorXd(nv), VectorXd(nv), VectorXd(nv),
                      VectorXd(m_->nq), VectorXd(nv_), VectorXd(nv_), VectorXd(nv_)};
      const Eigen::Vector4d quat = Eigen::Vector4d(n(rng), n(rng), n(rng), n(rng)).normalized();
      s.q.head<7>() << w(rng), w(rng), 10.0 + w(rng), quat;
      for (int i = 0; i < nj; ++i) {
        const int j = joint_[static_cast<std::size_t>(i)];
        s.q[7 + i] = m_->jnt_range[2 * j] + u(rng) * (m_->jnt_range[2 * j + 1] - m_->jnt_range[2 * j]);
      }
      for (int i = 0; i < nv; ++i) s.v[i] = w(rng), s.a[i] = w(rng), s.tau[i] = 10.0 * w(rng);
      const int bq = m_->jnt_qposadr[base_], bv = m_->jnt_dofadr[base_];
      FreeJointToMujoco(s.q.data(), s.v.data(), s.qpos.data() + bq, s.qvel.data() + bv);
      FreeJointAccelerationToMujoco(s.q.data(), s.v.data(), s.a.data(), s.qacc.data() + bv);
      FreeJointForceToMujoco(s.q.data(), s.tau.data(), s.qfrc.data() + bv);
      for (int i = 0; i < nj; ++i) {
        const int j = joint_[static_cast<std::size_t>(i)];
        s.qpos[m_->jnt_qposadr[j]] = s.q[7 + i];
        s.qvel[m_->jnt_dofadr[j]] = s.v[6 + i];
        s.qacc[m_->jnt_dofadr[j]] = s.a[6 + i];
        s.qfrc[m_->jnt_dofadr[j]] = s.tau[6 + i];
      }
      states.push_back(std::move(s));
    }
    return states;
  }

  // MuJoCo's `term` at `s`, in its coordinates: a matrix in M (nv x nv, or 6 x nv for A_G), a vector in out (nv).
  void Evaluate(FloatingTerm term, const FloatingState& s, MatrixXd& M, VectorXd& out) {
    const MujocoState state{s.qpos.data(), s.qvel.data(), s.qacc.data(), s.qfrc.data()};
    switch (term) {
      case FloatingTerm::kFD: EvaluateMujoco(m_, d_, DynamicsTerm::kFD, state, M, out, bias_, rhs_); return;
      case FloatingTerm::kID: EvaluateMujoco(m_, d_, DynamicsTerm::kID, state, M, out, bias_, rhs_); return;
      case FloatingTerm::kM: EvaluateMujoco(m_, d_, DynamicsTerm::kM, state, M, out, bias_, rhs_); return;
      case FloatingTerm::kAG: {
        EvaluateMujoco(m_, d_, DynamicsTerm::kM, state, M_, out, bias_, rhs_);
        const int bv = m_->jnt_dofadr[base_], body = m_->jnt_bodyid[base_];
        const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> R(d_->xmat + 9 * body);
        const Eigen::Vector3d r = Eigen::Map<const Eigen::Vector3d>(d_->subtree_com + 3 * body) -
                                  Eigen::Map<const Eigen::Vector3d>(d_->xpos + 3 * body);
        Eigen::Matrix3d rx;
        rx << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
        M.topRows<3>() = M_.middleRows<3>(bv);
        M.bottomRows<3>() = R * M_.middleRows<3>(bv + 3) - rx * M_.middleRows<3>(bv);
        return;
      }
    }
  }

  // lagrange's `term` at `s` (M nv x nv or A_G 6 x nv; out nv).
  void EvaluateLagrange(FloatingTerm term, const FloatingState& s, MatrixXd& M, VectorXd& out) {
    switch (term) {
      case FloatingTerm::kM: dynamics_.ComputeMassMatrix(*data_, s.q, M); return;
      case FloatingTerm::kAG: dynamics_.ComputeCentroidalMomentumMatrix(*data_, s.q, M); return;
      case FloatingTerm::kID: dynamics_.ComputeInverseDynamics(*data_, s.q, s.v, s.a, DynamicsTerms{}, out); return;
      case FloatingTerm::kFD: dynamics_.ComputeForwardDynamics(*data_, s.q, s.v, s.tau, DynamicsTerms{}, out); return;
    }
  }

  // MuJoCo's result (Evaluate's) in lagrange's coordinates: S (qvel = S v) at s.
  void ToLagrange(FloatingTerm term, const FloatingState& s, MatrixXd& M, VectorXd& out) const {
    const int nv = dynamics_.num_v(), bv = m_->jnt_dofadr[base_];
    MatrixXd S = MatrixXd::Zero(nv_, nv);
    S.block<3, 3>(bv, 0) = FreeJointRotation(s.q.data());
    S.block<3, 3>(bv + 3, 3).setIdentity();
    for (int i = 0; i < dynamics_.num_joints(); ++i) S(m_->jnt_dofadr[joint_[static_cast<std::size_t>(i)]], 6 + i) = 1.0;
    switch (term) {
      case FloatingTerm::kM: M = (S.transpose() * M * S).eval(); return;
      case FloatingTerm::kAG: M = (M * S).eval(); return;
      case FloatingTerm::kID: out = (S.transpose() * out).eval(); return;  // qacc was S a + Ṡ v: the same motion
      case FloatingTerm::kFD: {
        VectorXd a(nv);
        FreeJointAccelerationFromMujoco(s.q.data(), s.v.data(), out.data() + bv, a.data());
        for (int i = 0; i < dynamics_.num_joints(); ++i) a[6 + i] = out[m_->jnt_dofadr[joint_[static_cast<std::size_t>(i)]]];
        out = a;
        return;
      }
    }
  }

 private:
  static std::string Robot(const std::string& file) { return std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + file; }
  static std::shared_ptr<const MujocoPlantModel> Load(const UrdfRobot& robot) {
    MujocoOptions o;
    o.floating_base = true;
    o.exact_inertia = &robot.tree;
    o.joint_order = robot.tree.joint_names();
    return LoadMujocoPlant(Robot("a1.xml"), o);
  }
  UrdfRobot robot_;
  std::shared_ptr<const MujocoPlantModel> model_;
  FloatingDynamics dynamics_;
  std::unique_ptr<FloatingData> data_;
  const mjModel* m_;
  mjData* d_;
  int nv_;
  int base_ = 0;            // MuJoCo's free joint
  std::vector<int> joint_;  // MuJoCo's joint id of each of lagrange's joints
  VectorXd bias_, rhs_;
  MatrixXd M_;  // A_G's scratch: M
};

MatrixXd FloatingMatrix(FloatingTerm term, int nv) { return MatrixXd::Zero(term == FloatingTerm::kAG ? 6 : nv, nv); }

void AgreeFloating(std::vector<AgreementRow>& rows) {
  FloatingPeer peer;
  std::mt19937 rng{7};
  const std::vector<FloatingState> states = peer.States(kCheckStates, rng);
  const int nv = peer.nv();
  for (FloatingTerm term : kFloatingTerms) {
    Difference worst;
    for (const FloatingState& s : states) {
      MatrixXd M = FloatingMatrix(term, nv), Mj = FloatingMatrix(term, nv);
      VectorXd v(nv), vj(nv);
      peer.EvaluateLagrange(term, s, M, v);
      peer.Evaluate(term, s, Mj, vj);
      peer.ToLagrange(term, s, Mj, vj);
      const bool matrix = term == FloatingTerm::kM || term == FloatingTerm::kAG;
      const Difference diff = matrix ? Compare(M, Mj) : Compare(v, vj);
      worst.absolute = std::max(worst.absolute, diff.absolute);
      worst.relative = std::max(worst.relative, diff.relative);
      worst.compared = true;
    }
    rows.push_back({"a1", "floating", FloatingTermName(term), worst});
  }
}

void TimeFloating(benchmark::State& bm, FloatingTerm term, bool mujoco) {
  FloatingPeer peer;
  std::mt19937 rng{42};
  const std::vector<FloatingState> states = peer.States(kStates, rng);
  const int nv = peer.nv();
  MatrixXd M = FloatingMatrix(term, nv);
  VectorXd v(nv);
  int k = 0;
  for (auto _ : bm) {
    if (mujoco) {
      peer.Evaluate(term, states[k], M, v);
    } else {
      peer.EvaluateLagrange(term, states[k], M, v);
    }
    benchmark::DoNotOptimize(M.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = nv;
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
  for (FloatingTerm term : kFloatingTerms) {
    for (const bool mujoco : {true, false}) {
      benchmark::RegisterBenchmark(
          PeerBenchmarkName("mujoco", "a1", mujoco ? "mujoco" : "lagrange", FloatingTermName(term)).c_str(),
          [term, mujoco](benchmark::State& bm) { TimeFloating(bm, term, mujoco); });
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
