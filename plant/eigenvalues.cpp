#include "plant/eigenvalues.hpp"

#include <Eigen/Eigenvalues>

namespace lagrange {

VectorXd SymmetricEigenvalues(const MatrixXd& X) {
  return Eigen::SelfAdjointEigenSolver<MatrixXd>(X, Eigen::EigenvaluesOnly).eigenvalues();
}

Eigen::VectorXcd Eigenvalues(const MatrixXd& A) { return Eigen::EigenSolver<MatrixXd>(A, false).eigenvalues(); }

}  // namespace lagrange
