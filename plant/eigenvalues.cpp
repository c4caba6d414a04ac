#include "plant/eigenvalues.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace lagrange {

VectorXd SymmetricEigenvalues(const MatrixXd& X) {
  return Eigen::SelfAdjointEigenSolver<MatrixXd>(X, Eigen::EigenvaluesOnly).eigenvalues();
}

Eigen::VectorXcd Eigenvalues(const MatrixXd& A) { return Eigen::EigenSolver<MatrixXd>(A, false).eigenvalues(); }

void SymmetricEigen6(const Eigen::Matrix<double, 6, 6>& X, Eigen::Matrix<double, 6, 1>& values) {
  values = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(X, Eigen::EigenvaluesOnly).eigenvalues();
}

void SymmetricEigen6(const Eigen::Matrix<double, 6, 6>& X, Eigen::Matrix<double, 6, 1>& values,
                     Eigen::Matrix<double, 6, 6>& vectors) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(X);
  values = eig.eigenvalues();
  vectors = eig.eigenvectors();
}

SymmetricRankTwo SymmetricRankTwoOf(const Eigen::Matrix3d& X) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(X);
  const Eigen::Vector3d& l = eig.eigenvalues();
  return {l[0], std::sqrt(l[1] - l[0]) * eig.eigenvectors().col(1), std::sqrt(l[2] - l[0]) * eig.eigenvectors().col(2)};
}

}  // namespace lagrange
