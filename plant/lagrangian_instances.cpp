// The Lagrangian path of every plant type, compiled here once (the nested
// duals of the derivatives are the project's heaviest instantiations: one
// translation unit keeps their compile time in one place). A new plant type
// that uses LagrangianDynamics adds its line below.

#include "plant/arm2.hpp"
#include "plant/cartpole.hpp"
#include "plant/lagrangian_derivatives.hpp"
#include "plant/pendulum.hpp"
#include "plant/recursive_dynamics.hpp"
#include "plant/rigid_tree.hpp"

namespace lagrange {

template class LagrangianDynamics<Pendulum>;
template class LagrangianDynamics<Arm2>;
template class LagrangianDynamics<CartPole>;
template class LagrangianDynamics<PlanarChain>;
template class LagrangianDynamics<RigidTree>;

}  // namespace lagrange
