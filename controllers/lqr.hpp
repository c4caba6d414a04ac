#pragma once
// Linear-quadratic regulation: design-time math (free functions returning
// result structs) and the state-feedback controller that uses it.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "controllers/controller.hpp"
#include "plant/integrators.hpp"

namespace lagrange {

struct LqrResult {
  MatrixXd K;  // (m x 2n) optimal gain, u = −K x
  MatrixXd S;  // (2n x 2n) stabilizing solution of the Riccati equation, cost-to-go xᵀ S x
};

// Relative tolerance of the weight checks below: an eigenvalue of Q down to
// −kLqrWeightTolerance·‖Q‖ counts as zero, one of R must exceed
// kLqrWeightTolerance·‖R‖, and ‖X − Xᵀ‖ <= kLqrWeightTolerance·‖X‖ is symmetric
// (‖·‖ the Frobenius norm). Round-off leaves the zero eigenvalues of a
// rank-deficient Q near ±1e-16·‖Q‖, far inside it.
inline constexpr double kLqrWeightTolerance = 1e-9;

// The one check of LQR weights, used by the scene validator and by
// LinearQuadraticRegulator: Q (k x k) finite, symmetric, positive
// semi-definite; R (m x m) finite, symmetric, positive definite. Returns
// "Q: expected ..." or "R: expected ...", or nullopt when they fit.
std::optional<std::string> CheckLqrWeights(const MatrixXd& Q, const MatrixXd& R);

// Continuous-time LQR for ẋ = A x + B u minimising ∫ xᵀQx + uᵀRu dt:
//   Aᵀ S + S A − S B R⁻¹ Bᵀ S + Q = 0,   K = R⁻¹ Bᵀ S.
// Solved by the matrix sign function of the Hamiltonian
//   H = [[A, −B R⁻¹ Bᵀ], [−Q, −Aᵀ]]
// (Newton iteration with determinant scaling); S spans the stable invariant
// subspace [I; S]. Throws std::invalid_argument when sizes disagree, when
// CheckLqrWeights refuses Q or R (with its message), or when no stabilizing
// solution exists (e.g. (A, B) not stabilizable).
LqrResult LinearQuadraticRegulator(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q, const MatrixXd& R);

// Discrete-time LQR for x⁺ = A x + B u minimising Σ xᵀQx + uᵀRu:
//   S = Aᵀ S A − Aᵀ S B (R + Bᵀ S B)⁻¹ Bᵀ S A + Q,   K = (R + Bᵀ S B)⁻¹ Bᵀ S A.
// Solved by the structure-preserving doubling algorithm (Chu, Fan and Lin
// 2005: A ← A (I + G H)⁻¹ A, G ← G + A (I + G H)⁻¹ G Aᵀ, H ← H + Aᵀ H (I + G H)⁻¹ A
// from G = B R⁻¹ Bᵀ, H = Q; H → S quadratically). With the same Q and R per
// step as the continuous cost per second, K tends to the continuous K as
// the step shrinks (a common factor h on Q and R does not change K). Throws
// std::invalid_argument as LinearQuadraticRegulator does; the closed loop's
// poles are inside the unit circle.
LqrResult DiscreteLinearQuadraticRegulator(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q,
                                           const MatrixXd& R);

struct LinearModel {
  MatrixXd A;   // (2n x 2n), state x = (q − q0, qd)
  MatrixXd B;   // (2n x m), inputs: the actuated joints' generalized forces
  VectorXd u0;  // (m) the actuated forces that hold q0 at rest: G(q0) on those joints
};

// Linearises qdd = M⁻¹ (tau − C qd − G) at (q0, qd = 0, tau = u0) with the
// model's exact derivatives (Dynamics::ComputeForwardDynamicsDerivatives):
// A = [[0, I], [∂qdd/∂q, ∂qdd/∂qd]], B = the actuated columns of [[0], [M⁻¹]].
// `actuated` lists the joints that take a force. Throws
// std::invalid_argument when q0 is not an equilibrium of the unactuated joints.
LinearModel Linearize(const Dynamics& model, const VectorXd& q0, const std::vector<int>& actuated);

// The same point through one tick of an integrator, for a discrete-time
// design: x⁺ = Φ(x, u) of `substeps` sub-steps of `type` over `period` s with
// u held (the tick's zero-order hold), A = ∂x⁺/∂x, B = ∂x⁺/∂u
// (StepDerivatives, plant/integrators.hpp; the model's dynamics with gravity
// and Coriolis, no other effect, as the continuous design). Throws
// std::invalid_argument as Linearize does, or with NoStepDerivativesReason.
LinearModel LinearizeStep(std::shared_ptr<const Dynamics> model, const VectorXd& q0,
                          const std::vector<int>& actuated, IntegratorType type, int substeps, double period);

// Law:    u = u_eq − K (x − x_d),  x − x_d = (wrap(q − q_d), qd − qd_d);
//         tau = u on the actuated joints, 0 on the others.
// Inputs: q, qd; setpoint (q_d, qd_d); q_d should stay near the
//         linearisation point (for a cart-pole: θ_d = π, any x_d).
// Output: tau (n).
// State:  none.
// K comes from LinearQuadraticRegulator at configure time; it has no
// adjustable gains.
class StateFeedbackController final : public Controller {
 public:
  StateFeedbackController(std::string name, std::vector<JointType> joints, VectorXd torque_limits,
                          std::vector<int> actuated, MatrixXd K, VectorXd u_eq);
  std::string_view name() const override { return name_; }
  const MatrixXd& K() const { return K_; }

  // With one actuated joint: K's row split as (kp, kd) = (K_q, K_qd), for reporting.
  Gains gains() const override;

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;

 private:
  std::string name_;
  std::vector<int> actuated_;
  MatrixXd K_;
  VectorXd u_eq_;
  VectorXd x_, u_;
};

}  // namespace lagrange
