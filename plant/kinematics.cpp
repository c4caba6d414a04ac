#include "plant/kinematics.hpp"

#include <cmath>
#include <stdexcept>

#include "plant/spatial_algebra.hpp"

namespace lagrange {

using spatial::Cross;
using spatial::Mul;
using spatial::MulAB;
using spatial::MulT;

namespace {

// Rotation by angle about the unit axis a (Rodrigues): c 1 + s [a]× + (1 − c) a aᵀ.
Eigen::Matrix3d AxisRotation(const Eigen::Vector3d& a, double angle) {
  const double c = std::cos(angle), s = std::sin(angle), t = 1.0 - c;
  Eigen::Matrix3d E;
  E << c + t * a.x() * a.x(), t * a.x() * a.y() - s * a.z(), t * a.x() * a.z() + s * a.y(),  //
      t * a.y() * a.x() + s * a.z(), c + t * a.y() * a.y(), t * a.y() * a.z() - s * a.x(),   //
      t * a.z() * a.x() - s * a.y(), t * a.z() * a.y() + s * a.x(), c + t * a.z() * a.z();
  return E;
}

}  // namespace

KinematicsData::KinematicsData(const Kinematics& model) : model_(&model), bodies_(model.joints_.size()) {
  const int n = model.num_dofs();
  frames_.resize(model.num_frames());
  for (Frame& f : frames_) {
    f.R.setIdentity();
    f.p.setZero();
    // Columns of joints that do not carry the frame stay zero.
    f.J_world = Matrix6Xd::Zero(6, n);
    f.J_local = Matrix6Xd::Zero(6, n);
    f.bias_world.setZero();
    f.bias_local.setZero();
  }
}

Kinematics::Kinematics(const RigidTree& tree)
    : num_dofs_(tree.num_dofs()), joints_(tree.joints), frames_(tree.frames) {
  if (const auto why = ValidateRigidTree(tree)) throw std::invalid_argument("kinematics: " + *why);
  names_ = tree.frame_names();
  for (int i = 0; i < tree.num_joints(); ++i) {
    const TreeJoint& j = joints_[static_cast<std::size_t>(i)];
    dof_.push_back(tree.DofOf(i));
    scale_.push_back(j.mimic < 0 ? 1.0 : j.multiplier);
    offset_.push_back(j.mimic < 0 ? 0.0 : j.offset);
  }
  support_.resize(frames_.size());
  for (std::size_t k = 0; k < frames_.size(); ++k) {
    for (int j = frames_[k].body; j >= 0; j = joints_[j].parent) support_[k].insert(support_[k].begin(), j);
  }
}

std::optional<int> Kinematics::FrameIndex(std::string_view name) const {
  for (int k = 0; k < num_frames(); ++k) {
    if (names_[k] == name) return k;
  }
  return std::nullopt;
}

std::unique_ptr<KinematicsData> Kinematics::MakeData() const {
  return std::unique_ptr<KinematicsData>(new KinematicsData(*this));
}

void Kinematics::ComputeFrameKinematics(KinematicsData& data, ConstVecRef q, ConstVecRef qd) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs() && qd.size() == num_dofs());
  ForwardPass(data, q, qd);
  for (int k = 0; k < num_frames(); ++k) FillFrame(data, k);
}

// Body i from its parent λ (world coordinates, r = p_i − p_λ, z_i the joint's
// world axis, ż_i = ω_λ × z_i):
//   revolute   ω_i = ω_λ + z_i qd_i          ω̇_i = ω̇_λ + ω_λ × z_i qd_i
//              v_i = v_λ + ω_λ × r           a_i = a_λ + ω̇_λ × r + ω_λ × (ω_λ × r)
//   prismatic  ω_i = ω_λ                     ω̇_i = ω̇_λ
//              v_i = v_λ + ω_λ × r + z_i qd_i
//              a_i = a_λ + ω̇_λ × r + ω_λ × (ω_λ × r) + 2 ω_λ × z_i qd_i
// with the accelerations at qdd = 0.
void Kinematics::ForwardPass(KinematicsData& data, ConstVecRef q, ConstVecRef qd) const {
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  for (int i = 0; i < static_cast<int>(joints_.size()); ++i) {
    const TreeJoint& j = joints_[i];
    const double qi = scale_[i] * q[dof_[i]] + offset_[i];  // a mimic follows its joint (RigidTree)
    const double qdi = scale_[i] * qd[dof_[i]];
    KinematicsData::Body& b = data.bodies_[i];
    const bool root = j.parent < 0;
    const KinematicsData::Body* parent = root ? nullptr : &data.bodies_[j.parent];
    const Eigen::Matrix3d R_joint = root ? j.rotation : MulAB(parent->R, j.rotation);
    const Eigen::Vector3d& w = root ? zero : parent->w;
    b.z = Mul(R_joint, j.axis);
    Eigen::Vector3d r = root ? j.position : Mul(parent->R, j.position);
    if (j.type == JointType::kRevolute) {
      b.R = MulAB(R_joint, AxisRotation(j.axis, qi));
    } else {
      b.R = R_joint;
      r += qi * b.z;
    }
    b.p = root ? r : parent->p + r;
    const Eigen::Vector3d wr = Cross(w, r);
    b.w = w;
    b.v = root ? wr : parent->v + wr;
    b.dw = root ? zero : parent->dw;
    b.dv = root ? zero : parent->dv + Cross(parent->dw, r) + Cross(w, wr);
    const Eigen::Vector3d zqd = qdi * b.z;
    if (j.type == JointType::kRevolute) {
      b.w += zqd;
      b.dw += Cross(w, zqd);
    } else {
      b.v += zqd;
      b.dv += 2.0 * Cross(w, zqd);
    }
  }
}

void Kinematics::FillFrame(KinematicsData& data, int k) const {
  const TreeFrame& tf = frames_[k];
  KinematicsData::Frame& f = data.frames_[k];
  if (tf.body < 0) {  // on the world: still, its Jacobian and bias zero from MakeData
    f.R = tf.rotation;
    f.p = tf.position;
    return;
  }
  const KinematicsData::Body& b = data.bodies_[tf.body];
  f.R = MulAB(b.R, tf.rotation);
  const Eigen::Vector3d r = Mul(b.R, tf.position);
  f.p = b.p + r;
  const Eigen::Vector3d a = b.dv + Cross(b.dw, r) + Cross(b.w, Cross(b.w, r));
  f.bias_world << a, b.dw;
  f.bias_local << MulT(f.R, a), MulT(f.R, b.dw);
  // Column d sums the motions of the joints d moves (J_joints S): its own and
  // its mimics', each times its multiplier.
  for (const int j : support_[k]) {
    f.J_world.col(dof_[j]).setZero();
    f.J_local.col(dof_[j]).setZero();
  }
  for (const int j : support_[k]) {
    const KinematicsData::Body& bj = data.bodies_[j];
    const bool revolute = joints_[j].type == JointType::kRevolute;
    const Eigen::Vector3d linear = revolute ? Cross(bj.z, Eigen::Vector3d(f.p - bj.p)) : bj.z;
    const Eigen::Vector3d angular = revolute ? bj.z : Eigen::Vector3d::Zero();
    f.J_world.col(dof_[j]).head<3>() += scale_[j] * linear;
    f.J_world.col(dof_[j]).tail<3>() += scale_[j] * angular;
    f.J_local.col(dof_[j]).head<3>() += scale_[j] * MulT(f.R, linear);
    f.J_local.col(dof_[j]).tail<3>() += scale_[j] * MulT(f.R, angular);
  }
}

}  // namespace lagrange
