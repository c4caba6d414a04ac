#include "plant/chain.hpp"

namespace lagrange {

PlanarChain ToPlanarChain(const ChainParams& p) {
  PlanarChain chain;
  chain.g = p.g;
  for (int i = 0; i < p.num_links(); ++i) {
    const ChainLink& link = p.links[i];
    const double along = i == 0 ? 0.0 : p.links[i - 1].L;
    chain.joints.push_back({link.joint, {along, 0.0}, i == 0 ? p.base_angle : 0.0});
    chain.bodies.push_back({link.m, {link.com_offset(), 0.0}, link.inertia()});
  }
  return chain;
}

}  // namespace lagrange
