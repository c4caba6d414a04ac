#pragma once
// Frame kinematics of a RigidTree (plant/rigid_tree.hpp): for a state
// (q, qd), every named frame's pose, Jacobian and bias acceleration, in one
// forward pass, as Pinocchio's forwardKinematics + computeJointJacobians.
//
// For frame k with origin p_k (m, world) and axes R_k (3 x 3, its x, y, z in
// world coordinates), all in the world (root link) frame:
//
//   pose       R_k(q), p_k(q)
//   Jacobian   J_k(q) (6 x n): (ṗ_k, ω_k) = J_k qd, rows 0..2 the linear
//              velocity of the frame's origin (m/s), rows 3..5 its angular
//              velocity (rad/s); column j is joint j's unit motion (zero for a
//              joint that does not move the frame): revolute (z_j × (p_k − o_j), z_j),
//              prismatic (z_j, 0), z_j the joint's world axis through o_j;
//              a mimic joint's column is added, times its multiplier, to the
//              column of the joint it follows (J_joints S, plant/rigid_tree.hpp)
//   bias       J̇_k qd (6): the classical acceleration of the frame's origin
//              and its angular acceleration at qdd = 0, (p̈_k, ω̇_k) − J_k qdd
//
// Each in two axes (FrameAxes), as Pinocchio's reference frames:
//   kWorldAligned  the world's axes at the frame's origin (LOCAL_WORLD_ALIGNED)
//   kLocal         the frame's own axes: blockdiag(R_kᵀ, R_kᵀ) times the above
//                  (LOCAL); the bias is the same physical acceleration in the
//                  frame's axes (Pinocchio's classical acceleration in LOCAL),
//                  not d/dt(J_local) qd
//
// Cost: the pass over the joints is O(n); each frame's Jacobian fills the
// columns of the joints that carry it (O(depth)). Frames on the world have
// zero Jacobian and bias.
//
// Entry points. ComputeFrameKinematics computes everything above for every
// frame; the others compute one part, as Pinocchio's forwardKinematics +
// updateFramePlacements, computeFrameJacobian and
// getFrameClassicalAcceleration do, and are the ones to call in a tick when
// a part is all it needs:
//
//   entry point                    computes                                   over
//   ComputeFrameKinematics         every frame: R, p, J and J̇ qd, both axes   every joint
//   ComputeFramePlacements         every frame: R, p                          every joint
//   ComputeFramePlacement          frame k: R, p                              the joints that carry k
//   ComputeFrameJacobians          every frame: R, p, J in one axes           every joint
//   ComputeFrameJacobian           frame k: R, p, J in one axes               the joints that carry k
//   ComputeFrameBiasAcceleration   frame k: R, p, J̇ qd in one axes            the joints that carry k
//   ComputeFrameJacobianAndBias    frame k: R, p, J and J̇ qd in one axes      the joints that carry k
//
// (every one also takes the sines and cosines of all n joint angles, O(n)).
// Read from `data` (the accessors of KinematicsData) only what the last call
// computed: the rest holds values of earlier calls, or, for a frame at the
// origin of a body that call moved, of this one. A column of J for a joint
// that does not carry the frame is always zero.
//
// How. At load time each joint's frame is turned so that its axis is z (as
// plant/spatial_dynamics.hpp folds it), so a revolute joint's rotation is
// Rz(q): with a fixed rotation before it, that product comes first (it does
// not wait for the parent), and the parent's rotation times it is the one
// 3 x 3 product per joint; without one, two of the parent's columns mix
// (12 multiplications). Offsets along one axis cost 3 multiplications, zero
// ones none, and a frame at its body's origin with its axes (most URDF
// links) is read from the body, not copied. Sines and cosines of all joint
// angles come from one vectorised loop (plant/spatial_sincos.hpp).
//
// Cost (bench/kinematics_bench.cpp, the Panda: 7 joints, 9 frames), in
// multiples of one sin + cos of the C library measured in the same run:
// every frame's pose 9, one frame's pose 8, its Jacobian 11, every frame's
// Jacobian 24, one frame's J̇ qd 17, ComputeFrameKinematics 58; 0.06 to 0.25
// times Orocos KDL's calls for the same (README, "Spatial robots").
//
// Model and data apart, as plant/dynamics.hpp: a Kinematics is immutable
// and may be shared by threads; each user evaluates it through a
// KinematicsData it made (MakeData), which holds every result and buffer, so
// no entry point allocates and a controller may call them in the tick.
// Sizes and frame indices are checked by eigen_assert (on in debug and
// sanitizer builds).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "plant/rigid_tree.hpp"
#include "plant/types.hpp"

namespace lagrange {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

enum class FrameAxes : std::uint8_t {
  kWorldAligned,  // world axes at the frame's origin (Pinocchio's LOCAL_WORLD_ALIGNED)
  kLocal,         // the frame's own axes (Pinocchio's LOCAL)
};

class Kinematics;

// One user's results of Kinematics' entry points, every buffer sized by
// Kinematics::MakeData. Frame indices are the model's (FrameIndex).
class KinematicsData {
 public:
  KinematicsData(const KinematicsData&) = delete;
  KinematicsData& operator=(const KinematicsData&) = delete;

  const Kinematics& model() const { return *model_; }
  // R_k: the frame's axes in world coordinates (3 x 3).
  const Eigen::Matrix3d& rotation(int frame) const { return *frames_[frame].R_at; }
  // p_k: the frame's origin in the world frame, m.
  const Eigen::Vector3d& position(int frame) const { return *frames_[frame].p_at; }
  // J_k (6 x n): rows (linear m/s, angular rad/s) per unit joint velocity.
  const Matrix6Xd& jacobian(int frame, FrameAxes axes) const {
    return axes == FrameAxes::kLocal ? frames_[frame].J_local : frames_[frame].J_world;
  }
  // J̇_k qd (6): (linear m/s², angular rad/s²) at qdd = 0.
  const Vector6d& bias_acceleration(int frame, FrameAxes axes) const {
    return axes == FrameAxes::kLocal ? frames_[frame].bias_local : frames_[frame].bias_world;
  }

 private:
  friend class Kinematics;
  explicit KinematicsData(const Kinematics& model);

  // A body's state in world coordinates: its folded axes R (column 2 the
  // joint's world axis z), origin p, velocity (w, v of its origin) and bias
  // acceleration (dw, dv at qdd = 0).
  struct Body {
    Eigen::Matrix3d R;
    Eigen::Vector3d p, w, v, dw, dv;
  };
  // A frame's pose is read where it lives: its own R, p, or its body's when
  // it sits at the body's origin with its axes (most URDF links), which
  // then costs no copy.
  struct Frame {
    Eigen::Matrix3d R;
    Eigen::Vector3d p;
    const Eigen::Matrix3d* R_at = nullptr;  // &R or &bodies_[body].R
    const Eigen::Vector3d* p_at = nullptr;  // &p or &bodies_[body].p
    Matrix6Xd J_world, J_local;
    Vector6d bias_world, bias_local;
  };

  const Kinematics* model_;
  std::vector<double> qj_;       // (num_joints) each joint's position, with mimics (RigidTree); unused without
  std::vector<double> cq_, sq_;  // (num_joints) cos, sin of each joint's position
  std::vector<Body> bodies_;     // (num_joints)
  std::vector<Frame> frames_;    // (num_frames)
};

class Kinematics {
 public:
  // The tree's joints and frames. Throws std::invalid_argument when the
  // tree is not valid (ValidateRigidTree).
  explicit Kinematics(const RigidTree& tree);

  // The tree's degrees of freedom, q's size (a mimic joint follows its joint).
  int num_dofs() const { return num_dofs_; }
  int num_frames() const { return static_cast<int>(frames_.size()); }
  // The frames' names, by index (the tree's order).
  const std::vector<std::string>& frame_names() const { return names_; }
  // The index of the frame called `name`, or nullopt (a search by name: look
  // frames up once, before the loop, and pass indices to the tick).
  std::optional<int> FrameIndex(std::string_view name) const;

  // A data object for one user, every buffer sized.
  std::unique_ptr<KinematicsData> MakeData() const;

  // (q, qd) (n, n) => every frame's R, p, J and J̇ qd, in both axes, into `data`.
  void ComputeFrameKinematics(KinematicsData& data, ConstVecRef q, ConstVecRef qd) const;

  // In the entry points below `frame` is an index of FrameIndex (0 ≤ frame <
  // num_frames()), q (n) in rad or m, qd (n) in rad/s or m/s; R (3 x 3) and
  // p (m) are read with rotation(k) and position(k), J (6 x n; per unit
  // joint velocity: m/s then rad/s) with jacobian(k, axes), J̇ qd (6; m/s²
  // then rad/s²) with bias_acceleration(k, axes). None allocates.

  // q => R_k(q), p_k(q) of every frame (forward kinematics; Pinocchio's
  // forwardKinematics + updateFramePlacements). O(n + frames).
  void ComputeFramePlacements(KinematicsData& data, ConstVecRef q) const;
  // q => R_k(q), p_k(q) of one frame, over the joints that carry it only
  // (KDL's ChainFkSolverPos::JntToCart). O(depth).
  void ComputeFramePlacement(KinematicsData& data, ConstVecRef q, int frame) const;
  // q => R_k, p_k and J_k(q) in `axes` of every frame: column j of J_k is
  // (z_j × (p_k − o_j), z_j) for a revolute joint, (z_j, 0) for a prismatic
  // one, in world axes (times blockdiag(R_kᵀ, R_kᵀ) for kLocal); zero for a
  // joint that does not carry the frame. O(n + Σ depth).
  void ComputeFrameJacobians(KinematicsData& data, ConstVecRef q, FrameAxes axes) const;
  // q => R_k, p_k and J_k(q) in `axes` of one frame, as above (KDL's
  // ChainJntToJacSolver::JntToJac; Pinocchio's computeFrameJacobian). O(depth).
  // In the frame's own axes (kLocal) by LocalJacobianKernel::kFromTip.
  void ComputeFrameJacobian(KinematicsData& data, ConstVecRef q, int frame, FrameAxes axes) const;
  // One frame's Jacobian in its own axes, by either exact kernel:
  //   kRotated  the joints placed root first in world axes, each column
  //             formed in world axes, then rotated by R_kᵀ (9 + 9 + 6
  //             multiplications a revolute column)
  //   kFromTip  the frame placed in each body's axes from the tip to the root
  //             (T_j = R_jᵀ R_k, t_j = R_jᵀ (p_k − o_j), one joint's rotation
  //             at a time, as Pinocchio's computeFrameJacobian in LOCAL), each
  //             column formed in the frame's axes from them: (T_jᵀ (e_z × t_j),
  //             T_jᵀ e_z), 6 multiplications; the root's step gives R_k, p_k
  //             (the default)
  // Both write the same outputs as ComputeFrameJacobian (R_k, p_k, J_k);
  // kRotated stays for the tests and bench/kinematics_bench.cpp's baseline.
  enum class LocalJacobianKernel : std::uint8_t { kRotated, kFromTip };
  void ComputeFrameJacobian(KinematicsData& data, ConstVecRef q, int frame, LocalJacobianKernel kernel) const;
  // (q, qd) => R_k, p_k and J̇_k qd in `axes` of one frame: the classical
  // acceleration of its origin and its angular acceleration at qdd = 0,
  // (p̈_k, ω̇_k) − J_k qdd (KDL's ChainJntToJacDotSolver in its hybrid
  // representation, then times qd; Pinocchio's getFrameClassicalAcceleration
  // at zero acceleration). O(depth).
  void ComputeFrameBiasAcceleration(KinematicsData& data, ConstVecRef q, ConstVecRef qd, int frame,
                                    FrameAxes axes) const;
  // (q, qd) => R_k, p_k, J_k and J̇_k qd in `axes` of one frame, in one pass:
  // what a task-space law needs of its frame each tick. O(depth).
  void ComputeFrameJacobianAndBias(KinematicsData& data, ConstVecRef q, ConstVecRef qd, int frame,
                                   FrameAxes axes) const;

 private:
  friend class KinematicsData;  // places the frames on the world once

  // A constant offset r as R r, in the form that costs least: zero, along
  // one coordinate axis (3 multiplications; most URDF origins), or any (9).
  // Exact: the skipped terms are exact zeros, so R r has the full product's bits.
  struct Offset {
    enum class Kind : std::uint8_t { kZero, kAlongAxis, kGeneral };
    Kind kind = Kind::kZero;
    int axis = 0;  // kAlongAxis: r = length e_axis
    double length = 0.0;
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
  };
  // Joint i folded (its frame turned so that its axis is z): its frame's axes
  // E and origin r in the folded parent body frame; body i's folded axes are
  // R_λ E Rz(q) (revolute) or R_λ E (prismatic, origin moved by q along z).
  struct Joint {
    int parent = -1;
    RigidTree::JointMap map;  // q_joint = scale q[dof] + offset: 1 and 0 but for a mimic
    bool revolute = true;
    bool identity = false;  // E is exactly the identity (most URDF joints): R_λ E is R_λ
    Eigen::Matrix3d E;
    Offset r;
  };
  // A frame on body `body` (−1: the world), placed in the folded body frame.
  struct Frame {
    int body = -1;
    bool identity = false;  // R is exactly the identity
    bool at_body = false;   // and p is zero: the frame's pose is its body's
    Eigen::Matrix3d R;
    Offset p;
  };
  static Offset OffsetOf(const Eigen::Vector3d& r);

  // q => each joint's position (q itself, or q_j = S q + o with mimics) and its cos, sin into `data`.
  const double* JointSines(KinematicsData& data, ConstVecRef q) const;
  // q => cos q, sin q and the folded pose of each joint in `joints` (root first, parents before children).
  void PlaceBodies(KinematicsData& data, ConstVecRef q, std::span<const int> joints) const;
  // qd and the bodies' poses => each body's velocity and bias acceleration in `joints`, world axes.
  void MoveBodies(KinematicsData& data, ConstVecRef qd, std::span<const int> joints) const;
  // The bodies' poses => frame k's R, p.
  void PlaceFrame(KinematicsData& data, int k) const;
  // Frame k's pose and the bodies' poses => J_k in `axes`.
  void FillJacobian(KinematicsData& data, int k, FrameAxes axes) const;
  // q => frame k's R, p and J_k in its own axes, tip to root (LocalJacobianKernel::kFromTip).
  void PlaceFrameAndLocalJacobianFromTip(KinematicsData& data, ConstVecRef q, int k) const;
  // Frame k's pose and the bodies' motion => J̇_k qd in `axes`.
  void FillBias(KinematicsData& data, int k, FrameAxes axes) const;

  int num_dofs_ = 0;
  bool mimics_ = false;                    // some joint mimics another: q is mapped to the joints
  std::vector<Joint> joints_;              // every joint, mimics too
  std::vector<Frame> frames_;
  std::vector<std::string> names_;
  std::vector<int> all_joints_;            // 0 … num_joints − 1
  std::vector<std::vector<int>> support_;  // per frame: the joints that move it, root first (joint indices)
};

}  // namespace lagrange
