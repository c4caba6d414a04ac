#include "controllers/lqr.hpp"

#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "plant/eigenvalues.hpp"

namespace lagrange {
namespace {

bool FiniteSymmetric(const MatrixXd& X) {
  return X.rows() == X.cols() && X.allFinite() && (X - X.transpose()).norm() <= kLqrWeightTolerance * X.norm();
}

// Smallest eigenvalue of the symmetric part; X is square.
double MinEigenvalue(const MatrixXd& X) {
  if (X.size() == 0) return 0.0;
  const MatrixXd symmetric = 0.5 * (X + X.transpose());
  return SymmetricEigenvalues(symmetric).minCoeff();
}

}  // namespace

std::optional<std::string> CheckLqrWeights(const MatrixXd& Q, const MatrixXd& R) {
  if (!FiniteSymmetric(Q) || MinEigenvalue(Q) < -kLqrWeightTolerance * Q.norm()) {
    return std::string("Q: expected a symmetric positive semi-definite matrix");
  }
  if (R.size() == 0 || !FiniteSymmetric(R) || MinEigenvalue(R) <= kLqrWeightTolerance * R.norm()) {
    return std::string("R: expected a symmetric positive definite matrix");
  }
  return std::nullopt;
}

LqrResult LinearQuadraticRegulator(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q, const MatrixXd& R) {
  const Eigen::Index n = A.rows(), m = B.cols();
  if (A.cols() != n || B.rows() != n || Q.rows() != n || Q.cols() != n || R.rows() != m || R.cols() != m) {
    throw std::invalid_argument("LQR: expected A (n x n), B (n x m), Q (n x n), R (m x m)");
  }
  if (auto err = CheckLqrWeights(Q, R)) throw std::invalid_argument(*err);

  const MatrixXd Rinv_Bt = R.ldlt().solve(B.transpose());
  MatrixXd Z(2 * n, 2 * n);
  Z << A, -B * Rinv_Bt, -Q, -A.transpose();
  // Newton iteration for sign(H): Z ← (c Z + (c Z)⁻¹) / 2, c = |det Z|^(−1/2n).
  bool converged = false;
  for (int it = 0; it < 100; ++it) {
    Eigen::PartialPivLU<MatrixXd> lu(Z);
    const double logdet = lu.matrixLU().diagonal().cwiseAbs().array().log().sum();
    if (!std::isfinite(logdet)) break;  // H has an eigenvalue on the imaginary axis
    const double c = std::exp(-logdet / static_cast<double>(2 * n));
    const MatrixXd next = 0.5 * (c * Z + lu.inverse() / c);
    const double change = (next - Z).norm();
    Z = next;
    if (!Z.allFinite()) break;
    if (change <= 1e-13 * Z.norm()) {
      converged = true;
      break;
    }
  }
  if (!converged) throw std::invalid_argument("LQR: no stabilizing solution ((A, B) not stabilizable?)");

  // (sign(H) + I) [I; S] = 0  =>  [W12; W22 + I] S = −[W11 + I; W21].
  const MatrixXd I = MatrixXd::Identity(n, n);
  MatrixXd lhs(2 * n, n), rhs(2 * n, n);
  lhs << Z.topRightCorner(n, n), Z.bottomRightCorner(n, n) + I;
  rhs << Z.topLeftCorner(n, n) + I, Z.bottomLeftCorner(n, n);
  MatrixXd S = lhs.colPivHouseholderQr().solve(-rhs);
  S = 0.5 * (S + S.transpose());

  LqrResult result{Rinv_Bt * S, S};
  const MatrixXd residual = A.transpose() * S + S * A - S * B * result.K + Q;
  const MatrixXd closed_loop = A - B * result.K;
  const Eigen::VectorXcd poles = Eigenvalues(closed_loop);
  if (!S.allFinite() || residual.norm() > 1e-8 * std::max(1.0, S.norm() * A.norm() + Q.norm()) ||
      poles.real().maxCoeff() >= 0.0) {
    throw std::invalid_argument("LQR: no stabilizing solution ((A, B) not stabilizable?)");
  }
  return result;
}

LqrResult DiscreteLinearQuadraticRegulator(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q,
                                           const MatrixXd& R) {
  const Eigen::Index n = A.rows(), m = B.cols();
  if (A.cols() != n || B.rows() != n || Q.rows() != n || Q.cols() != n || R.rows() != m || R.cols() != m) {
    throw std::invalid_argument("LQR: expected A (n x n), B (n x m), Q (n x n), R (m x m)");
  }
  if (auto err = CheckLqrWeights(Q, R)) throw std::invalid_argument(*err);
  const MatrixXd I = MatrixXd::Identity(n, n);
  MatrixXd Ak = A, Gk = B * R.ldlt().solve(B.transpose()), Hk = Q;
  bool converged = false;
  for (int it = 0; it < 100 && !converged; ++it) {
    const Eigen::PartialPivLU<MatrixXd> lu(I + Gk * Hk);
    const MatrixXd V1 = lu.solve(Ak), V2 = lu.solve(Gk);
    const MatrixXd H_next = Hk + Ak.transpose() * Hk * V1;
    Gk = Gk + Ak * V2 * Ak.transpose();
    Ak = Ak * V1;
    const double change = (H_next - Hk).norm();
    Hk = 0.5 * (H_next + H_next.transpose());
    Gk = 0.5 * (Gk + Gk.transpose());
    if (!Hk.allFinite() || !Gk.allFinite() || !Ak.allFinite()) break;
    converged = change <= 1e-13 * Hk.norm();
  }
  const MatrixXd& S = Hk;
  const MatrixXd BtS = B.transpose() * S;
  LqrResult result{(R + BtS * B).ldlt().solve(BtS * A), S};
  const MatrixXd residual = A.transpose() * S * A - S - A.transpose() * S * B * result.K + Q;
  const MatrixXd closed_loop = A - B * result.K;
  const Eigen::VectorXcd poles = Eigenvalues(closed_loop);
  if (!converged || !S.allFinite() || residual.norm() > 1e-8 * std::max(1.0, S.norm() * A.norm() * A.norm() + Q.norm()) ||
      poles.cwiseAbs().maxCoeff() >= 1.0) {
    throw std::invalid_argument("LQR: no stabilizing solution ((A, B) not stabilizable?)");
  }
  return result;
}

namespace {

// u0 = G(q0) on the actuated joints (m), and the full tau0 (n) with it; throws
// when q0 is not an equilibrium of the unactuated joints.
VectorXd EquilibriumForce(const Dynamics& model, DynamicsData& data, const VectorXd& q0,
                          const std::vector<int>& actuated, VectorXd& u0) {
  const int n = model.num_dofs();
  VectorXd G(n), tau0 = VectorXd::Zero(n);
  model.ComputeGravityForce(data, q0, G);
  u0.resize(static_cast<Eigen::Index>(actuated.size()));
  for (std::size_t k = 0; k < actuated.size(); ++k) {
    tau0[actuated[k]] = G[actuated[k]];
    u0[static_cast<Eigen::Index>(k)] = G[actuated[k]];
  }
  for (int i = 0; i < n; ++i) {
    const bool is_actuated = std::find(actuated.begin(), actuated.end(), i) != actuated.end();
    if (!is_actuated && std::abs(G[i]) > 1e-9 * std::max(1.0, G.norm())) {
      throw std::invalid_argument("the linearisation point is not an equilibrium of unactuated joint " +
                                  std::to_string(i));
    }
  }
  return tau0;
}

}  // namespace

LinearModel Linearize(const Dynamics& model, const VectorXd& q0, const std::vector<int>& actuated) {
  const std::unique_ptr<DynamicsData> data = model.MakeData();
  const int n = model.num_dofs();
  const int m = static_cast<int>(actuated.size());
  LinearModel lin{MatrixXd::Zero(2 * n, 2 * n), MatrixXd::Zero(2 * n, m), VectorXd(m)};
  const VectorXd tau0 = EquilibriumForce(model, *data, q0, actuated, lin.u0);
  VectorXd qdd(n);
  MatrixXd dq(n, n), dqd(n, n), dtau(n, n);
  model.ComputeForwardDynamicsDerivatives(*data, q0, VectorXd::Zero(n), tau0, DynamicsTerms{}, qdd, dq, dqd, dtau);
  lin.A.topRightCorner(n, n).setIdentity();
  lin.A.bottomLeftCorner(n, n) = dq;
  lin.A.bottomRightCorner(n, n) = dqd;
  for (int k = 0; k < m; ++k) lin.B.block(n, k, n, 1) = dtau.col(actuated[static_cast<std::size_t>(k)]);
  return lin;
}

LinearModel LinearizeStep(std::shared_ptr<const Dynamics> model, const VectorXd& q0,
                          const std::vector<int>& actuated, IntegratorType type, int substeps, double period) {
  if (model == nullptr) throw std::invalid_argument("LinearizeStep: expected a model, got null");
  if (const char* reason = NoStepDerivativesReason(type)) throw std::invalid_argument(reason);
  if (substeps < 1 || !(period > 0.0)) throw std::invalid_argument("LinearizeStep: expected substeps >= 1, period > 0");
  const int n = model->num_dofs();
  const int m = static_cast<int>(actuated.size());
  LinearModel lin{MatrixXd(2 * n, 2 * n), MatrixXd(2 * n, m), VectorXd(m)};
  const VectorXd tau0 = EquilibriumForce(*model, *model->MakeData(), q0, actuated, lin.u0);
  PlantModel plant(std::move(model), EffectsConfig{});
  StepDerivatives step(type, n);
  MatrixXd B(2 * n, n);
  step.Advance(plant, 0.0, period, substeps, q0, VectorXd::Zero(n), tau0, lin.A, B);
  for (int k = 0; k < m; ++k) lin.B.col(k) = B.col(actuated[static_cast<std::size_t>(k)]);
  return lin;
}

StateFeedbackController::StateFeedbackController(std::string name, std::vector<JointType> joints,
                                                 VectorXd torque_limits, std::vector<int> actuated, MatrixXd K,
                                                 VectorXd u_eq)
    : Controller(std::move(joints), std::move(torque_limits)),
      name_(std::move(name)),
      actuated_(std::move(actuated)),
      K_(std::move(K)),
      u_eq_(std::move(u_eq)),
      x_(2 * num_dofs()),
      u_(actuated_.size()) {
  if (K_.rows() != static_cast<Eigen::Index>(actuated_.size()) || K_.cols() != 2 * num_dofs() ||
      u_eq_.size() != K_.rows()) {
    throw std::invalid_argument("state feedback: K must be (actuated x 2n) and u_eq (actuated)");
  }
}

Gains StateFeedbackController::gains() const {
  const int n = num_dofs();
  if (actuated_.size() != 1) return {};
  return {K_.row(0).head(n).transpose(), K_.row(0).tail(n).transpose()};
}

void StateFeedbackController::ComputeLaw(double, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  const int n = num_dofs();
  for (int i = 0; i < n; ++i) {
    x_[i] = -Error(i, sp.q[i], q[i]);
    x_[n + i] = qd[i] - sp.qd[i];
  }
  u_ = u_eq_;
  u_.noalias() -= K_ * x_;
  tau.setZero();
  for (std::size_t k = 0; k < actuated_.size(); ++k) tau[actuated_[k]] = u_[static_cast<int>(k)];
}

}  // namespace lagrange
