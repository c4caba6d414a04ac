#pragma once
// The fastest a named frame of a RigidTree (plant/rigid_tree.hpp) can move
// when each degree of freedom's speed is bounded, |qd_d| <= v_d: an upper
// bound, over every configuration, on the frame origin's linear speed ‖ṗ‖
// (m/s) and its angular speed ‖ω‖ (rad/s), (ṗ, ω) = J(q) qd
// (plant/kinematics.hpp). A twist above it is one no joint velocity within
// the limits produces anywhere; configure-time, O(depth).
//
// Each joint j that carries the frame adds its column of J times its speed
// |s_j| v_d (d its degree of freedom, s_j a mimic's multiplier, else 1):
//   revolute   ω += ẑ_j q̇_j,  ṗ += ẑ_j × (p − o_j) q̇_j   ⇒  ‖ω‖ <= Σ |s_j| v_d,  ‖ṗ‖ <= Σ |s_j| v_d ρ_j
//   prismatic  ṗ += ẑ_j q̇_j                              ⇒  ‖ṗ‖ <= Σ |s_j| v_d
// where ρ_j >= ‖p − o_j‖ at every configuration: the lengths of the fixed
// offsets from joint j to the frame (the origins of the joints after it and
// the frame's placement) plus the largest travel of each prismatic joint
// between them, |s_j| max(|lower_d|, |upper_d|) + |offset_j| (rotations keep
// lengths: the triangle inequality). A joint of speed 0 adds nothing; a speed,
// or a travel it multiplies, without a bound (+inf) makes the bound +inf.
// A frame on the world has 0, 0.

#include <limits>

#include "plant/rigid_tree.hpp"
#include "plant/types.hpp"

namespace lagrange {

struct FrameSpeedBound {
  double linear = std::numeric_limits<double>::infinity();   // m/s
  double angular = std::numeric_limits<double>::infinity();  // rad/s
};

// `frame`: an index into tree.frames; velocity_limits, lower, upper (n, the
// degrees of freedom's, q's order): v_d >= 0 (+inf: none), position limits
// (±inf: none; only prismatic joints' are read).
FrameSpeedBound MaxFrameSpeed(const RigidTree& tree, int frame, const VectorXd& velocity_limits, const VectorXd& lower,
                              const VectorXd& upper);

}  // namespace lagrange
