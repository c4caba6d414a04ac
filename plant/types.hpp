#pragma once
// Vocabulary shared by the plant library.
//
// Symbols used throughout (n = num_dofs, SI units):
//   q    (n)     generalized positions: rad for revolute joints, m for prismatic joints
//   qd   (n)     generalized velocities: rad/s, m/s
//   qdd  (n)     generalized accelerations: rad/s², m/s²
//   tau  (n)     generalized forces: N·m for revolute joints, N for prismatic joints
//   M    (n x n) mass matrix, symmetric positive definite: kg·m², kg·m, kg
//   C    (n x n) Coriolis/centrifugal matrix from the Christoffel symbols of M
//   G    (n)     gravity generalized force dV/dq
//   T, V         kinetic and potential energy, J

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "base/vocabulary.hpp"  // kMaxDofs, kMaxContacts, Method and its names

namespace lagrange {

using Eigen::MatrixXd;
using Eigen::VectorXd;
// Arguments: writable views by value (cheap), read-only views by const
// reference (a by-value Ref<const T> carries an empty VectorXd for possible
// copies and destroys it on every call: measured at ~30 % of an RK4 step).
using VecRef = Eigen::Ref<VectorXd>;
using ConstVecRef = const Eigen::Ref<const VectorXd>&;
using MatRef = Eigen::Ref<MatrixXd>;

inline constexpr double kStandardGravity = 9.81;  // m/s², along −y

enum class JointType : std::uint8_t { kRevolute, kPrismatic };

// The dynamics terms a scene evaluates. A term that is off is never computed.
struct DynamicsTerms {
  bool gravity = true;   // G(q)
  bool coriolis = true;  // C(q, qd) qd
};

// How often each gated stage actually ran; a stage that is off never counts.
struct StageCounts {
  std::int64_t gravity = 0;
  std::int64_t coriolis = 0;
  std::int64_t damping = 0;
  std::int64_t friction = 0;
  std::int64_t limits = 0;
  std::int64_t saturation = 0;
  std::int64_t disturbance = 0;
};

}  // namespace lagrange
