#pragma once
// A kinematic tree of rigid bodies in 3-D, fixed or floating base: the one
// description of every plant's bodies and joints. A URDF plant's is read from its file
// (plant/urdf.hpp); the built-in plants' (pendulum, arm2, cartpole, chain)
// are planar trees in the world's xy plane, every joint axis along z,
// gravity along −y (ToRigidTree in their headers, PlanarTreeJoint and
// PlanarTreeBody below). It is evaluated by the recursive spatial algorithms
// (plant/spatial_dynamics.hpp), by the planar ones for a planar chain
// (plant/recursive_dynamics.hpp, PlanarChainOf) and, through the templated
// energies below, by the Lagrangian path (plant/lagrangian.hpp).
//
// Frames. The world is the root link's frame. Joint i's frame is placed in
// its parent body's frame (the world for a root joint) by a fixed transform:
//   p_parent = position + rotation · p_joint       (URDF <origin xyz rpy>)
// Body i's frame is joint i's frame after the joint's motion: a revolute joint
// rotates it by q_i about `axis`, a prismatic joint translates it by q_i·axis.
// Gravity is the vector `gravity` in the world frame (URDF/ROS: (0, 0, −9.81)).
// Named frames (`frames`, TreeFrame) ride on a body (or the world) at a fixed
// placement in its frame: every URDF link, including those merged into a body
// by fixed joints, and the built-in plants' links and tips
// (plant/kinematics.hpp evaluates them). They carry no inertia.
//
// Floating base (floating_base true; Pinocchio's free-flyer root joint): the
// tree's root is the body `base`, free in the world, and joints with parent −1
// hang from it (frames with body −1 ride on it). Its configuration and velocity
// lead q and v, in Pinocchio's conventions:
//   q = (p, x, y, z, w, q_joints)   p (m) the base frame's origin in the world,
//                                   (x, y, z, w) the unit quaternion of its axes
//                                   in the world                  nq = num_q() = n + 7 (n = num_dofs())
//   v = (v_b, ω_b, qd_joints)       the velocity of the base origin (m/s) and the
//                                   base's angular velocity (rad/s), both in base
//                                   axes                            nv = num_v() = n + 6
// so q̇ ≠ v: the base advances on the manifold (plant/free_flyer.hpp). The
// generalized force on the base is its wrench in base axes (force N, then
// moment N·m about the base origin). A floating tree runs under FloatingDynamics
// (plant/floating_dynamics.hpp) and is checked by ValidateFloatingTree; every
// fixed-base algorithm refuses it (ValidateRigidTree).
//
// Energies (SI units), with p_c, v_c the world position and velocity of body
// i's centre of mass, ω its angular velocity and I its inertia about the centre
// of mass, all in world axes:
//   T(q, qd) = Σ ½ (m ‖v_c‖² + ωᵀ I ω)
//   V(q)     = −Σ m gravityᵀ p_c           (zero with every centre of mass at the world origin)

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "plant/types.hpp"

namespace lagrange {

struct RigidBody {
  double mass = 0.0;                                  // kg, >= 0
  Eigen::Vector3d com = Eigen::Vector3d::Zero();      // centre of mass in the body frame, m
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  // about the centre of mass, body axes, kg·m²
};

struct TreeJoint {
  std::string name;
  JointType type = JointType::kRevolute;
  int parent = -1;                                     // index of the joint carrying the parent body; −1: the world
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // joint frame origin in the parent body frame, m
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // joint frame axes in the parent body frame
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();         // unit motion axis in the joint frame
  // A mimic joint (URDF <mimic>) is no degree of freedom: it follows joint
  // `mimic` (an index into RigidTree::joints, itself a degree of freedom) as
  //   q = multiplier · q_mimic + offset,  qd = multiplier · qd_mimic.
  // −1: the joint is a degree of freedom.
  int mimic = -1;
  double multiplier = 1.0;  // (this joint's unit) per (the followed joint's unit)
  double offset = 0.0;      // rad or m
};

// A named frame fixed to body `body` (−1: the world):
//   p_body = position + rotation · p_frame
struct TreeFrame {
  std::string name;
  int body = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      // frame origin in the body frame, m
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // frame axes in the body frame
};

// Joints and degrees of freedom. Every joint carries a body; the degrees of
// freedom are the joints that mimic none, numbered in joint order. The
// generalized coordinates q (n = num_dofs()) are theirs: a mimic joint's
// position is the affine function above of its followed joint's, so
//   q_joints = S q + o,  qd_joints = S qd
// with the constant selection S (num_joints x n: column d holds 1 at d's own
// joint and each mimic's multiplier at the mimics of it) and o the offsets.
// Everything over q (M = Sᵀ M_joints S, C, G, the Jacobians J_joints S, the
// messages, the scenes, the controllers) sees only the degrees of freedom; a
// mimic's generalized force lands on the joint it follows.
inline constexpr int kFreeFlyerNq = 7;  // p (3), quaternion (4)
inline constexpr int kFreeFlyerNv = 6;  // v_b (3), ω_b (3)

struct RigidTree {
  std::vector<TreeJoint> joints;  // joint i carries body i; parents come first: joints[i].parent < i
  std::vector<RigidBody> bodies;  // one per joint
  std::vector<TreeFrame> frames;  // named frames, distinct names; may be empty
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -kStandardGravity);  // m/s², world frame
  bool floating_base = false;  // the root is `base`, free in the world (above); false: the world
  RigidBody base;              // the floating base's body (floating_base only)

  int num_joints() const { return static_cast<int>(joints.size()); }
  // Sizes of q and v: num_dofs() for a fixed base; + 7 and + 6 for a floating one.
  int num_q() const { return num_dofs() + (floating_base ? kFreeFlyerNq : 0); }
  int num_v() const { return num_dofs() + (floating_base ? kFreeFlyerNv : 0); }
  // The joints that mimic none.
  int num_dofs() const;
  bool has_mimics() const { return num_dofs() != num_joints(); }
  // The degree of freedom that moves joint `joint` (its own, or that of the
  // joint it mimics), an index into q: joint order, mimics skipped. O(joint).
  int DofOf(int joint) const;
  // How joint `joint` moves with q: q_joint = scale · q[dof] + offset,
  // qd_joint = scale · qd[dof] (scale 1, offset 0 but for a mimic): its row of
  // S and its entry of o. O(joint).
  struct JointMap {
    int dof = 0;
    double scale = 1.0;
    double offset = 0.0;
  };
  JointMap MapOf(int joint) const;
  // The degrees of freedom's joint types and names (n), in q's order.
  std::vector<JointType> joint_types() const;
  std::vector<std::string> joint_names() const;
  std::vector<std::string> frame_names() const;
  // The same tree with every joint a degree of freedom (mimics cleared): what
  // a recursive algorithm runs on before the reduction (plant/mimic_dynamics.hpp).
  RigidTree WithEveryJointFree() const;

  // Energies by forward kinematics, templated over the scalar for the
  // Lagrangian path (double and every Dual of plant/dual.hpp).
  template <class S>
  S KineticEnergy(std::span<const S> q, std::span<const S> qd) const;
  template <class S>
  S PotentialEnergy(std::span<const S> q) const;
};

// A joint of a planar plant, in the xy plane: its frame sits at (x, y) in its
// parent body's frame (m), turned by `angle` (rad) about z; a revolute joint
// turns about z, a prismatic one slides along its frame's x.
TreeJoint PlanarTreeJoint(std::string name, JointType type, int parent, double x, double y, double angle);
// A frame of a planar plant on body `body`: at (x, y) in its frame (m),
// turned by `angle` (rad) about z.
TreeFrame PlanarTreeFrame(std::string name, int body, double x, double y, double angle);
// A body of a planar plant: `mass` (kg) with its centre of mass at (x, y) in
// its frame (m) and inertia `I` (kg·m²) about z through it, as a thin lamina
// in the plane: I_xx = I_yy = I/2 (the perpendicular-axis theorem), which
// planar motion never excites.
RigidBody PlanarTreeBody(double mass, double x, double y, double I);
// Gravity of a planar plant: g (m/s²) along −y.
inline Eigen::Vector3d PlanarGravity(double g) { return {0.0, -g, 0.0}; }

// Why I (3 x 3, kg·m², about the centre of mass) is not a rigid body's
// rotational inertia, or nullopt. It must be finite, symmetric, positive
// semi-definite, and its principal moments must obey the triangle inequality
// (each <= the sum of the other two); each to kInertiaTolerance times its
// largest principal moment in magnitude, for rounding in a file. The reason
// reads "inertia is not positive semi-definite (eigenvalue -0.1 kg·m²)".
// The one check for ValidateRigidTree and the URDF loader.
inline constexpr double kInertiaTolerance = 1e-9;
std::optional<std::string> CheckRotationalInertia(const Eigen::Matrix3d& I);

// Why `tree` is not a valid model, as "KEY: expected ..., got ...", or nullopt:
// sizes agree, 1..kMaxDofs joints, parents come first, rotations are proper
// orthonormal, axes unit, all numbers finite, masses >= 0, frames on an
// existing body (or the world) with distinct non-empty names, inertias passing
// CheckRotationalInertia (physically realisable), mimics that follow another
// joint which is itself a degree of freedom (no chains, no cycles) with finite
// multiplier and offset, and M(0) = Sᵀ M_joints S positive definite at q = 0
// (no massless leaf, no joint that moves nothing), and with mimics the same of
// the tree with every joint free, which the recursive path runs. A floating
// tree is refused (every fixed-base algorithm calls this).
std::optional<std::string> ValidateRigidTree(const RigidTree& tree);

// The same for a floating-base tree (floating_base true): 0..kMaxDofs joints,
// the checks above on them (M(0) of the joints with the base held; mimic
// joints as above: FloatingDynamics reduces them), and a base body of positive mass and
// positive definite inertia (so M(q) is positive definite at every q).
std::optional<std::string> ValidateFloatingTree(const RigidTree& tree);

}  // namespace lagrange

// Template definitions of the energies.
#include "plant/rigid_tree_energy.hpp"
