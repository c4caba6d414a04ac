#include "plant/kinematics.hpp"

#include <Eigen/Geometry>
#include <numeric>
#include <stdexcept>

#include "plant/spatial_algebra.hpp"
#include "plant/spatial_sincos.hpp"

namespace lagrange {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using spatial::Cross;
using spatial::Mul;
using spatial::MulAB;
using spatial::MulT;

namespace {

// A rotation taking z to the unit vector a: a joint's folding (exactly the
// identity for a = z, which most URDF joints have). The least rotation, about
// z x a (Eigen's Quaternion::FromTwoVectors' too), written out: FromTwoVectors
// instantiates a JacobiSVD for the antiparallel case, half of this file's compile
// time in each of scripts/test's four trees. With c = a_z and s^2 = a_x^2 + a_y^2,
// R = c 1 + [z x a]x + (z x a)(z x a)^T / (1 + c), where 1 / (1 + c) = (1 - c) / s^2
// keeps its precision near a = -z; a = -z itself folds by a half turn about x.
Matrix3d FoldOf(const Vector3d& axis) {
  const Vector3d a = axis.normalized();
  const double c = a.z(), s2 = a.x() * a.x() + a.y() * a.y();
  if (s2 == 0.0) return c > 0.0 ? Matrix3d::Identity() : Matrix3d(Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal());
  const double k = (1.0 - c) / s2;
  Matrix3d R;
  R << c + k * a.y() * a.y(), -k * a.x() * a.y(), a.x(),  //
      -k * a.x() * a.y(), c + k * a.x() * a.x(), a.y(),   //
      -a.x(), -a.y(), c;
  return R;
}

// R r, with r in the form Kinematics::Offset keeps it.
template <class Offset>
LAGRANGE_SPATIAL_INLINE Vector3d Offsetted(const Matrix3d& R, const Offset& o) {
  switch (o.kind) {
    case Offset::Kind::kZero: return Vector3d::Zero();
    case Offset::Kind::kAlongAxis: return o.length * R.col(o.axis);
    case Offset::Kind::kGeneral: break;
  }
  return Mul(R, o.r);
}

}  // namespace

KinematicsData::KinematicsData(const Kinematics& model)
    : model_(&model),
      qj_(model.joints_.size()),
      cq_(model.joints_.size()),
      sq_(model.joints_.size()),
      bodies_(model.joints_.size()) {
  const int n = model.num_dofs();
  frames_.resize(model.num_frames());
  for (int k = 0; k < model.num_frames(); ++k) {
    Frame& f = frames_[k];
    const Kinematics::Frame& tf = model.frames_[k];
    // A frame on the world stays where the tree puts it; the others until computed.
    f.R = tf.body < 0 ? tf.R : Matrix3d::Identity();
    f.p = tf.body < 0 ? tf.p.r : Vector3d::Zero();
    f.R_at = tf.at_body ? &bodies_[tf.body].R : &f.R;
    f.p_at = tf.at_body ? &bodies_[tf.body].p : &f.p;
    // Columns of joints that do not carry the frame stay zero.
    f.J_world = Matrix6Xd::Zero(6, n);
    f.J_local = Matrix6Xd::Zero(6, n);
    f.bias_world.setZero();
    f.bias_local.setZero();
  }
  for (Body& b : bodies_) {
    b.R.setIdentity();
    b.p.setZero();
    b.w.setZero();
    b.v.setZero();
    b.dw.setZero();
    b.dv.setZero();
  }
}

Kinematics::Offset Kinematics::OffsetOf(const Vector3d& r) {
  Offset o;
  o.r = r;
  const int nonzero = (r.x() != 0.0) + (r.y() != 0.0) + (r.z() != 0.0);
  if (nonzero == 1) {
    o.kind = Offset::Kind::kAlongAxis;
    o.axis = r.x() != 0.0 ? 0 : r.y() != 0.0 ? 1 : 2;
    o.length = r[o.axis];
  } else if (nonzero > 1) {
    o.kind = Offset::Kind::kGeneral;
  }
  return o;
}

// Folding: body i's folded axes are its own times fold_i, fold_i e_z = axis_i,
// so the joint frame's axes in the folded parent frame are fold_λᵀ rotation fold_i
// and its origin fold_λᵀ position; a frame's placement turns by fold_bodyᵀ.
Kinematics::Kinematics(const RigidTree& tree) {
  if (const auto why = ValidateRigidTree(tree)) throw std::invalid_argument("kinematics: " + *why);
  num_dofs_ = tree.num_dofs();
  mimics_ = tree.has_mimics();
  const int n = tree.num_joints();
  std::vector<Matrix3d> fold(n);
  for (int i = 0; i < n; ++i) {
    const TreeJoint& tj = tree.joints[i];
    fold[i] = FoldOf(tj.axis);
    const Matrix3d parent_fold = tj.parent < 0 ? Matrix3d::Identity() : fold[tj.parent];
    Joint j;
    j.parent = tj.parent;
    j.map = tree.MapOf(i);
    j.revolute = tj.type == JointType::kRevolute;
    j.E = parent_fold.transpose() * tj.rotation * fold[i];
    j.identity = j.E == Matrix3d::Identity();
    j.r = OffsetOf(parent_fold.transpose() * tj.position);
    joints_.push_back(j);
  }
  for (const TreeFrame& tf : tree.frames) {
    Frame f;
    f.body = tf.body;
    const Matrix3d body_fold = tf.body < 0 ? Matrix3d::Identity() : fold[tf.body];
    f.R = body_fold.transpose() * tf.rotation;
    f.p = OffsetOf(body_fold.transpose() * tf.position);
    f.identity = f.R == Matrix3d::Identity();
    f.at_body = f.body >= 0 && f.identity && f.p.kind == Offset::Kind::kZero;
    frames_.push_back(f);
  }
  names_ = tree.frame_names();
  all_joints_.resize(n);
  std::iota(all_joints_.begin(), all_joints_.end(), 0);
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

// ---- entry points -------------------------------------------------------------

void Kinematics::ComputeFrameKinematics(KinematicsData& data, ConstVecRef q, ConstVecRef qd) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs() && qd.size() == num_dofs());
  PlaceBodies(data, q, all_joints_);
  MoveBodies(data, qd, all_joints_);
  for (int k = 0; k < num_frames(); ++k) {
    PlaceFrame(data, k);
    FillJacobian(data, k, FrameAxes::kWorldAligned);
    FillJacobian(data, k, FrameAxes::kLocal);
    FillBias(data, k, FrameAxes::kWorldAligned);
    FillBias(data, k, FrameAxes::kLocal);
  }
}

void Kinematics::ComputeFramePlacements(KinematicsData& data, ConstVecRef q) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs());
  PlaceBodies(data, q, all_joints_);
  for (int k = 0; k < num_frames(); ++k) PlaceFrame(data, k);
}

void Kinematics::ComputeFramePlacement(KinematicsData& data, ConstVecRef q, int frame) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs() && frame >= 0 && frame < num_frames());
  PlaceBodies(data, q, support_[frame]);
  PlaceFrame(data, frame);
}

void Kinematics::ComputeFrameJacobians(KinematicsData& data, ConstVecRef q, FrameAxes axes) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs());
  PlaceBodies(data, q, all_joints_);
  for (int k = 0; k < num_frames(); ++k) {
    PlaceFrame(data, k);
    FillJacobian(data, k, axes);
  }
}

void Kinematics::ComputeFrameJacobian(KinematicsData& data, ConstVecRef q, int frame, FrameAxes axes) const {
  if (axes == FrameAxes::kLocal) {
    ComputeFrameJacobian(data, q, frame, LocalJacobianKernel::kFromTip);
    return;
  }
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs() && frame >= 0 && frame < num_frames());
  PlaceBodies(data, q, support_[frame]);
  PlaceFrame(data, frame);
  FillJacobian(data, frame, axes);
}

void Kinematics::ComputeFrameJacobian(KinematicsData& data, ConstVecRef q, int frame,
                                      LocalJacobianKernel kernel) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs() && frame >= 0 && frame < num_frames());
  if (kernel == LocalJacobianKernel::kFromTip) {
    PlaceFrameAndLocalJacobianFromTip(data, q, frame);
    return;
  }
  PlaceBodies(data, q, support_[frame]);
  PlaceFrame(data, frame);
  FillJacobian(data, frame, FrameAxes::kLocal);
}

void Kinematics::ComputeFrameBiasAcceleration(KinematicsData& data, ConstVecRef q, ConstVecRef qd, int frame,
                                              FrameAxes axes) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs() && qd.size() == num_dofs() && frame >= 0 && frame < num_frames());
  PlaceBodies(data, q, support_[frame]);
  MoveBodies(data, qd, support_[frame]);
  PlaceFrame(data, frame);
  FillBias(data, frame, axes);
}

void Kinematics::ComputeFrameJacobianAndBias(KinematicsData& data, ConstVecRef q, ConstVecRef qd, int frame,
                                             FrameAxes axes) const {
  eigen_assert(&data.model() == this && "KinematicsData made by another model");
  eigen_assert(q.size() == num_dofs() && qd.size() == num_dofs() && frame >= 0 && frame < num_frames());
  PlaceBodies(data, q, support_[frame]);
  MoveBodies(data, qd, support_[frame]);
  PlaceFrame(data, frame);
  FillJacobian(data, frame, axes);
  FillBias(data, frame, axes);
}

// ---- passes -----------------------------------------------------------------

// Body i from its parent λ (folded axes; R_λ = 1, p_λ = 0 for a root joint):
//   B   = E Rz(q_i): columns (c E₀ + s E₁, c E₁ − s E₀, E₂) for a revolute joint, E for a prismatic one
//   R_i = R_λ B                     (R_λ Rz(q_i), two columns mixed, when E is the identity)
//   p_i = p_λ + R_λ r               (+ q_i R_i e_z for a prismatic joint)
// B first: it does not wait for the parent, so each joint adds one product to
// the chain of dependencies. Written out element by element: Eigen's column
// expressions on 3-vectors cost about a fifth more here.
const double* Kinematics::JointSines(KinematicsData& data, ConstVecRef q) const {
  const int n = static_cast<int>(joints_.size());
  const double* qj = q.data();  // each joint's position: q itself, unless a joint mimics another
  if (mimics_) {
    for (int i = 0; i < n; ++i) {
      const RigidTree::JointMap& m = joints_[i].map;
      data.qj_[i] = m.scale * q[m.dof] + m.offset;
    }
    qj = data.qj_.data();
  }
  spatial::SinCos(qj, data.cq_.data(), data.sq_.data(), n);
  return qj;
}

void Kinematics::PlaceBodies(KinematicsData& data, ConstVecRef q, std::span<const int> joints) const {
  const double* qj = JointSines(data, q);
  for (const int i : joints) {
    const Joint& j = joints_[i];
    KinematicsData::Body& b = data.bodies_[i];
    const bool root = j.parent < 0;
    const Matrix3d& R = root ? j.E : data.bodies_[j.parent].R;  // R_λ B, or B itself for a root
    if (!j.revolute) {
      b.R = root || j.identity ? R : MulAB(R, j.E);
    } else if (root || j.identity) {
      const double c = data.cq_[i], s = data.sq_[i];
      for (int r = 0; r < 3; ++r) {
        b.R(r, 0) = c * R(r, 0) + s * R(r, 1);
        b.R(r, 1) = c * R(r, 1) - s * R(r, 0);
        b.R(r, 2) = R(r, 2);
      }
    } else {
      const double c = data.cq_[i], s = data.sq_[i];
      const Matrix3d& E = j.E;
      double B[3][3];  // row-major
      for (int r = 0; r < 3; ++r) {
        B[r][0] = c * E(r, 0) + s * E(r, 1);
        B[r][1] = c * E(r, 1) - s * E(r, 0);
        B[r][2] = E(r, 2);
      }
      for (int col = 0; col < 3; ++col) {
        for (int r = 0; r < 3; ++r) b.R(r, col) = R(r, 0) * B[0][col] + R(r, 1) * B[1][col] + R(r, 2) * B[2][col];
      }
    }
    b.p = root ? j.r.r : Vector3d(data.bodies_[j.parent].p + Offsetted(R, j.r));
    if (!j.revolute) b.p += qj[i] * b.R.col(2);
  }
}

// Body i from its parent λ, world coordinates, r = p_i − p_λ, z_i the joint's
// world axis (ż_i = ω_λ × z_i):
//   revolute   ω_i = ω_λ + z_i qd_i          ω̇_i = ω̇_λ + ω_λ × z_i qd_i
//              v_i = v_λ + ω_λ × r           a_i = a_λ + ω̇_λ × r + ω_λ × (ω_λ × r)
//   prismatic  ω_i = ω_λ                     ω̇_i = ω̇_λ
//              v_i = v_λ + ω_λ × r + z_i qd_i
//              a_i = a_λ + ω̇_λ × r + ω_λ × (ω_λ × r) + 2 ω_λ × z_i qd_i
// with the accelerations at qdd = 0.
void Kinematics::MoveBodies(KinematicsData& data, ConstVecRef qd, std::span<const int> joints) const {
  for (const int i : joints) {
    const Joint& j = joints_[i];
    KinematicsData::Body& b = data.bodies_[i];
    const Vector3d zqd = (j.map.scale * qd[j.map.dof]) * b.R.col(2);
    if (j.parent < 0) {  // the world is still
      b.w.setZero();
      b.v.setZero();
      b.dw.setZero();
      b.dv.setZero();
    } else {
      const KinematicsData::Body& parent = data.bodies_[j.parent];
      const Vector3d r = b.p - parent.p;
      const Vector3d wr = Cross(parent.w, r);
      b.w = parent.w;
      b.v = parent.v + wr;
      b.dw = parent.dw;
      b.dv = parent.dv + Cross(parent.dw, r) + Cross(parent.w, wr);
      if (j.revolute) {
        b.dw += Cross(parent.w, zqd);
      } else {
        b.dv += 2.0 * Cross(parent.w, zqd);
      }
    }
    if (j.revolute) {
      b.w += zqd;
    } else {
      b.v += zqd;
    }
  }
}

void Kinematics::PlaceFrame(KinematicsData& data, int k) const {
  const Frame& tf = frames_[k];
  // On the world: placed by MakeData, never moves; at its body's origin: read there.
  if (tf.body < 0 || tf.at_body) return;
  const KinematicsData::Body& b = data.bodies_[tf.body];
  KinematicsData::Frame& f = data.frames_[k];
  f.R = tf.identity ? b.R : MulAB(b.R, tf.R);
  f.p = b.p + Offsetted(b.R, tf.p);
}

void Kinematics::FillJacobian(KinematicsData& data, int k, FrameAxes axes) const {
  KinematicsData::Frame& f = data.frames_[k];
  const Matrix3d& R = *f.R_at;
  const Vector3d& p = *f.p_at;
  Matrix6Xd& J = axes == FrameAxes::kLocal ? f.J_local : f.J_world;
  if (mimics_) {  // column d sums its joints' motions, each times its multiplier (J_joints S)
    for (const int j : support_[k]) J.col(joints_[j].map.dof).setZero();
  }
  for (const int j : support_[k]) {
    const KinematicsData::Body& bj = data.bodies_[j];
    const Vector3d z = bj.R.col(2);
    const bool revolute = joints_[j].revolute;
    const Vector3d linear = revolute ? Cross(z, Vector3d(p - bj.p)) : z;
    const Vector3d angular = revolute ? z : Vector3d::Zero();
    if (mimics_) {
      const double m = joints_[j].map.scale;
      const int d = joints_[j].map.dof;
      J.col(d).head<3>() += m * (axes == FrameAxes::kLocal ? MulT(R, linear) : linear);
      J.col(d).tail<3>() += m * (axes == FrameAxes::kLocal ? MulT(R, angular) : angular);
    } else if (axes == FrameAxes::kLocal) {
      J.col(j) << MulT(R, linear), MulT(R, angular);
    } else {
      J.col(j) << linear, angular;
    }
  }
}

// With T_j = R_jᵀ R_k and t_j = R_jᵀ (p_k − o_j), frame k's axes and origin in
// body j's folded frame, from T_b = the frame's R and t_b = its offset on its
// body b, and B_j = R_λᵀ R_j = E Rz(q_j) (revolute) or E (prismatic):
//   T_λ = B_j T_j,  t_λ = B_j t_j + r_j  (+ q_j E e_z for a prismatic joint)
// and joint j's column in the frame's axes: R_kᵀ z_j = T_jᵀ e_z (row 2 of T_j);
// R_kᵀ (z_j × (p_k − o_j)) = T_jᵀ (e_z × t_j) = t_x (row 1) − t_y (row 0).
// Past the root joint T and t are R_k and p_k.
void Kinematics::PlaceFrameAndLocalJacobianFromTip(KinematicsData& data, ConstVecRef q, int k) const {
  const Frame& tf = frames_[k];
  if (tf.body < 0) return;  // on the world: placed by MakeData, zero Jacobian
  const double* qj = JointSines(data, q);
  KinematicsData::Frame& f = data.frames_[k];
  Matrix6Xd& J = f.J_local;
  const std::vector<int>& support = support_[k];
  if (mimics_) {
    for (const int j : support) J.col(joints_[j].map.dof).setZero();
  }
  Matrix3d T = tf.R;
  Vector3d t = tf.p.r;
  for (auto it = support.rbegin(); it != support.rend(); ++it) {
    const int i = *it;
    const Joint& j = joints_[i];
    double column[6];
    for (int c = 0; c < 3; ++c) {
      column[c] = j.revolute ? t.x() * T(1, c) - t.y() * T(0, c) : T(2, c);
      column[3 + c] = j.revolute ? T(2, c) : 0.0;
    }
    if (mimics_) {
      for (int r = 0; r < 6; ++r) J(r, j.map.dof) += j.map.scale * column[r];
    } else {
      for (int r = 0; r < 6; ++r) J(r, i) = column[r];
    }
    // Into the parent's frame: B = E Rz(q), Rz(q)'s rows mixed alone when E is the identity.
    if (!j.revolute) {
      const Vector3d slide = qj[i] * j.E.col(2);
      if (!j.identity) {
        T = MulAB(j.E, T);
        t = Mul(j.E, t);
      }
      t += slide + j.r.r;
    } else if (j.identity) {
      const double c = data.cq_[i], s = data.sq_[i];
      for (int col = 0; col < 3; ++col) {
        const double t0 = T(0, col), t1 = T(1, col);
        T(0, col) = c * t0 - s * t1;
        T(1, col) = s * t0 + c * t1;
      }
      const double t0 = t.x(), t1 = t.y();
      t.x() = c * t0 - s * t1 + j.r.r.x();
      t.y() = s * t0 + c * t1 + j.r.r.y();
      t.z() += j.r.r.z();
    } else {
      const double c = data.cq_[i], s = data.sq_[i];
      const Matrix3d& E = j.E;
      Matrix3d B;
      for (int r = 0; r < 3; ++r) {
        B(r, 0) = c * E(r, 0) + s * E(r, 1);
        B(r, 1) = c * E(r, 1) - s * E(r, 0);
        B(r, 2) = E(r, 2);
      }
      T = MulAB(B, T);
      t = Mul(B, t) + j.r.r;
    }
  }
  // Past the root: the frame's pose, where its readers find it.
  if (tf.at_body) {
    data.bodies_[tf.body].R = T;
    data.bodies_[tf.body].p = t;
  } else {
    f.R = T;
    f.p = t;
  }
}

// The frame's origin sits at r = p_k − p_b on body b: a_k = a_b + ω̇_b × r + ω_b × (ω_b × r), ω̇_k = ω̇_b.
void Kinematics::FillBias(KinematicsData& data, int k, FrameAxes axes) const {
  const Frame& tf = frames_[k];
  if (tf.body < 0) return;  // on the world: zero from MakeData
  const KinematicsData::Body& b = data.bodies_[tf.body];
  KinematicsData::Frame& f = data.frames_[k];
  const Vector3d r = *f.p_at - b.p;
  const Vector3d a = b.dv + Cross(b.dw, r) + Cross(b.w, Cross(b.w, r));
  if (axes == FrameAxes::kLocal) {
    const Matrix3d& R = *f.R_at;
    f.bias_local << MulT(R, a), MulT(R, b.dw);
  } else {
    f.bias_world << a, b.dw;
  }
}

}  // namespace lagrange
