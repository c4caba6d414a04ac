#include "plant/mimic_dynamics.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace lagrange {

struct MimicDynamics::Data final : DynamicsData {
  Data(const MimicDynamics& model, std::unique_ptr<DynamicsData> free_data, int joints)
      : DynamicsData(model),
        free(std::move(free_data)),
        q(joints),
        qd(joints),
        x(joints),
        A(joints, joints),
        B(joints, joints),
        C(joints, joints) {}
  std::unique_ptr<DynamicsData> free;  // the free tree's data
  VectorXd q, qd, x;                   // (num_joints) q_j, qd_j, a joint-space result (or qdd_j)
  MatrixXd A, B, C;                    // (num_joints²) joint-space matrices
};

MimicDynamics::MimicDynamics(const RigidTree& tree, std::shared_ptr<const Dynamics> free)
    : Dynamics(tree.joint_types()), free_(std::move(free)) {
  if (auto error = ValidateRigidTree(tree)) throw std::invalid_argument("MimicDynamics: " + *error);
  if (!tree.has_mimics()) throw std::invalid_argument("MimicDynamics: a tree without mimic joints");
  if (!free_ || free_->num_dofs() != tree.num_joints()) {
    throw std::invalid_argument("MimicDynamics: expected the dynamics of the tree's " +
                                std::to_string(tree.num_joints()) + " joints, each free");
  }
  for (int i = 0; i < tree.num_joints(); ++i) maps_.push_back(tree.MapOf(i));
}

std::unique_ptr<DynamicsData> MimicDynamics::MakeData() const {
  return std::make_unique<Data>(*this, free_->MakeData(), free_->num_dofs());
}

void MimicDynamics::ExpandPosition(Data& d, ConstVecRef q) const {
  for (std::size_t i = 0; i < maps_.size(); ++i) {
    d.q[static_cast<Eigen::Index>(i)] = maps_[i].scale * q[maps_[i].dof] + maps_[i].offset;
  }
}

void MimicDynamics::Expand(Data& d, ConstVecRef q, ConstVecRef qd) const {
  ExpandPosition(d, q);
  for (std::size_t i = 0; i < maps_.size(); ++i) d.qd[static_cast<Eigen::Index>(i)] = maps_[i].scale * qd[maps_[i].dof];
}

void MimicDynamics::Reduce(ConstVecRef x_joints, VecRef out) const {
  out.setZero();
  for (std::size_t i = 0; i < maps_.size(); ++i) out[maps_[i].dof] += maps_[i].scale * x_joints[static_cast<Eigen::Index>(i)];
}

void MimicDynamics::Reduce(const MatrixXd& A_joints, MatRef out) const {
  out.setZero();
  for (std::size_t c = 0; c < maps_.size(); ++c) {
    for (std::size_t r = 0; r < maps_.size(); ++r) {
      out(maps_[r].dof, maps_[c].dof) +=
          maps_[r].scale * maps_[c].scale * A_joints(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
    }
  }
}

void MimicDynamics::ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const {
  Data& d = Checked<Data>(data, q, M);
  ExpandPosition(d, q);
  free_->ComputeMassMatrix(*d.free, d.q, d.A);
  Reduce(d.A, M);
}

void MimicDynamics::ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const {
  Data& d = Checked<Data>(data, q, qd, C);
  Expand(d, q, qd);
  free_->ComputeCoriolisMatrix(*d.free, d.q, d.qd, d.A);
  Reduce(d.A, C);
}

void MimicDynamics::ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const {
  Data& d = Checked<Data>(data, q, qd, c);
  Expand(d, q, qd);
  free_->ComputeCoriolisForce(*d.free, d.q, d.qd, d.x);
  Reduce(d.x, c);
}

void MimicDynamics::ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const {
  Data& d = Checked<Data>(data, q, G);
  ExpandPosition(d, q);
  free_->ComputeGravityForce(*d.free, d.q, d.x);
  Reduce(d.x, G);
}

void MimicDynamics::ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                 VecRef dTdq) const {
  Data& d = Checked<Data>(data, q, qd, dTdq);
  Expand(d, q, qd);
  free_->ComputeKineticEnergyGradient(*d.free, d.q, d.qd, d.x);
  Reduce(d.x, dTdq);
}

double MimicDynamics::ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const {
  Data& d = Checked<Data>(data, q, qd);
  Expand(d, q, qd);
  return free_->ComputeKineticEnergy(*d.free, d.q, d.qd);
}

void MimicDynamics::ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                      ConstVecRef qdd, DynamicsTerms terms, MatRef dtau_dq,
                                                      MatRef dtau_dqd, MatRef dtau_dqdd) const {
  Data& d = Checked<Data>(data, q, qd, qdd, dtau_dq, dtau_dqd, dtau_dqdd);
  CountTerms(d, terms);
  Expand(d, q, qd);
  for (std::size_t i = 0; i < maps_.size(); ++i) d.x[static_cast<Eigen::Index>(i)] = maps_[i].scale * qdd[maps_[i].dof];
  free_->ComputeInverseDynamicsDerivatives(*d.free, d.q, d.qd, d.x, terms, d.A, d.B, d.C);
  Reduce(d.A, dtau_dq);
  Reduce(d.B, dtau_dqd);
  Reduce(d.C, dtau_dqdd);
}

void MimicDynamics::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  Data& d = Checked<Data>(data, q, dG_dq);
  ExpandPosition(d, q);
  free_->ComputeGravityDerivatives(*d.free, d.q, d.A);
  Reduce(d.A, dG_dq);
}

double MimicDynamics::ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const {
  Data& d = Checked<Data>(data, q);
  ExpandPosition(d, q);
  return free_->ComputePotentialEnergy(*d.free, d.q);
}

}  // namespace lagrange
