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

DynamicsData::DynamicsData(const Dynamics& model)
    : model_(&model),
      M_(model.num_dofs(), model.num_dofs()),
      term_(model.num_dofs()),
      llt_(model.num_dofs()),
      unused_a_(model.num_dofs(), model.num_dofs()),
      unused_b_(model.num_dofs(), model.num_dofs()),
      zeros_(VectorXd::Zero(model.num_dofs())) {}

Dynamics::Dynamics(std::vector<JointType> joints) : joints_(std::move(joints)) {}

std::unique_ptr<DynamicsData> Dynamics::MakeData() const {
  return std::unique_ptr<DynamicsData>(new DynamicsData(*this));
}

void Dynamics::ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                      DynamicsTerms terms, VecRef tau) const {
  DynamicsData& d = Checked(data, q, qd, qdd, tau);
  ComputeMassMatrix(d, q, d.M_);
  tau.noalias() = d.M_ * qdd;
  if (terms.coriolis) {
    CountCoriolis(d);
    ComputeCoriolisForce(d, q, qd, d.term_);
    tau += d.term_;
  }
  if (terms.gravity) {
    CountGravity(d);
    ComputeGravityForce(d, q, d.term_);
    tau += d.term_;
  }
}

void Dynamics::ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                      DynamicsTerms terms, VecRef qdd) const {
  DynamicsData& d = Checked(data, q, qd, tau, qdd);
  qdd = tau;
  if (terms.coriolis) {
    CountCoriolis(d);
    ComputeCoriolisForce(d, q, qd, d.term_);
    qdd -= d.term_;
  }
  if (terms.gravity) {
    CountGravity(d);
    ComputeGravityForce(d, q, d.term_);
    qdd -= d.term_;
  }
  ComputeMassMatrix(d, q, d.M_);
  d.llt_.compute(d.M_);
  d.llt_.solveInPlace(qdd);
}

// ID(q, qd, FD(q, qd, tau)) = tau differentiated: ∂ID/∂x + M ∂FD/∂x = 0 for
// x = q, qd, and M ∂FD/∂tau = I.
void Dynamics::ComputeForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                                 DynamicsTerms terms, VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd,
                                                 MatRef dqdd_dtau) const {
  DynamicsData& d = Checked(data, q, qd, tau, qdd, dqdd_dq, dqdd_dqd, dqdd_dtau);
  const StageCounts counts = d.counts_;
  ComputeForwardDynamics(d, q, qd, tau, terms, qdd);
  ComputeInverseDynamicsDerivatives(d, q, qd, qdd, terms, dqdd_dq, dqdd_dqd, dqdd_dtau);
  d.counts_ = counts;
  CountTerms(d, terms);
  d.llt_.compute(dqdd_dtau);
  dqdd_dtau.setIdentity();
  d.llt_.solveInPlace(dqdd_dtau);
  d.llt_.solveInPlace(dqdd_dq);
  dqdd_dq = -dqdd_dq;
  if (terms.coriolis) {
    d.llt_.solveInPlace(dqdd_dqd);
    dqdd_dqd = -dqdd_dqd;
  }
}

void Dynamics::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  DynamicsData& d = Checked(data, q, dG_dq);
  const StageCounts counts = d.counts_;  // G is not counted (as ComputeGravityForce)
  ComputeInverseDynamicsDerivatives(d, q, d.zeros_, d.zeros_, DynamicsTerms{.gravity = true, .coriolis = false}, dG_dq,
                                    d.unused_a_, d.unused_b_);
  d.counts_ = counts;
}

double Power(ConstVecRef qd, ConstVecRef tau) { return qd.dot(tau); }

}  // namespace lagrange
