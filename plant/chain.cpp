#include "plant/chain.hpp"

#include <string>
#include <utility>

namespace lagrange {

RigidTree ToRigidTree(const ChainParams& p) {
  RigidTree tree;
  tree.gravity = PlanarGravity(p.g);
  for (int i = 0; i < p.num_links(); ++i) {
    const ChainLink& link = p.links[i];
    const double along = i == 0 ? 0.0 : p.links[i - 1].L;
    std::string name = std::to_string(i + 1);  // "q1".., built in place: g++ 12 warns falsely on "q" + string
    name.insert(name.begin(), 'q');
    tree.joints.push_back(PlanarTreeJoint(std::move(name), link.joint, i - 1, along, 0.0, i == 0 ? p.base_angle : 0.0));
    tree.bodies.push_back(PlanarTreeBody(link.m, link.com_offset(), 0.0, link.inertia()));
    std::string frame = std::to_string(i + 1);  // "link1".., built in place as above
    frame.insert(0, "link");
    tree.frames.push_back(PlanarTreeFrame(std::move(frame), i, 0.0, 0.0, 0.0));
  }
  tree.frames.push_back(PlanarTreeFrame("tip", p.num_links() - 1, p.links.back().L, 0.0, 0.0));
  return tree;
}

}  // namespace lagrange
