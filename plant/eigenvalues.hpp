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

}  // namespace lagrange
