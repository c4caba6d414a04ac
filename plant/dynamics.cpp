#include "plant/dynamics.hpp"

#include <utility>

#include "plant/enum_names.hpp"

namespace lagrange {

namespace {

constexpr EnumName<Method> kMethodNames[] = {
    {Method::kClosedForm, "closed-form"},
    {Method::kLagrangian, "lagrangian"},
    {Method::kRecursive, "recursive"},
};

}  // namespace

std::string_view ToString(Method method) { return NameOf(kMethodNames, method); }
std::optional<Method> ParseMethod(std::string_view name) { return ValueOf(kMethodNames, name); }
std::string MethodNames() { return NamesInWords(kMethodNames); }

Dynamics::Dynamics(std::vector<JointType> joints)
    : joints_(std::move(joints)), M_(num_dofs(), num_dofs()), term_(num_dofs()), llt_(num_dofs()) {}

void Dynamics::ComputeInverseDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms,
                                      VecRef tau) const {
  AssertSizes(q, qd, qdd, tau);
  ComputeMassMatrix(q, M_);
  tau.noalias() = M_ * qdd;
  if (terms.coriolis) {
    CountCoriolis();
    ComputeCoriolisForce(q, qd, term_);
    tau += term_;
  }
  if (terms.gravity) {
    CountGravity();
    ComputeGravityForce(q, term_);
    tau += term_;
  }
}

void Dynamics::ComputeForwardDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                                      VecRef qdd) const {
  AssertSizes(q, qd, tau, qdd);
  qdd = tau;
  if (terms.coriolis) {
    CountCoriolis();
    ComputeCoriolisForce(q, qd, term_);
    qdd -= term_;
  }
  if (terms.gravity) {
    CountGravity();
    ComputeGravityForce(q, term_);
    qdd -= term_;
  }
  ComputeMassMatrix(q, M_);
  llt_.compute(M_);
  llt_.solveInPlace(qdd);
}

double Power(ConstVecRef qd, ConstVecRef tau) { return qd.dot(tau); }

}  // namespace lagrange
