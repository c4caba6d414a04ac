#include "plant/rigid_tree.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <utility>

#include "plant/eigenvalues.hpp"

namespace lagrange {

int RigidTree::num_dofs() const {
  return static_cast<int>(std::count_if(joints.begin(), joints.end(), [](const TreeJoint& j) { return j.mimic < 0; }));
}

int RigidTree::DofOf(int joint) const {
  const int own = joints[static_cast<std::size_t>(joint)].mimic < 0 ? joint : joints[static_cast<std::size_t>(joint)].mimic;
  if (own < 0 || own >= num_joints()) return -1;  // a tree ValidateRigidTree refuses
  int dof = 0;
  for (int i = 0; i < own; ++i) dof += joints[static_cast<std::size_t>(i)].mimic < 0 ? 1 : 0;
  return dof;
}

RigidTree::JointMap RigidTree::MapOf(int joint) const {
  const TreeJoint& j = joints[static_cast<std::size_t>(joint)];
  return j.mimic < 0 ? JointMap{DofOf(joint), 1.0, 0.0} : JointMap{DofOf(joint), j.multiplier, j.offset};
}

std::vector<JointType> RigidTree::joint_types() const {
  std::vector<JointType> types;
  types.reserve(joints.size());
  for (const TreeJoint& j : joints) {
    if (j.mimic < 0) types.push_back(j.type);
  }
  return types;
}

std::vector<std::string> RigidTree::joint_names() const {
  std::vector<std::string> names;
  names.reserve(joints.size());
  for (const TreeJoint& j : joints) {
    if (j.mimic < 0) names.push_back(j.name);
  }
  return names;
}

RigidTree RigidTree::WithEveryJointFree() const {
  RigidTree tree = *this;
  for (TreeJoint& j : tree.joints) {
    j.mimic = -1;
    j.multiplier = 1.0;
    j.offset = 0.0;
  }
  return tree;
}

std::vector<std::string> RigidTree::frame_names() const {
  std::vector<std::string> names;
  names.reserve(frames.size());
  for (const TreeFrame& f : frames) names.push_back(f.name);
  return names;
}

TreeFrame PlanarTreeFrame(std::string name, int body, double x, double y, double angle) {
  const TreeJoint j = PlanarTreeJoint(std::move(name), JointType::kRevolute, body, x, y, angle);
  return {j.name, body, j.position, j.rotation};
}

TreeJoint PlanarTreeJoint(std::string name, JointType type, int parent, double x, double y, double angle) {
  TreeJoint j;
  j.name = std::move(name);
  j.type = type;
  j.parent = parent;
  j.position = Eigen::Vector3d(x, y, 0.0);
  const double c = std::cos(angle), s = std::sin(angle);
  j.rotation << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;  // Rz(angle), its z row and column exact
  j.axis = type == JointType::kRevolute ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  return j;
}

RigidBody PlanarTreeBody(double mass, double x, double y, double I) {
  RigidBody b;
  b.mass = mass;
  b.com = Eigen::Vector3d(x, y, 0.0);
  b.inertia = Eigen::Vector3d(0.5 * I, 0.5 * I, I).asDiagonal();
  return b;
}

namespace {

// Tolerances of the checks, relative to the quantity's own scale.
constexpr double kUnitTol = 1e-9;    // |‖axis‖ − 1|, ‖RᵀR − 1‖
constexpr double kPivotTol = 1e-12;  // Cholesky pivot of M(0), × the largest diagonal entry

std::string Num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

std::string Str(const Eigen::Vector3d& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.6g, %.6g, %.6g)", v.x(), v.y(), v.z());
  return buf;
}

std::string Str(const Eigen::Matrix3d& m) {
  std::string s = "[";
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) s += Num(m(r, c)) + (c < 2 ? " " : (r < 2 ? "; " : "]"));
  }
  return s;
}

std::string Key(const char* list, int i, const char* field) {
  return std::string(list) + "[" + std::to_string(i) + "]." + field;
}

std::string Bad(const std::string& key, const std::string& expected, const std::string& got) {
  return key + ": expected " + expected + ", got " + got;
}

// A fixed placement (`list`[i].position and .rotation): finite, the rotation proper.
std::optional<std::string> CheckPlacement(const char* list, int i, const Eigen::Vector3d& position,
                                          const Eigen::Matrix3d& rotation) {
  if (!position.allFinite()) return Bad(Key(list, i, "position"), "finite numbers", Str(position));
  if (!rotation.allFinite()) return Bad(Key(list, i, "rotation"), "finite numbers", Str(rotation));
  const double orth = (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm();
  if (orth > kUnitTol || rotation.determinant() <= 0.0) {
    return Bad(Key(list, i, "rotation"), "a proper rotation (RᵀR = 1, det R = +1)", Str(rotation));
  }
  return std::nullopt;
}

std::optional<std::string> CheckJoint(const TreeJoint& j, int i) {
  if (j.parent < -1 || j.parent >= i) {
    return Bad(Key("joints", i, "parent"), "-1 (the world) to " + std::to_string(i - 1) + " (parents come first)",
               std::to_string(j.parent));
  }
  if (auto why = CheckPlacement("joints", i, j.position, j.rotation)) return why;
  if (!j.axis.allFinite()) return Bad(Key("joints", i, "axis"), "finite numbers", Str(j.axis));
  if (std::abs(j.axis.norm() - 1.0) > kUnitTol) {
    return Bad(Key("joints", i, "axis"), "a unit vector", Str(j.axis) + " of norm " + Num(j.axis.norm()));
  }
  return std::nullopt;
}

// A mimic follows another joint, itself a degree of freedom (no chains, so no
// cycles), by finite numbers.
std::optional<std::string> CheckMimic(const RigidTree& tree, int i) {
  const TreeJoint& j = tree.joints[static_cast<std::size_t>(i)];
  if (j.mimic < 0) return std::nullopt;
  const int n = tree.num_joints();
  if (j.mimic >= n || j.mimic == i) {
    return Bad(Key("joints", i, "mimic"),
               "-1 (a degree of freedom) or another joint's index, 0 to " + std::to_string(n - 1),
               std::to_string(j.mimic));
  }
  if (tree.joints[static_cast<std::size_t>(j.mimic)].mimic >= 0) {
    return Bad(Key("joints", i, "mimic"), "a joint that is a degree of freedom (no chains of mimics)",
               "joints[" + std::to_string(j.mimic) + "], itself a mimic of joints[" +
                   std::to_string(tree.joints[static_cast<std::size_t>(j.mimic)].mimic) + "]");
  }
  if (!std::isfinite(j.multiplier)) return Bad(Key("joints", i, "multiplier"), "a finite number", Num(j.multiplier));
  if (!std::isfinite(j.offset)) return Bad(Key("joints", i, "offset"), "a finite number", Num(j.offset));
  return std::nullopt;
}

std::optional<std::string> CheckFrames(const RigidTree& tree) {
  std::set<std::string_view> names;
  for (int i = 0; i < static_cast<int>(tree.frames.size()); ++i) {
    const TreeFrame& f = tree.frames[i];
    if (f.name.empty()) return Bad(Key("frames", i, "name"), "a name", "''");
    if (!names.insert(f.name).second) return Bad(Key("frames", i, "name"), "a name of one frame", "a repeated name");
    if (f.body < -1 || f.body >= tree.num_joints()) {
      return Bad(Key("frames", i, "body"), "-1 (the world) to " + std::to_string(tree.num_joints() - 1),
                 std::to_string(f.body));
    }
    if (auto why = CheckPlacement("frames", i, f.position, f.rotation)) return why;
  }
  return std::nullopt;
}

std::optional<std::string> CheckBody(const RigidBody& b, int i) {
  if (!std::isfinite(b.mass) || b.mass < 0.0) return Bad(Key("bodies", i, "mass"), "a finite mass >= 0", Num(b.mass));
  if (!b.com.allFinite()) return Bad(Key("bodies", i, "com"), "finite numbers", Str(b.com));
  const Eigen::Matrix3d& I = b.inertia;
  const std::string key = Key("bodies", i, "inertia");
  if (!I.allFinite()) return Bad(key, "finite numbers", Str(I));
  if (const auto why = CheckRotationalInertia(I)) {
    return Bad(key, "a rigid body's rotational inertia (symmetric, positive semi-definite, triangle inequality)",
               Str(I) + ": " + *why);
  }
  return std::nullopt;
}

// M(0) by the composite-rigid-body algorithm in world coordinates at q = 0
// (every joint at zero but a mimic, at its offset), written here so the check
// needs no dynamics object: with J_i joint i's world motion axis and Ic_i the
// world spatial inertia of its subtree, M_ij = J_iᵀ Ic_i J_j for j an ancestor
// of i or i itself; over the joints, then reduced to the degrees of freedom,
// Sᵀ M S.
Eigen::MatrixXd MassMatrixAtZero(const RigidTree& tree) {
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  const int n = tree.num_joints();
  std::vector<Eigen::Matrix3d> R(n);
  std::vector<Eigen::Vector3d> o(n);
  std::vector<Vector6d> J(n);
  std::vector<Matrix6d> Ic(n);
  auto skew = [](const Eigen::Vector3d& v) {
    Eigen::Matrix3d S;
    S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return S;
  };
  for (int i = 0; i < n; ++i) {
    const TreeJoint& j = tree.joints[i];
    const Eigen::Matrix3d Rp = j.parent < 0 ? Eigen::Matrix3d::Identity() : R[j.parent];
    const Eigen::Vector3d op = j.parent < 0 ? Eigen::Vector3d::Zero() : o[j.parent];
    R[i] = Rp * j.rotation;
    o[i] = op + Rp * j.position;
    const Eigen::Vector3d a = R[i] * j.axis;
    if (j.type == JointType::kRevolute) {
      J[i] << a, o[i].cross(a);
      R[i] = R[i] * Eigen::AngleAxisd(j.offset, j.axis).toRotationMatrix();
    } else {
      J[i] << Eigen::Vector3d::Zero(), a;
      o[i] += a * j.offset;
    }
    // Spatial inertia about the world origin: [[I_c − m[c]×², m[c]×], [−m[c]×, m 1]].
    const RigidBody& b = tree.bodies[i];
    const Eigen::Vector3d c = o[i] + R[i] * b.com;
    const Eigen::Matrix3d C = skew(c);
    Ic[i].topLeftCorner<3, 3>() = R[i] * b.inertia * R[i].transpose() - b.mass * C * C;
    Ic[i].topRightCorner<3, 3>() = b.mass * C;
    Ic[i].bottomLeftCorner<3, 3>() = -b.mass * C;
    Ic[i].bottomRightCorner<3, 3>() = b.mass * Eigen::Matrix3d::Identity();
  }
  for (int i = n - 1; i >= 0; --i) {
    if (tree.joints[i].parent >= 0) Ic[tree.joints[i].parent] += Ic[i];
  }
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    const Vector6d F = Ic[i] * J[i];
    for (int j = i; j >= 0; j = tree.joints[j].parent) {
      M(i, j) = J[j].dot(F);
      M(j, i) = M(i, j);
    }
  }
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, tree.num_dofs());
  for (int i = 0; i < n; ++i) S(i, tree.MapOf(i).dof) = tree.MapOf(i).scale;
  return S.transpose() * M * S;
}

// The joint of degree of freedom `dof`.
int JointOfDof(const RigidTree& tree, int dof) {
  for (int i = 0; i < tree.num_joints(); ++i) {
    if (tree.joints[i].mimic < 0 && dof-- == 0) return i;
  }
  return -1;
}

// The first joint at which M(0) stops being positive definite, by Cholesky
// in joint order; −1 if none.
int FirstSingularJoint(Eigen::MatrixXd M) {
  const int n = static_cast<int>(M.rows());
  const double scale = M.diagonal().cwiseAbs().maxCoeff();
  for (int k = 0; k < n; ++k) {
    const double d = M(k, k) - M.row(k).head(k).squaredNorm();
    if (!(d > kPivotTol * scale)) return k;
    M(k, k) = std::sqrt(d);
    for (int r = k + 1; r < n; ++r) M(r, k) = (M(r, k) - M.row(r).head(k).dot(M.row(k).head(k))) / M(k, k);
  }
  return -1;
}

bool MovesNothing(const RigidTree& tree, int i) {
  const RigidBody& b = tree.bodies[i];
  if (b.mass > 0.0 || b.inertia.cwiseAbs().maxCoeff() > 0.0) return false;
  for (int c = i + 1; c < tree.num_joints(); ++c) {
    if (tree.joints[c].parent == i) return false;
  }
  return true;
}

}  // namespace

std::optional<std::string> CheckRotationalInertia(const Eigen::Matrix3d& I) {
  if (!I.allFinite()) return "inertia has an entry that is not a finite number";
  const MatrixXd symmetric = 0.5 * (I + I.transpose());
  const VectorXd l = SymmetricEigenvalues(symmetric);  // ascending
  const double tolerance = kInertiaTolerance * l.cwiseAbs().maxCoeff();
  if ((I - I.transpose()).cwiseAbs().maxCoeff() > tolerance) return "inertia is not symmetric";
  if (l[0] < -tolerance) return "inertia is not positive semi-definite (eigenvalue " + Num(l[0]) + " kg·m²)";
  // Ascending: the one triangle inequality that can fail is l2 <= l0 + l1.
  if (l[2] > l[0] + l[1] + tolerance) {
    return "principal moments " + Num(l[0]) + ", " + Num(l[1]) + ", " + Num(l[2]) +
           " kg·m² violate the triangle inequality (" + Num(l[0]) + " + " + Num(l[1]) + " < " + Num(l[2]) +
           "): no rigid body has them";
  }
  return std::nullopt;
}

namespace {

// Every check of a tree's joints, bodies and frames; `floating` allows a tree
// of no joints (a free body).
std::optional<std::string> ValidateJointsBodiesFrames(const RigidTree& tree, bool floating) {
  const int n = tree.num_joints();
  if (n < (floating ? 0 : 1) || n > kMaxDofs) {
    return Bad("joints", (floating ? "0 to " : "1 to ") + std::to_string(kMaxDofs) + " joints", std::to_string(n));
  }
  if (tree.bodies.size() != tree.joints.size()) {
    return Bad("bodies", std::to_string(n) + " bodies (one per joint)", std::to_string(tree.bodies.size()));
  }
  if (!tree.gravity.allFinite()) return Bad("gravity", "finite numbers", Str(tree.gravity));
  for (int i = 0; i < n; ++i) {
    if (auto e = CheckJoint(tree.joints[i], i)) return e;
  }
  for (int i = 0; i < n; ++i) {
    if (auto e = CheckMimic(tree, i)) return e;
  }
  for (int i = 0; i < n; ++i) {
    if (auto e = CheckBody(tree.bodies[i], i)) return e;
  }
  if (auto e = CheckFrames(tree)) return e;
  if (n == 0) return std::nullopt;
  const int dof = FirstSingularJoint(MassMatrixAtZero(tree));
  if (dof < 0) return std::nullopt;
  const int k = JointOfDof(tree, dof);
  if (MovesNothing(tree, k)) {
    return Bad(Key("bodies", k, "mass"), "mass or inertia on a leaf body (M(0) positive definite)",
               "a massless leaf: joints[" + std::to_string(k) + "] moves nothing");
  }
  return Bad("joints[" + std::to_string(k) + "]",
             "a joint that moves mass or inertia of its own (M(0) positive definite)",
             "a singular mass matrix at this joint");
}

}  // namespace

std::optional<std::string> ValidateRigidTree(const RigidTree& tree) {
  if (tree.floating_base) {
    return Bad("floating_base", "false (a fixed-base tree; a floating one runs under FloatingDynamics)", "true");
  }
  if (auto why = ValidateJointsBodiesFrames(tree, false)) return why;
  // The recursive path runs a tree with mimic joints on the same tree with every joint free, reduced
  // (plant/mimic_dynamics.hpp): that tree must be valid too (a mimicked joint that moves mass only through its
  // mimics is not). Found by scripts/fuzz's URDF fuzzer.
  if (tree.has_mimics()) {
    if (auto why = ValidateJointsBodiesFrames(tree.WithEveryJointFree(), false)) {
      return "with every mimic joint free (as the recursive path runs them): " + *why;
    }
  }
  return std::nullopt;
}

std::optional<std::string> ValidateFloatingTree(const RigidTree& tree) {
  if (!tree.floating_base) return Bad("floating_base", "true (a floating-base tree)", "false");
  const RigidBody& b = tree.base;
  if (!std::isfinite(b.mass) || !(b.mass > 0.0)) return Bad("base.mass", "a finite mass > 0", Num(b.mass));
  if (!b.com.allFinite()) return Bad("base.com", "finite numbers", Str(b.com));
  if (const auto why = CheckRotationalInertia(b.inertia)) {
    return Bad("base.inertia", "a rigid body's rotational inertia", Str(b.inertia) + ": " + *why);
  }
  if (const double l = SymmetricEigenvalues(0.5 * (b.inertia + b.inertia.transpose()))[0]; !(l > 0.0)) {
    return Bad("base.inertia", "positive definite (a free body turns about every axis)",
               "smallest principal moment " + Num(l) + " kg·m²");
  }
  return ValidateJointsBodiesFrames(tree, true);
}

}  // namespace lagrange
