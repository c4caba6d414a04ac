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
// Model and data apart, as plant/dynamics.hpp: a Kinematics is immutable
// and may be shared by threads; each user evaluates it through a
// KinematicsData it made (MakeData), which holds every result and buffer, so
// ComputeFrameKinematics allocates nothing and a controller may call it in
// the tick. Sizes are checked by eigen_assert (on in debug and sanitizer
// builds).

#include <Eigen/Core>
#include <memory>
#include <optional>
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

// One user's results of Kinematics::ComputeFrameKinematics, every buffer
// sized by Kinematics::MakeData. Frame indices are the model's (FrameIndex).
class KinematicsData {
 public:
  KinematicsData(const KinematicsData&) = delete;
  KinematicsData& operator=(const KinematicsData&) = delete;

  const Kinematics& model() const { return *model_; }
  // R_k: the frame's axes in world coordinates (3 x 3).
  const Eigen::Matrix3d& rotation(int frame) const { return frames_[frame].R; }
  // p_k: the frame's origin in the world frame, m.
  const Eigen::Vector3d& position(int frame) const { return frames_[frame].p; }
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

  // A body's state in world coordinates: pose, the world axis of its joint,
  // velocity (w, v of its origin) and bias acceleration (dw, dv at qdd = 0).
  struct Body {
    Eigen::Matrix3d R;
    Eigen::Vector3d p, z, w, v, dw, dv;
  };
  struct Frame {
    Eigen::Matrix3d R;
    Eigen::Vector3d p;
    Matrix6Xd J_world, J_local;
    Vector6d bias_world, bias_local;
  };

  const Kinematics* model_;
  std::vector<Body> bodies_;   // (num_joints), mimics too
  std::vector<Frame> frames_;  // (num_frames)
};

class Kinematics {
 public:
  // The tree's joints and frames. Throws std::invalid_argument when the
  // tree is not valid (ValidateRigidTree).
  explicit Kinematics(const RigidTree& tree);

  // The tree's degrees of freedom (q's size; mimic joints follow theirs).
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

 private:
  // (q, qd) => each body's pose, joint axis, velocity and bias acceleration.
  void ForwardPass(KinematicsData& data, ConstVecRef q, ConstVecRef qd) const;
  // The bodies' state => frame k's pose, Jacobians and biases.
  void FillFrame(KinematicsData& data, int k) const;

  friend class KinematicsData;

  int num_dofs_;
  std::vector<TreeJoint> joints_;  // every joint, mimics too
  std::vector<int> dof_;           // (joints) the degree of freedom moving each joint (RigidTree::DofOf)
  std::vector<double> scale_;      // (joints) 1, or a mimic's multiplier
  std::vector<double> offset_;     // (joints) 0, or a mimic's offset
  std::vector<TreeFrame> frames_;
  std::vector<std::string> names_;
  std::vector<std::vector<int>> support_;  // per frame: the joints that move it, root first (joint indices)
};

}  // namespace lagrange
