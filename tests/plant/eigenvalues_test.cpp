// The eigenvalue helpers (plant/eigenvalues.hpp): known spectra back, the
// symmetric one ascending and reading the lower triangle only.

#include "plant/eigenvalues.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

namespace lagrange {
namespace {

constexpr double kSpectrumTolerance = 1e-12;

// A rotation by `angle` in the (i, j) plane of R^3.
MatrixXd PlaneRotation(int i, int j, double angle) {
  MatrixXd r = MatrixXd::Identity(3, 3);
  r(i, i) = r(j, j) = std::cos(angle);
  r(i, j) = -std::sin(angle);
  r(j, i) = std::sin(angle);
  return r;
}

TEST(Eigenvalues, SymmetricSpectrumComesBackAscendingFromAnyRotatedBasis) {
  const MatrixXd R = PlaneRotation(0, 1, 0.7) * PlaneRotation(1, 2, -1.3);
  const MatrixXd X = R * VectorXd{{3.0, -1.0, 2.0}}.asDiagonal() * R.transpose();
  const VectorXd eig = SymmetricEigenvalues(X);
  ASSERT_EQ(eig.size(), 3);
  EXPECT_NEAR(eig[0], -1.0, kSpectrumTolerance);
  EXPECT_NEAR(eig[1], 2.0, kSpectrumTolerance);
  EXPECT_NEAR(eig[2], 3.0, kSpectrumTolerance);
}

TEST(Eigenvalues, SymmetricSpectrumReadsTheLowerTriangleOnly) {
  MatrixXd X{{2.0, 0.0}, {1.0, 2.0}};  // the symmetric [[2, 1], [1, 2]] by its lower triangle: 1 and 3
  const VectorXd eig = SymmetricEigenvalues(X);
  EXPECT_NEAR(eig[0], 1.0, kSpectrumTolerance);
  EXPECT_NEAR(eig[1], 3.0, kSpectrumTolerance);
}

TEST(Eigenvalues, GeneralSpectrumHasTheCompanionMatrixsRootsAndRotationsImaginaryPair) {
  // Companion matrix of (s + 1)(s + 2)(s − 3) = s³ − 7s − 6.
  const MatrixXd companion{{0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}, {6.0, 7.0, 0.0}};
  const Eigen::VectorXcd roots = Eigenvalues(companion);
  ASSERT_EQ(roots.size(), 3);
  std::vector<double> real;
  for (const std::complex<double>& r : roots) {
    EXPECT_NEAR(r.imag(), 0.0, kSpectrumTolerance);
    real.push_back(r.real());
  }
  std::sort(real.begin(), real.end());
  EXPECT_NEAR(real[0], -2.0, kSpectrumTolerance);
  EXPECT_NEAR(real[1], -1.0, kSpectrumTolerance);
  EXPECT_NEAR(real[2], 3.0, kSpectrumTolerance);

  const double omega = 2.5;  // rad/s: ẋ = [[0, −ω], [ω, 0]] x turns at ω
  const Eigen::VectorXcd pair = Eigenvalues(MatrixXd{{0.0, -omega}, {omega, 0.0}});
  ASSERT_EQ(pair.size(), 2);
  for (const std::complex<double>& p : pair) {
    EXPECT_NEAR(p.real(), 0.0, kSpectrumTolerance);
    EXPECT_NEAR(std::abs(p.imag()), omega, kSpectrumTolerance);
  }
  EXPECT_NEAR(pair[0].imag() + pair[1].imag(), 0.0, kSpectrumTolerance);
}

}  // namespace
}  // namespace lagrange
