#pragma once
// Template definitions of RigidTree::KineticEnergy and PotentialEnergy
// (included at the end of plant/rigid_tree.hpp): forward kinematics over the
// scalar S (double or any Dual of plant/dual.hpp), written from the tree as
// given (raw axes, origin rotations and positions) and independent of the
// recursive algorithms of plant/spatial_dynamics, so the two check each other.
//
// Each body's frame is placed in the world, depth-first from each root joint:
//   joint frame   R_j = R_p · rotation,        o_j = o_p + R_p · position
//   revolute      R_b = R_j · Rot(axis, q),    o_b = o_j,                  ω_b = ω_p + R_j axis qd
//   prismatic     R_b = R_j,                   o_b = o_j + R_j axis q,     ω_b = ω_p
// with v the world velocity of the body origin (v_b = v_p + ω_p × (o_b − o_p)
// [+ R_j axis qd]), and Rot(a, q) = cos q 1 + sin q [a]× + (1 − cos q) a aᵀ.
// A mimic joint's q and qd are its followed joint's, scaled and offset
// (RigidTree), so the energies are over the degrees of freedom and the
// Lagrangian path's M, C and G are the reduced ones without a reduction step.
// The walk recurses into children: stack use grows with the tree's depth,
// nothing is allocated.

#include <cmath>

namespace lagrange {
namespace rigid_tree_energy {

template <class S>
struct Vec3 {
  S x, y, z;
};

// Row-major 3x3: m[r][c].
template <class S>
struct Mat3 {
  S m[3][3];
};

template <class S>
Vec3<S> operator+(const Vec3<S>& a, const Vec3<S>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class S>
Vec3<S> operator-(const Vec3<S>& a, const Vec3<S>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class S>
Vec3<S> operator*(const Vec3<S>& a, const S& s) {
  return {a.x * s, a.y * s, a.z * s};
}
template <class S>
S Dot(const Vec3<S>& a, const Vec3<S>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class S>
Vec3<S> Cross(const Vec3<S>& a, const Vec3<S>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// R x for a constant x.
template <class S>
Vec3<S> Mul(const Mat3<S>& R, const Eigen::Vector3d& x) {
  Vec3<S> out;
  S* o[3] = {&out.x, &out.y, &out.z};
  for (int r = 0; r < 3; ++r) *o[r] = R.m[r][0] * x[0] + R.m[r][1] * x[1] + R.m[r][2] * x[2];
  return out;
}

// Rᵀ x.
template <class S>
Vec3<S> MulTransposed(const Mat3<S>& R, const Vec3<S>& x) {
  return {R.m[0][0] * x.x + R.m[1][0] * x.y + R.m[2][0] * x.z, R.m[0][1] * x.x + R.m[1][1] * x.y + R.m[2][1] * x.z,
          R.m[0][2] * x.x + R.m[1][2] * x.y + R.m[2][2] * x.z};
}

// A B for a constant B.
template <class S>
Mat3<S> Mul(const Mat3<S>& A, const Eigen::Matrix3d& B) {
  Mat3<S> out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.m[r][c] = A.m[r][0] * B(0, c) + A.m[r][1] * B(1, c) + A.m[r][2] * B(2, c);
  }
  return out;
}

// A B.
template <class S>
Mat3<S> Mul(const Mat3<S>& A, const Mat3<S>& B) {
  Mat3<S> out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.m[r][c] = A.m[r][0] * B.m[0][c] + A.m[r][1] * B.m[1][c] + A.m[r][2] * B.m[2][c];
  }
  return out;
}

// Rot(a, q) by Rodrigues' formula, a a constant unit vector, (c, s) = (cos q, sin q).
template <class S>
Mat3<S> AxisRotation(const Eigen::Vector3d& a, const S& c, const S& s) {
  const S k = 1.0 - c;
  Mat3<S> R;
  for (int r = 0; r < 3; ++r) {
    for (int col = 0; col < 3; ++col) R.m[r][col] = k * (a[r] * a[col]);
    R.m[r][r] += c;
  }
  R.m[0][1] -= s * a.z();
  R.m[0][2] += s * a.y();
  R.m[1][0] += s * a.z();
  R.m[1][2] -= s * a.x();
  R.m[2][0] -= s * a.y();
  R.m[2][1] += s * a.x();
  return R;
}

template <class S>
Vec3<S> ToVec3(const Eigen::Vector3d& x) {
  return {S(x.x()), S(x.y()), S(x.z())};
}

template <class S>
Mat3<S> Identity() {
  Mat3<S> R;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R.m[r][c] = S(r == c ? 1.0 : 0.0);
  }
  return R;
}

// A body frame in the world: axes R (columns in world coordinates), origin o;
// for the kinetic energy also ω and the origin's velocity v, world coordinates.
template <class S>
struct Placement {
  Mat3<S> R;
  Vec3<S> o;
};
template <class S>
struct Motion {
  Placement<S> X;
  Vec3<S> w, v;
};

// Joint i's frame, fixed in its parent body: R_p · rotation, o_p + R_p · position.
template <class S>
Placement<S> PlaceJoint(const TreeJoint& j, const Placement<S>& parent) {
  return {Mul(parent.R, j.rotation), parent.o + Mul(parent.R, j.position)};
}

// Body i's frame: the joint frame moved by q_i.
template <class S>
Placement<S> MoveByJoint(const TreeJoint& j, const Placement<S>& joint, const S& qi) {
  using std::cos;
  using std::sin;
  if (j.type == JointType::kRevolute) return {Mul(joint.R, AxisRotation(j.axis, cos(qi), sin(qi))), joint.o};
  return {joint.R, joint.o + Mul(joint.R, j.axis) * qi};
}

// Joint i's position and velocity from the degrees of freedom's (q, qd):
// its own, or for a mimic multiplier · the followed joint's (+ offset).
// (A degree of freedom's own q is passed on untouched, not times 1 plus 0.)
template <class S>
S JointPosition(const RigidTree& tree, int i, std::span<const S> q) {
  const RigidTree::JointMap m = tree.MapOf(i);
  const S& own = q[static_cast<std::size_t>(m.dof)];
  return tree.joints[i].mimic < 0 ? own : own * m.scale + m.offset;
}
template <class S>
S JointVelocity(const RigidTree& tree, int i, std::span<const S> qd) {
  const RigidTree::JointMap m = tree.MapOf(i);
  const S& own = qd[static_cast<std::size_t>(m.dof)];
  return tree.joints[i].mimic < 0 ? own : own * m.scale;
}

// ½ m |v_c|² + ½ ω_bᵀ I ω_b of one body moving with b (world velocities).
template <class S>
S BodyKineticEnergy(const RigidBody& body, const Motion<S>& b) {
  // Centre of mass velocity and the body-axis angular velocity.
  const Vec3<S> vc = b.v + Cross(b.w, Mul(b.X.R, body.com));
  const Vec3<S> wb = MulTransposed(b.X.R, b.w);
  const Eigen::Matrix3d& I = body.inertia;
  const Vec3<S> Iw{wb.x * I(0, 0) + wb.y * I(0, 1) + wb.z * I(0, 2), wb.x * I(1, 0) + wb.y * I(1, 1) + wb.z * I(1, 2),
                   wb.x * I(2, 0) + wb.y * I(2, 1) + wb.z * I(2, 2)};
  return 0.5 * (body.mass * Dot(vc, vc) + Dot(wb, Iw));
}

template <class S>
S KineticEnergyFrom(const RigidTree& tree, int i, const Motion<S>& parent, std::span<const S> q,
                    std::span<const S> qd) {
  const TreeJoint& j = tree.joints[i];
  const RigidBody& body = tree.bodies[i];
  const Placement<S> joint = PlaceJoint(j, parent.X);
  const Vec3<S> axis = Mul(joint.R, j.axis);  // world axis
  Motion<S> b{MoveByJoint(j, joint, JointPosition(tree, i, q)), parent.w, {}};
  b.v = parent.v + Cross(parent.w, b.X.o - parent.X.o);
  if (j.type == JointType::kRevolute) {
    b.w = b.w + axis * JointVelocity(tree, i, qd);
  } else {
    b.v = b.v + axis * JointVelocity(tree, i, qd);
  }
  S T = BodyKineticEnergy(body, b);
  for (int c = i + 1; c < tree.num_joints(); ++c) {
    if (tree.joints[c].parent == i) T += KineticEnergyFrom(tree, c, b, q, qd);
  }
  return T;
}

template <class S>
S PotentialEnergyFrom(const RigidTree& tree, int i, const Placement<S>& parent, std::span<const S> q) {
  const Placement<S> b = MoveByJoint(tree.joints[i], PlaceJoint(tree.joints[i], parent), JointPosition(tree, i, q));
  const RigidBody& body = tree.bodies[i];
  const Vec3<S> pc = b.o + Mul(b.R, body.com);
  S V = -(body.mass * (pc.x * tree.gravity.x() + pc.y * tree.gravity.y() + pc.z * tree.gravity.z()));
  for (int c = i + 1; c < tree.num_joints(); ++c) {
    if (tree.joints[c].parent == i) V += PotentialEnergyFrom(tree, c, b, q);
  }
  return V;
}

// A floating tree (floating_base true): the base body at `base` in the world
// moving with the body twist (vb, wb) (base axes; its origin's velocity and
// its angular velocity), q and qd the joints' degrees of freedom. T is
// left-invariant (the same for every base pose): the Euler–Poincaré path
// (plant/floating_lagrangian.hpp) evaluates it at the identity.
template <class S>
S FloatingKineticEnergy(const RigidTree& tree, const Placement<S>& base, const Vec3<S>& vb, const Vec3<S>& wb,
                        std::span<const S> q, std::span<const S> qd) {
  const Mat3<S>& R = base.R;
  auto world = [&R](const Vec3<S>& x) {
    return Vec3<S>{R.m[0][0] * x.x + R.m[0][1] * x.y + R.m[0][2] * x.z,
                   R.m[1][0] * x.x + R.m[1][1] * x.y + R.m[1][2] * x.z,
                   R.m[2][0] * x.x + R.m[2][1] * x.y + R.m[2][2] * x.z};
  };
  const Motion<S> b{base, world(wb), world(vb)};
  S T = BodyKineticEnergy(tree.base, b);
  for (int i = 0; i < tree.num_joints(); ++i) {
    if (tree.joints[i].parent < 0) T += KineticEnergyFrom(tree, i, b, q, qd);
  }
  return T;
}

// −g · (first moment) of a floating tree with its base at `base`.
template <class S>
S FloatingPotentialEnergy(const RigidTree& tree, const Placement<S>& base, std::span<const S> q) {
  const Vec3<S> pc = base.o + Mul(base.R, tree.base.com);
  S V = -(tree.base.mass * (pc.x * tree.gravity.x() + pc.y * tree.gravity.y() + pc.z * tree.gravity.z()));
  for (int i = 0; i < tree.num_joints(); ++i) {
    if (tree.joints[i].parent < 0) V += PotentialEnergyFrom(tree, i, base, q);
  }
  return V;
}

}  // namespace rigid_tree_energy

template <class S>
S RigidTree::KineticEnergy(std::span<const S> q, std::span<const S> qd) const {
  eigen_assert(!floating_base && "the fixed-base energies: a floating tree runs under FloatingDynamics");
  using namespace rigid_tree_energy;
  const Vec3<S> zero{S(0.0), S(0.0), S(0.0)};
  const Motion<S> world{{Identity<S>(), zero}, zero, zero};
  S T(0.0);
  for (int i = 0; i < num_joints(); ++i) {
    if (joints[i].parent < 0) T += KineticEnergyFrom(*this, i, world, q, qd);
  }
  return T;
}

template <class S>
S RigidTree::PotentialEnergy(std::span<const S> q) const {
  eigen_assert(!floating_base && "the fixed-base energies: a floating tree runs under FloatingDynamics");
  using namespace rigid_tree_energy;
  const Placement<S> world{Identity<S>(), {S(0.0), S(0.0), S(0.0)}};
  S V(0.0);
  for (int i = 0; i < num_joints(); ++i) {
    if (joints[i].parent < 0) V += PotentialEnergyFrom(*this, i, world, q);
  }
  return V;
}

}  // namespace lagrange
