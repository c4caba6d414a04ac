#include "plant/dynamics.hpp"

#include <cmath>
#include <utility>

namespace lagrange {

DynamicsData::DynamicsData(const Dynamics& model)
    : model_(&model),
      M_(model.num_dofs(), model.num_dofs()),
      term_(model.num_dofs()),
      llt_(model.num_dofs()),
      unused_a_(model.num_dofs(), model.num_dofs()),
      unused_b_(model.num_dofs(), model.num_dofs()),
      zeros_(VectorXd::Zero(model.num_dofs())),
      rows_(3 * model.num_dofs(), model.num_dofs()) {}

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

namespace {

// M = L Lᵀ into L's lower triangle (n x n, column-major; M's upper triangle is
// not read). A matrix that is not positive definite gives NaN, which the
// callers' finiteness checks report.
void Cholesky(const MatRef& M, double* L, int n) {
  for (int j = 0; j < n; ++j) {
    double d = M(j, j);
    for (int k = 0; k < j; ++k) d -= L[j + k * n] * L[j + k * n];
    const double ljj = std::sqrt(d);
    L[j + j * n] = ljj;
    const double inv = 1.0 / ljj;
    for (int i = j + 1; i < n; ++i) {
      double x = M(i, j);
      for (int k = 0; k < j; ++k) x -= L[i + k * n] * L[j + k * n];
      L[i + j * n] = x * inv;
    }
  }
}

// X = (L Lᵀ)⁻¹ B in place for m right-hand sides stored one system row per
// column of `rows` (m x n, column-major: row i of B is rows[i·m .. i·m + m)),
// so every update is a contiguous axpy over the m sides.
void CholeskySolveRows(const double* L, int n, double* rows, int m) {
  for (int i = 0; i < n; ++i) {  // L Y = B
    double* yi = rows + i * m;
    for (int k = 0; k < i; ++k) {
      const double l = L[i + k * n];
      const double* yk = rows + k * m;
      for (int c = 0; c < m; ++c) yi[c] -= l * yk[c];
    }
    const double inv = 1.0 / L[i + i * n];
    for (int c = 0; c < m; ++c) yi[c] *= inv;
  }
  for (int i = n - 1; i >= 0; --i) {  // Lᵀ X = Y
    double* xi = rows + i * m;
    for (int k = i + 1; k < n; ++k) {
      const double l = L[k + i * n];
      const double* xk = rows + k * m;
      for (int c = 0; c < m; ++c) xi[c] -= l * xk[c];
    }
    const double inv = 1.0 / L[i + i * n];
    for (int c = 0; c < m; ++c) xi[c] *= inv;
  }
}

}  // namespace

// ID(q, qd, FD(q, qd, tau)) = tau differentiated: ∂ID/∂x + M ∂FD/∂x = 0 for
// x = q, qd, and M ∂FD/∂tau = I. One Cholesky factorisation of M, then all
// 3n right-hand sides [I, −∂tau/∂q, −∂tau/∂qd] solved together (2n without
// the Coriolis term, whose ∂tau/∂qd is zero): O(n³), written out for small n,
// where a general library's blocking costs more than the arithmetic.
void Dynamics::ComputeForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                                 DynamicsTerms terms, VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd,
                                                 MatRef dqdd_dtau) const {
  DynamicsData& d = Checked(data, q, qd, tau, qdd, dqdd_dq, dqdd_dqd, dqdd_dtau);
  const StageCounts counts = d.counts_;
  ComputeForwardDynamics(d, q, qd, tau, terms, qdd);
  ComputeInverseDynamicsDerivatives(d, q, qd, qdd, terms, dqdd_dq, dqdd_dqd, dqdd_dtau);
  d.counts_ = counts;
  CountTerms(d, terms);
  const int n = num_dofs();
  const int m = terms.coriolis ? 3 * n : 2 * n;
  Cholesky(dqdd_dtau, d.M_.data(), n);
  double* rows = d.rows_.data();
  for (int i = 0; i < n; ++i) {
    double* r = rows + i * m;
    for (int c = 0; c < n; ++c) {
      r[c] = i == c ? 1.0 : 0.0;
      r[n + c] = -dqdd_dq(i, c);
      if (terms.coriolis) r[2 * n + c] = -dqdd_dqd(i, c);
    }
  }
  CholeskySolveRows(d.M_.data(), n, rows, m);
  for (int i = 0; i < n; ++i) {
    const double* r = rows + i * m;
    for (int c = 0; c < n; ++c) {
      dqdd_dtau(i, c) = r[c];
      dqdd_dq(i, c) = r[n + c];
      dqdd_dqd(i, c) = terms.coriolis ? r[2 * n + c] : 0.0;
    }
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

void Dynamics::TwoJointForwardDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                                  DynamicsTerms terms, VecRef qdd, MatRef dqdd_dq, MatRef dqdd_dqd,
                                                  MatRef dqdd_dtau) const {
  Checked(data, q, qd, tau, qdd, dqdd_dq, dqdd_dqd, dqdd_dtau);
  eigen_assert(num_dofs() == 2 && "two joints");
  const StageCounts counts = SavedCounts(data);
  ComputeForwardDynamics(data, q, qd, tau, terms, qdd);
  Eigen::Matrix2d dq, dqd, M;
  ComputeInverseDynamicsDerivatives(data, q, qd, qdd, terms, dq, dqd, M);
  RestoreCounts(data, counts);
  CountTerms(data, terms);
  const double inv_det = 1.0 / (M(0, 0) * M(1, 1) - M(0, 1) * M(0, 1));
  Eigen::Matrix2d Minv;
  Minv << M(1, 1) * inv_det, -M(0, 1) * inv_det, -M(0, 1) * inv_det, M(0, 0) * inv_det;
  dqdd_dtau = Minv;
  dqdd_dq.noalias() = -Minv * dq;
  dqdd_dqd.noalias() = -Minv * dqd;
}

}  // namespace lagrange
