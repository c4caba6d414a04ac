#pragma once
// n-link planar chain, revolute joints by default. Angles are relative like
// the arm's: q1 is link 1's angle from the direction `base_angle` (from +x,
// counter-clockwise; 0 by default, like the arm's q1), q_i is link i's angle
// relative to link i−1. A link's joint may instead be prismatic: q_i is then
// link i's slide (m) along the direction of link i−1 (of `base_angle` for the
// first), from where the revolute joint would sit. Each link has mass m,
// length L, centre-of-mass offset com along the link from its joint, and
// inertia I about its centre of mass; by default every link is a 1.0 kg,
// 0.5 m uniform rod (com = L/2, I = m L²/12).

#include <optional>
#include <vector>

#include "plant/rigid_tree.hpp"

namespace lagrange {

struct ChainLink {
  double m = 1.0;                          // kg
  double L = 0.5;                          // m
  std::optional<double> com;               // m from the joint along the link; default L/2
  std::optional<double> I;                 // kg·m² about the centre of mass; default m L²/12
  JointType joint = JointType::kRevolute;  // the joint that carries this link

  double com_offset() const { return com.value_or(0.5 * L); }
  double inertia() const { return I.value_or(m * L * L / 12.0); }
};

struct ChainParams {
  std::vector<ChainLink> links = std::vector<ChainLink>(2);
  double base_angle = 0.0;  // rad
  double g = kStandardGravity;

  int num_links() const { return static_cast<int>(links.size()); }
};

// The chain as a tree: joint "qi" of link i at the end of link i − 1 (the
// origin for the first, turned by base_angle), link i along its frame's x.
// Frames (z out of the plane): "link1" .. "linkn" at each link's joint, x
// along the link; "tip" at the last link's end.
RigidTree ToRigidTree(const ChainParams& p);

}  // namespace lagrange
