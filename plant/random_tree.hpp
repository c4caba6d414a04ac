#pragma once
// Seeded random rigid trees (plant/rigid_tree.hpp) for tests and benchmarks:
// physically valid, with nothing aligned by accident.
//
//   parents    a chain (parent i − 1), or each joint's parent drawn from the
//              world and the joints before it (branching, several roots)
//   joints     revolute or prismatic, a random unit axis, a random origin
//              rotation and an origin within ±0.5 m per coordinate
//   bodies     mass 0.2..3 kg, centre of mass within ±0.2 m per coordinate,
//              inertia R diag(I1, I2, I3) Rᵀ with a random rotation R (so with
//              off-diagonal terms) and principal moments I1 = d2 + d3,
//              I2 = d1 + d3, I3 = d1 + d2 from second moments d ∈ 0.002..0.05 kg·m²
//              (so the triangle inequality holds)
//   gravity    9.81 m/s² in a random direction
// RandomFloatingTree: the same joints and bodies hung from a floating base
// (joints with parent −1 on it), whose body is drawn as the others are.

#include <Eigen/Geometry>
#include <random>
#include <string>

#include "plant/rigid_tree.hpp"

namespace lagrange {

struct RandomTreeOptions {
  int bodies = 7;
  bool chain = false;               // every parent the joint before; else random branching
  double prismatic_fraction = 0.3;  // chance that a joint is prismatic
};

inline Eigen::Vector3d RandomUnitVector(std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
  } while (v.norm() < 1e-3);
  return v.normalized();
}

inline Eigen::Matrix3d RandomRotation(std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Quaterniond r;
  do {
    r = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng));
  } while (r.norm() < 1e-3);
  return r.normalized().toRotationMatrix();
}

inline RigidBody RandomRigidBody(std::mt19937& rng) {
  std::uniform_real_distribution<double> com(-0.2, 0.2), mass(0.2, 3.0), moment(0.002, 0.05);
  RigidBody b;
  b.mass = mass(rng);
  b.com = Eigen::Vector3d(com(rng), com(rng), com(rng));
  const double d1 = moment(rng), d2 = moment(rng), d3 = moment(rng);
  const Eigen::Matrix3d R = RandomRotation(rng);
  b.inertia = R * Eigen::Vector3d(d2 + d3, d1 + d3, d1 + d2).asDiagonal() * R.transpose();
  b.inertia = 0.5 * (b.inertia + b.inertia.transpose()).eval();
  return b;
}

inline RigidTree RandomRigidTree(const RandomTreeOptions& options, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0), offset(-0.5, 0.5);
  RigidTree tree;
  for (int i = 0; i < options.bodies; ++i) {
    TreeJoint j;
    j.name = "j";
    j.name += std::to_string(i);
    j.type = unit(rng) < options.prismatic_fraction ? JointType::kPrismatic : JointType::kRevolute;
    j.parent = options.chain ? i - 1 : std::uniform_int_distribution<int>(-1, i - 1)(rng);
    j.position = Eigen::Vector3d(offset(rng), offset(rng), offset(rng));
    j.rotation = RandomRotation(rng);
    j.axis = RandomUnitVector(rng);
    tree.joints.push_back(j);
    tree.bodies.push_back(RandomRigidBody(rng));
  }
  tree.gravity = kStandardGravity * RandomUnitVector(rng);
  return tree;
}

// options.bodies joints (0: a lone free body) on a random floating base.
inline RigidTree RandomFloatingTree(const RandomTreeOptions& options, std::mt19937& rng) {
  RigidTree tree = options.bodies > 0 ? RandomRigidTree(options, rng) : RigidTree{};
  tree.floating_base = true;
  tree.base = RandomRigidBody(rng);
  tree.gravity = kStandardGravity * RandomUnitVector(rng);
  return tree;
}
// Every other joint (1, 3, ...) made a mimic of an even one, which stays a
// degree of freedom: multiplier within ±2, offset within ±0.5.
inline void AddRandomMimics(RigidTree& tree, std::mt19937& rng) {
  std::uniform_real_distribution<double> multiplier(-2.0, 2.0), offset(-0.5, 0.5);
  for (int i = 1; i < tree.num_joints(); i += 2) {
    std::uniform_int_distribution<int> followed(0, (tree.num_joints() - 1) / 2);
    tree.joints[i].mimic = 2 * followed(rng);
    tree.joints[i].multiplier = multiplier(rng);
    tree.joints[i].offset = offset(rng);
  }
}

// `bodies` joints, branching, on a random floating base.
inline RigidTree RandomFloatingTree(int bodies, std::mt19937& rng) {
  RandomTreeOptions options;
  options.bodies = bodies;
  return RandomFloatingTree(options, rng);
}

}  // namespace lagrange
