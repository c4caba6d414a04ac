#pragma once
// Eigenvalues of a dense matrix, computed in one translation unit.
//
// Eigen's eigensolvers are heavy templates (Householder tridiagonalization,
// Hessenberg and real Schur forms): every file that names one compiles it
// again, in every build tree. Configure-time checks and the tests call these
// instead, so the solvers are compiled once, here.

#include <Eigen/Core>

#include "plant/types.hpp"

namespace lagrange {

// Eigenvalues (n) of a symmetric X (n x n), ascending; only X's lower
// triangle is read (Eigen::SelfAdjointEigenSolver, eigenvalues only).
VectorXd SymmetricEigenvalues(const MatrixXd& X);

// Eigenvalues (n), complex, of a square A (n x n) (Eigen::EigenSolver,
// eigenvalues only; in the order Eigen's real Schur form gives them).
Eigen::VectorXcd Eigenvalues(const MatrixXd& A);

// Eigenvalues (6), ascending, of a symmetric 6 x 6 X, and with `vectors` its unit eigenvectors as columns in the
// same order; only X's lower triangle is read (Eigen::SelfAdjointEigenSolver). Fixed size: allocates nothing (the
// task-space laws and the stance law call them every tick).
void SymmetricEigen6(const Eigen::Matrix<double, 6, 6>& X, Eigen::Matrix<double, 6, 1>& values);
void SymmetricEigen6(const Eigen::Matrix<double, 6, 6>& X, Eigen::Matrix<double, 6, 1>& values,
                     Eigen::Matrix<double, 6, 6>& vectors);

// A symmetric 3 x 3 X as λ0 1 + a aᵀ + b bᵀ with λ0 its least eigenvalue,
// a = √(λ1 − λ0) u1 and b = √(λ2 − λ0) u2 (u the unit eigenvectors of the
// ascending eigenvalues λ): then R X Rᵀ = λ0 1 + (R a)(R a)ᵀ + (R b)(R b)ᵀ
// for a rotation R, in 30 multiplications instead of 45.
struct SymmetricRankTwo {
  double lambda0 = 0.0;
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::Zero();
};
SymmetricRankTwo SymmetricRankTwoOf(const Eigen::Matrix3d& X);

}  // namespace lagrange
