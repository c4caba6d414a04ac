#include "plant/frame_speed.hpp"

#include <algorithm>
#include <cmath>

namespace lagrange {

FrameSpeedBound MaxFrameSpeed(const RigidTree& tree, int frame, const VectorXd& velocity_limits, const VectorXd& lower,
                              const VectorXd& upper) {
  const TreeFrame& f = tree.frames[static_cast<std::size_t>(frame)];
  FrameSpeedBound bound{0.0, 0.0};
  double reach = f.position.norm();  // ρ: from the current joint's origin to the frame's, at most
  for (int j = f.body; j >= 0; j = tree.joints[static_cast<std::size_t>(j)].parent) {
    const TreeJoint& joint = tree.joints[static_cast<std::size_t>(j)];
    const RigidTree::JointMap map = tree.MapOf(j);
    const double speed = std::abs(map.scale) * velocity_limits[map.dof];  // |q̇_j| at most
    if (joint.type == JointType::kPrismatic) {
      if (speed > 0.0) bound.linear += speed;
      const double travel = std::max(std::abs(lower[map.dof]), std::abs(upper[map.dof]));
      reach += std::abs(map.scale) * travel + std::abs(map.offset);
    } else if (speed > 0.0) {
      bound.angular += speed;
      if (reach > 0.0) bound.linear += speed * reach;  // (an unbounded speed at the frame's own origin adds none)
    }
    reach += joint.position.norm();  // on to the parent's joint, through this joint's placement
  }
  return bound;
}

}  // namespace lagrange
