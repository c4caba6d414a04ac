// Frame kinematics (plant/kinematics.hpp) beside Orocos KDL (Debian
// liborocos-kdl-dev) on the shipped URDF robots (config/robots/panda.urdf,
// ur5.urdf), with the machine baseline (calib/sincos) in the same run. KDL's
// chain is kdl_bench's conversion (bench/kdl_chain.hpp) with the robot's
// named frames as segments, as kdl_parser would build it (panda_link8 and
// ur5's flange are fixed segments after the last joint).
//
//   term       KDL                                            lagrange (Kinematics)
//   poses      ChainFkSolverPos_recursive::JntToCart, the     ComputeFramePlacements
//              overload that fills every segment's pose in
//              one pass (Debian's KDL 1.5 has it)
//   pose       JntToCart, the end effector's segment          ComputeFramePlacement
//   jacobian   ChainJntToJacSolver::JntToJac, the end         ComputeFrameJacobian, world-aligned
//              effector's segment
//   jacobians  JntToJac once per frame (KDL has no pass       ComputeFrameJacobians, world-aligned
//              for all of them)
//   jdotqd     ChainJntToJacDotSolver::JntToJacDot in the     ComputeFrameBiasAcceleration, world-aligned
//              HYBRID representation (its default, set
//              anyway), the end effector's, into a Twist:
//              J̇ qd
//   all        (none)                                         ComputeFrameKinematics: every frame's pose,
//                                                             J and J̇ qd in both axes
//   jacobian_local          (none)                            ComputeFrameJacobian in the frame's own axes
//                                                             (LocalJacobianKernel::kFromTip, the default
//                                                             since issue 37)
//   jacobian_local_rotated  (none)                            the same by kRotated, the old kernel: world
//                                                             axes, each column rotated (the baseline)
//
// The end effector is panda_link8 (the flange) and ur5's flange.
// Conventions. KDL's JntToJac gives the Jacobian in the base's axes with the
// reference point at the segment's tip, rows (linear, angular): lagrange's
// world-aligned Jacobian at the frame's origin (FrameAxes::kWorldAligned).
// KDL's hybrid J̇ is d/dt of that Jacobian, so J̇ qd is the classical
// acceleration of the tip and the angular acceleration at qdd = 0: lagrange's
// world-aligned bias.
//
// Benchmark names: kin/<robot>/<library>/<term>, library kdl or lagrange.
// Each call cycles through 16 seeded random states (bench/bench_plants.hpp),
// converted to KDL's arrays before timing.
//
// Before timing, both libraries evaluate every term at 8 seeded random
// states of each robot and of a random 12-link chain with prismatic joints
// and named frames at random placements (on the world too), for every frame;
// the largest difference, absolute and relative to 1 + max |KDL's value|, goes
// to stderr (and to --agreement_csv=FILE). Above kAgreement relative the
// program exits 1 without timing.

#include <kdl/config.h>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacdotsolver.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jntarrayvel.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "bench/kdl_chain.hpp"
#include "bench/kdl_main.hpp"
#include "plant/kinematics.hpp"
#include "plant/random_tree.hpp"

namespace lagrange::bench {
namespace {

constexpr int kStates = 16;          // states cycled through while timing, as bench_plants.hpp TimeTerm does
constexpr int kCheckStates = 8;      // states the agreement check compares
constexpr double kAgreement = 1e-9;  // largest |lagrange − KDL| / (1 + max |KDL|) accepted

enum class KinematicsTerm : std::uint8_t {
  kPoses,
  kPose,
  kJacobian,
  kJacobians,
  kJdotQd,
  kAll,
  kJacobianLocal,
  kJacobianLocalRotated
};
constexpr KinematicsTerm kPeerTerms[] = {KinematicsTerm::kPoses, KinematicsTerm::kPose, KinematicsTerm::kJacobian,
                                         KinematicsTerm::kJacobians, KinematicsTerm::kJdotQd};

std::string_view TermName(KinematicsTerm term) {
  switch (term) {
    case KinematicsTerm::kPoses: return "poses";
    case KinematicsTerm::kPose: return "pose";
    case KinematicsTerm::kJacobian: return "jacobian";
    case KinematicsTerm::kJacobians: return "jacobians";
    case KinematicsTerm::kJdotQd: return "jdotqd";
    case KinematicsTerm::kAll: return "all";
    case KinematicsTerm::kJacobianLocal: return "jacobian_local";
    case KinematicsTerm::kJacobianLocalRotated: return "jacobian_local_rotated";
  }
  return "?";
}

// The frame each shipped robot's single-frame terms use.
std::string EndEffectorOf(const std::string& robot) {
  if (robot == "panda") return "panda_link8";
  if (robot == "ur5") return "flange";
  throw std::invalid_argument("kinematics_bench: no end effector named for " + robot);
}

Eigen::Matrix3d ToEigen(const KDL::Rotation& R) {
  Eigen::Matrix3d E;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) E(r, c) = R(r, c);
  }
  return E;
}
Eigen::Vector3d ToEigen(const KDL::Vector& v) { return {v.x(), v.y(), v.z()}; }
Vector6d ToEigen(const KDL::Twist& t) {
  Vector6d v;
  v << ToEigen(t.vel), ToEigen(t.rot);
  return v;
}

// KDL's solvers for one chain with frames, and their scratch. The solvers keep
// a reference to the chain, so a KdlKinematics never moves.
class KdlKinematics {
 public:
  explicit KdlKinematics(const RigidTree& tree)
      : chain_(ToKdlFrameChain(tree)),
        fk_(chain_.chain),
        jac_(chain_.chain),
        jac_dot_(chain_.chain),
        poses_(chain_.chain.getNrOfSegments()),
        jacobians_(tree.frames.size(), KDL::Jacobian(chain_.chain.getNrOfJoints())) {
    jac_dot_.setRepresentation(KDL::ChainJntToJacDotSolver::HYBRID);
    for (KDL::Jacobian& J : jacobians_) SetToZero(J);  // a frame on the base keeps its zero Jacobian
  }
  KdlKinematics(const KdlKinematics&) = delete;
  KdlKinematics& operator=(const KdlKinematics&) = delete;

  unsigned int num_joints() const { return chain_.chain.getNrOfJoints(); }
  int num_frames() const { return static_cast<int>(chain_.segment.size()); }
  // KDL's segment count up to frame k's tip: its segment + 1 (0 for the base).
  int SegmentsTo(int k) const { return chain_.segment[k] + 1; }

  // One call of `term` (not kAll); frame is the single-frame terms'. KDL's error code.
  int Evaluate(KinematicsTerm term, int frame, const KDL::JntArrayVel& s) {
    switch (term) {
      case KinematicsTerm::kPoses: return fk_.JntToCart(s.q, poses_);
      case KinematicsTerm::kPose: return fk_.JntToCart(s.q, pose_, SegmentsTo(frame));
      case KinematicsTerm::kJacobian: return jac_.JntToJac(s.q, jacobians_[frame], SegmentsTo(frame));
      case KinematicsTerm::kJacobians: {
        int rc = 0;
        for (int k = 0; k < num_frames(); ++k) {
          if (chain_.segment[k] >= 0) rc = std::min(rc, jac_.JntToJac(s.q, jacobians_[k], SegmentsTo(k)));
        }
        return rc;
      }
      case KinematicsTerm::kJdotQd: return jac_dot_.JntToJacDot(s, jdot_qd_, SegmentsTo(frame));
      default: throw std::logic_error("KDL has no " + std::string(TermName(term)));
    }
  }

  // Frame k's values after Evaluate: the pose from kPoses or kPose, J from kJacobian(s), J̇ qd from kJdotQd.
  Eigen::Matrix3d Rotation(KinematicsTerm term, int k) const { return ToEigen(Pose(term, k).M); }
  Eigen::Vector3d Position(KinematicsTerm term, int k) const { return ToEigen(Pose(term, k).p); }
  const KDL::Jacobian& Jacobian(int k) const { return jacobians_[k]; }
  Vector6d JdotQd() const { return ToEigen(jdot_qd_); }

 private:
  KDL::Frame Pose(KinematicsTerm term, int k) const {
    if (term == KinematicsTerm::kPose) return pose_;
    return chain_.segment[k] < 0 ? KDL::Frame::Identity() : poses_[chain_.segment[k]];
  }

  KdlFrameChain chain_;  // first: the solvers below refer to it
  KDL::ChainFkSolverPos_recursive fk_;
  KDL::ChainJntToJacSolver jac_;
  KDL::ChainJntToJacDotSolver jac_dot_;
  std::vector<KDL::Frame> poses_;  // (segments)
  KDL::Frame pose_;
  std::vector<KDL::Jacobian> jacobians_;  // (frames)
  KDL::Twist jdot_qd_;
};

// One call of `term` through lagrange's entry point.
void EvaluateLagrange(const Kinematics& model, KinematicsData& data, KinematicsTerm term, int frame, const State& s) {
  constexpr FrameAxes kWorld = FrameAxes::kWorldAligned;
  switch (term) {
    case KinematicsTerm::kPoses: model.ComputeFramePlacements(data, s.q); break;
    case KinematicsTerm::kPose: model.ComputeFramePlacement(data, s.q, frame); break;
    case KinematicsTerm::kJacobian: model.ComputeFrameJacobian(data, s.q, frame, kWorld); break;
    case KinematicsTerm::kJacobians: model.ComputeFrameJacobians(data, s.q, kWorld); break;
    case KinematicsTerm::kJdotQd: model.ComputeFrameBiasAcceleration(data, s.q, s.qd, frame, kWorld); break;
    case KinematicsTerm::kAll: model.ComputeFrameKinematics(data, s.q, s.qd); break;
    case KinematicsTerm::kJacobianLocal: model.ComputeFrameJacobian(data, s.q, frame, FrameAxes::kLocal); break;
    case KinematicsTerm::kJacobianLocalRotated:
      model.ComputeFrameJacobian(data, s.q, frame, Kinematics::LocalJacobianKernel::kRotated);
      break;
  }
}

std::vector<KDL::JntArrayVel> ToKdl(const std::vector<State>& states) {
  std::vector<KDL::JntArrayVel> out;
  for (const State& s : states) out.emplace_back(ToJntArray(s.q), ToJntArray(s.qd));
  return out;
}

// ---- agreement ---------------------------------------------------------------

// What a term yields for each frame it covers.
bool IsSingleFrame(KinematicsTerm t) {
  return t == KinematicsTerm::kPose || t == KinematicsTerm::kJacobian || t == KinematicsTerm::kJdotQd;
}
bool HasPose(KinematicsTerm t) {
  return t == KinematicsTerm::kPoses || t == KinematicsTerm::kPose || t == KinematicsTerm::kAll;
}
bool HasJacobian(KinematicsTerm t) {
  return t == KinematicsTerm::kJacobian || t == KinematicsTerm::kJacobians || t == KinematicsTerm::kAll;
}
bool HasBias(KinematicsTerm t) { return t == KinematicsTerm::kJdotQd || t == KinematicsTerm::kAll; }

constexpr KinematicsTerm kCheckedTerms[] = {KinematicsTerm::kPoses,    KinematicsTerm::kPose,
                                            KinematicsTerm::kJacobian, KinematicsTerm::kJacobians,
                                            KinematicsTerm::kJdotQd,   KinematicsTerm::kAll};
enum Quantity { kPoseQ, kJacobianQ, kBiasQ, kQuantities };
constexpr const char* kQuantityNames[] = {"pose", "J", "Jdot_qd"};

void Worsen(Difference& worst, const MatrixXd& ours, const MatrixXd& theirs) {
  const double gap = (ours - theirs).cwiseAbs().maxCoeff();
  worst.compared = true;
  worst.absolute = std::max(worst.absolute, gap);
  worst.relative = std::max(worst.relative, gap / (1.0 + theirs.cwiseAbs().maxCoeff()));
  if (!(gap == gap)) worst.relative = gap;  // a NaN never passes
}

// Every term of lagrange against the KDL calls timed for it, at kCheckStates
// states, for every frame (the single-frame terms called for each in turn).
std::vector<AgreementRow> CheckAgreement(const NamedTree& robot) {
  const Kinematics model(robot.tree);
  const std::unique_ptr<KinematicsData> data = model.MakeData();
  KdlKinematics kdl(robot.tree);
  if (static_cast<int>(kdl.num_joints()) != model.num_dofs()) throw std::logic_error("ToKdlFrameChain lost joints");
  std::mt19937 rng{7};
  const std::vector<State> states = RandomStates(robot.tree.joint_types(), kCheckStates, rng);
  const std::vector<KDL::JntArrayVel> kstates = ToKdl(states);
  const int frames = model.num_frames();
  constexpr FrameAxes kWorld = FrameAxes::kWorldAligned;
  Difference diff[std::size(kCheckedTerms)][kQuantities];
  for (int s = 0; s < kCheckStates; ++s) {
    const auto kdl_call = [&](KinematicsTerm term, int k) {
      const int rc = kdl.Evaluate(term, k, kstates[s]);
      if (rc != 0) throw std::runtime_error("KDL " + std::string(TermName(term)) + ": error " + std::to_string(rc));
    };
    for (std::size_t t = 0; t < std::size(kCheckedTerms); ++t) {
      const KinematicsTerm term = kCheckedTerms[t];
      const bool single = IsSingleFrame(term);
      for (int k = 0; k < (single ? frames : 1); ++k) {
        EvaluateLagrange(model, *data, term, k, states[s]);
        if (term == KinematicsTerm::kAll) {
          kdl_call(KinematicsTerm::kPoses, k);
          kdl_call(KinematicsTerm::kJacobians, k);
        } else {
          kdl_call(term, k);
        }
        for (int f = single ? k : 0; f < (single ? k + 1 : frames); ++f) {
          if (HasPose(term)) {
            const KinematicsTerm from = term == KinematicsTerm::kPose ? term : KinematicsTerm::kPoses;
            Worsen(diff[t][kPoseQ], data->rotation(f), kdl.Rotation(from, f));
            Worsen(diff[t][kPoseQ], data->position(f), kdl.Position(from, f));
          }
          if (HasJacobian(term)) Worsen(diff[t][kJacobianQ], data->jacobian(f, kWorld), kdl.Jacobian(f).data);
          if (HasBias(term)) {
            if (term == KinematicsTerm::kAll) kdl_call(KinematicsTerm::kJdotQd, f);
            Worsen(diff[t][kBiasQ], data->bias_acceleration(f, kWorld), kdl.JdotQd());
          }
        }
      }
    }
  }
  std::vector<AgreementRow> rows;
  for (std::size_t t = 0; t < std::size(kCheckedTerms); ++t) {
    for (int q = 0; q < kQuantities; ++q) {
      if (diff[t][q].compared) {
        rows.push_back({robot.name, std::string(TermName(kCheckedTerms[t])), kQuantityNames[q], diff[t][q]});
      }
    }
  }
  return rows;
}

// A random serial chain with prismatic joints (which the robots lack) and
// named frames: one at each body's origin, one at a random placement on each
// body, one at the world's origin and one away from it.
NamedTree RandomChainWithFrames() {
  NamedTree robot = RandomSpatialChain(12, 42, 0.3);
  robot.name += "-prismatic";
  std::mt19937 rng{43};
  std::uniform_real_distribution<double> offset(-0.3, 0.3);
  const auto random_frame = [&](std::string name, int body) {
    return TreeFrame{std::move(name), body, Eigen::Vector3d(offset(rng), offset(rng), offset(rng)),
                     RandomRotation(rng)};
  };
  robot.tree.frames.push_back({"world", -1, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()});
  robot.tree.frames.push_back(random_frame("stand", -1));
  for (int i = 0; i < robot.tree.num_dofs(); ++i) {
    robot.tree.frames.push_back({"body" + std::to_string(i), i, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()});
    robot.tree.frames.push_back(random_frame("tool" + std::to_string(i), i));
  }
  return robot;
}

// Prints the agreement table to stderr (and CSV to `csv_path` if not empty); false if any row is off.
bool Agree(const std::string& csv_path) {
  std::vector<AgreementRow> rows;
  std::vector<NamedTree> robots;
  for (const std::string& name : ShippedRobotNames()) robots.push_back(LoadShippedRobot(name));
  robots.push_back(RandomChainWithFrames());
  for (const NamedTree& robot : robots) {
    for (AgreementRow& row : CheckAgreement(robot)) rows.push_back(std::move(row));
  }
  return ReportAgreement("kinematics_bench",
                         "lagrange against KDL, " + std::to_string(kCheckStates) + " random states each, every frame",
                         "term", "quantity", rows, kAgreement, csv_path);
}

// ---- timing ------------------------------------------------------------------

void TimeKdl(benchmark::State& bm, const RigidTree& tree, KinematicsTerm term, int frame) {
  KdlKinematics kdl(tree);
  std::mt19937 rng{42};
  const std::vector<KDL::JntArrayVel> states = ToKdl(RandomStates(tree.joint_types(), kStates, rng));
  int k = 0;
  for (auto _ : bm) {
    int rc = kdl.Evaluate(term, frame, states[k]);
    benchmark::DoNotOptimize(rc);
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = kdl.num_joints();
}

// The same states as TimeKdl's.
void TimeLagrange(benchmark::State& bm, const RigidTree& tree, KinematicsTerm term, int frame) {
  const Kinematics model(tree);
  const std::unique_ptr<KinematicsData> data = model.MakeData();
  std::mt19937 rng{42};
  const std::vector<State> states = RandomStates(tree.joint_types(), kStates, rng);
  int k = 0;
  for (auto _ : bm) {
    EvaluateLagrange(model, *data, term, frame, states[k]);
    benchmark::DoNotOptimize(data.get());
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  bm.counters["dofs"] = model.num_dofs();
}

// kin/<robot>/<library>/<term>
std::string BenchmarkName(const std::string& robot, std::string_view library, KinematicsTerm term) {
  return PeerBenchmarkName("kin", robot, library, TermName(term));
}

void RegisterAll() {
  for (const std::string& robot : ShippedRobotNames()) {
    const RigidTree tree = LoadShippedRobot(robot).tree;
    const std::optional<int> ee = Kinematics(tree).FrameIndex(EndEffectorOf(robot));
    if (!ee) throw std::logic_error("kinematics_bench: " + robot + " has no frame " + EndEffectorOf(robot));
    const int frame = *ee;
    for (KinematicsTerm term : kPeerTerms) {
      benchmark::RegisterBenchmark(BenchmarkName(robot, "kdl", term).c_str(),
                                   [tree, term, frame](benchmark::State& bm) { TimeKdl(bm, tree, term, frame); });
      benchmark::RegisterBenchmark(BenchmarkName(robot, "lagrange", term).c_str(),
                                   [tree, term, frame](benchmark::State& bm) { TimeLagrange(bm, tree, term, frame); });
    }
    for (KinematicsTerm term :
         {KinematicsTerm::kAll, KinematicsTerm::kJacobianLocal, KinematicsTerm::kJacobianLocalRotated}) {
      benchmark::RegisterBenchmark(BenchmarkName(robot, "lagrange", term).c_str(),
                                   [tree, term, frame](benchmark::State& bm) { TimeLagrange(bm, tree, term, frame); });
    }
  }
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) {
  using namespace lagrange::bench;
  return RunAfterAgreement(argc, argv, "kinematics_bench", Agree, RegisterAll);
}
