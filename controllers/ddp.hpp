#pragma once
// Box-constrained differential dynamic programming in Gauss–Newton form
// (iLQR with control limits): the optimiser of model-predictive control.
//
// Problem, over a horizon of N knots of step dt; state x = (q, qd) (2n),
// control u (m): the forces of the actuated joints, S (n x m) puts them into
// tau (the others get 0):
//
//   minimise    J = Σ_{k<N} ℓ_k(x_k, u_k) + ℓ_N(x_N)
//   subject to  x_0 given,  x_{k+1} = Φ(x_k, S u_k),  lower <= u_k <= upper
//
//   ℓ_k = ½ Σ_i wq_i (q_i − q_ref,k,i)² + ½ Σ_i wqd_i (qd_i − qd_ref,k,i)² + ½ Σ_j wu_j (u_j − u_ref,k,j)²
//   ℓ_N = ½ Σ_i wqN_i (q_i − q_ref,N,i)² + ½ Σ_i wqdN_i (qd_i − qd_ref,N,i)²
//
// and, with a frame (DdpFrameCost), its pose error to the pose reference at
// every knot, the task-space controllers' e = (p_d − p, log(R_d Rᵀ))
// (controllers/task_trajectory.hpp, PoseError):
//   ℓ_k += ½ w_pos |p_d,k − p(q)|² + ½ w_rot |log(R_d,k R(q)ᵀ)|²   (w_posN, w_rotN at k = N)
// with the Gauss–Newton derivatives of the frame's Jacobian J (6 x n, rows
// linear then angular, world axes), W = diag(w_pos I₃, w_rot I₃):
//   ∂ℓ/∂q = −Jᵀ W e  (exact: eᵀ J_r⁻¹(e_R) = eᵀ for the log map)   ∂²ℓ/∂q² ≈ Jᵀ W J
//
// Φ is one tick of dt of the plant's own model (its Dynamics under the
// config's effects) through explicit Euler, semi-implicit Euler or RK4 in
// `substeps` sub-steps with tau held, and A_k = ∂Φ/∂x, B_k = ∂Φ/∂u its exact
// derivatives (StepDerivatives, plant/integrators.hpp). q − q_ref is the
// plain difference (a reference of π asks for π, not −π).
//
// One iteration at the nominal (x̄, ū), as Tassa, Mansard & Todorov,
// "Control-limited differential dynamic programming", ICRA 2014:
//   1. A_k, B_k along the nominal.
//   2. Backward pass from V_N = ℓ_N (Gauss–Newton: the dynamics' second
//      derivatives are left out, so every Q_uu is positive definite):
//        Q_x = ℓ_x + Aᵀ V_x'        Q_xx = ℓ_xx + Aᵀ V_xx' A
//        Q_u = ℓ_u + Bᵀ V_x'        Q_uu = ℓ_uu + Bᵀ V_xx' B     Q_ux = Bᵀ V_xx' A
//        k_k = argmin ½ δuᵀ (Q_uu + μI) δu + Q_uᵀ δu  s.t.  lower − ū_k <= δu <= upper − ū_k
//              (the projected-Newton box QP), with its free set F;
//        K_k = −(Q_uu + μI)_FF⁻¹ Q_ux,F on the free rows, 0 on the clamped ones;
//        V_x = Q_x + Kᵀ Q_uu k + Kᵀ Q_u + Q_uxᵀ k,  V_xx = Q_xx + Kᵀ Q_uu K + Kᵀ Q_ux + Q_uxᵀ K.
//      Expected decrease of a step α: ΔJ(α) = −α Σ k_kᵀ Q_u,k − ½ α² Σ k_kᵀ Q_uu,k k_k.
//   3. Converged when ΔJ(1) <= tolerance · J: the gains and Q_u are then the
//      final nominal's, and ū satisfies the box QP's optimality (KKT)
//      conditions at every knot.
//   4. Backtracking line search on the actual cost, α = 1, ½, ¼, ...:
//        x̂_0 = x_0,  û_k = clamp(ū_k + α k_k + K_k (x̂_k − x̄_k)),  x̂_{k+1} = Φ(x̂_k, S û_k)
//      accepted at the first α with J − J(α) > acceptance · ΔJ(α) > 0; then
//      μ ← μ / factor (0 below regularization_min). When the backward pass
//      meets a Q_uu + μI that is not positive definite, or no α is accepted,
//      μ ← max(regularization_min, μ · factor) and the pass is run again
//      (Levenberg–Marquardt); past regularization_max the solve stops.
// So the cost never increases from one iteration to the next, and no ū_k is
// ever outside the limits.
//
// Model and data apart: a DdpModel (the problem: plant, integrator, horizon,
// weights, limits, options) is validated once and immutable; a DdpData made
// for it is one user's workspace (its own PlantModel, integrator, every
// buffer), the references it is solved for and the solution. Every size is
// fixed when the data is made: SolveDdp allocates nothing.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "controllers/task_trajectory.hpp"
#include "plant/effects.hpp"
#include "plant/integrators.hpp"
#include "plant/kinematics.hpp"

namespace lagrange {

// Diagonal weights of the cost above. The cost has no physical unit: a
// weight's unit is the inverse square of its error's (wq 1/rad² or 1/m², wqd
// s²/rad² or s²/m², wu 1/(N·m)² or 1/N²); only their ratios shape the solution.
struct DdpWeights {
  VectorXd q;            // (n) wq, >= 0
  VectorXd qd;           // (n) wqd, >= 0
  VectorXd tau;          // (m) wu, > 0
  VectorXd q_terminal;   // (n) wqN, >= 0
  VectorXd qd_terminal;  // (n) wqdN, >= 0
};

// The frame term of the cost (above): none while `kinematics` is null.
// Weights 1/m² (position) and 1/rad² (rotation), >= 0.
struct DdpFrameCost {
  std::shared_ptr<const Kinematics> kinematics;  // the plant's frames (its q), shared, immutable
  int frame = -1;                                // an index of kinematics' frames
  double position = 0.0, rotation = 0.0;                    // w_pos, w_rot on every knot k < N
  double position_terminal = 0.0, rotation_terminal = 0.0;  // w_posN, w_rotN at k = N
};

// ½ w_pos |p_d − p(q)|² + ½ w_rot |log(R_d R(q)ᵀ)|² of `frame` at q (n) toward
// `target`; with `derivatives`, also adds its gradient −Jᵀ W e to `gradient`
// (n) and its Gauss–Newton Hessian Jᵀ W J to `hessian` (n x n) (otherwise
// neither is touched: pass empty ones). Through `data` (of `kinematics`);
// allocates nothing.
double FramePoseCost(const Kinematics& kinematics, KinematicsData& data, int frame, const Pose& target, double w_pos,
                     double w_rot, ConstVecRef q, bool derivatives, VecRef gradient, Eigen::Ref<MatrixXd> hessian);

struct DdpOptions {
  int max_iterations = 50;               // 1..10000
  double tolerance = 1e-8;               // converged when ΔJ(1) <= tolerance · J; >= 0
  double regularization_min = 1e-6;      // μ's first non-zero value; > 0
  double regularization_max = 1e10;      // past it the solve stops; >= regularization_min
  double regularization_factor = 10.0;   // μ × on a failure, ÷ on an accepted step; > 1
  int line_search_steps = 10;            // α = 1, ½, ..., 2^−(steps − 1); 1..60
  double line_search_acceptance = 1e-4;  // actual over expected decrease to accept; in [0, 1)
  int box_qp_max_iterations = 100;       // projected-Newton iterations per knot; 1..1000
};

struct DdpConfig {
  IntegratorType integrator = IntegratorType::kRk4;  // explicit-euler, semi-implicit-euler or rk4
  int substeps = 1;                                  // per knot, 1..1000
  double dt = 0.01;                                  // s per knot, > 0
  int horizon = 100;                                 // N, 1..100000
  std::vector<int> actuated;                         // joints that take a force, ascending; empty: every joint
  VectorXd tau_lower, tau_upper;                     // (m) N·m or N; −inf / +inf allowed; empty: unbounded
  DdpWeights weights;
  DdpFrameCost frame_cost;  // a frame's pose error (none by default)
  DdpOptions options;
  EffectsConfig effects;  // the optimiser's model of the plant's effects (no disturbance pushes)
};

class DdpModel {
 public:
  // Throws std::invalid_argument naming the field and what was expected
  // ("ddp: weights.tau: expected (m) finite values > 0") for a null model, an
  // integrator without step derivatives, or any size or range above.
  DdpModel(std::shared_ptr<const Dynamics> dynamics, DdpConfig config);

  int num_dofs() const { return n_; }                                      // n
  int num_controls() const { return static_cast<int>(actuated_.size()); }  // m
  int horizon() const { return config_.horizon; }                          // N
  double dt() const { return config_.dt; }
  const DdpConfig& config() const { return config_; }
  const std::vector<int>& actuated() const { return actuated_; }
  const VectorXd& tau_lower() const { return lower_; }  // (m)
  const VectorXd& tau_upper() const { return upper_; }  // (m)
  const std::shared_ptr<const Dynamics>& dynamics() const { return dynamics_; }
  bool has_frame_cost() const { return config_.frame_cost.kinematics != nullptr; }

 private:
  std::shared_ptr<const Dynamics> dynamics_;
  DdpConfig config_;
  int n_;
  std::vector<int> actuated_;
  VectorXd lower_, upper_;
};

enum class DdpStatus : std::uint8_t {
  kConverged,            // ΔJ(1) <= tolerance · J
  kMaxIterations,        // still improving when max_iterations ran out
  kLineSearchFailed,     // no step decreased the cost up to regularization_max
  kNotPositiveDefinite,  // Q_uu + μI not positive definite up to regularization_max
  kDiverged,             // the first rollout left the finite numbers (x_0 non-finite, or the
                         // held policy blew up); the data is then Reset
  kStopped,              // DdpData::stop was set: the solve ended with the last accepted nominal
                         // (x̄, ū, cost; never above the first rollout's); its gains may be
                         // part-way through a backward pass: not a policy to follow. Set during
                         // the first rollout: no nominal of this solve (cost NaN; x̄, ū, K as
                         // the data held them before the solve, its warm start)
};
inline constexpr std::size_t kNumDdpStatuses = static_cast<std::size_t>(DdpStatus::kStopped) + 1;
std::string_view ToString(DdpStatus status);

struct DdpResult {
  DdpStatus status = DdpStatus::kMaxIterations;
  int iterations = 0;              // backward passes followed by a line search
  double cost = 0.0;               // J of the nominal
  double expected_decrease = 0.0;  // ΔJ(1) of the last backward pass
  double regularization = 0.0;     // μ at the end
  VectorXd cost_history;           // (max_iterations + 1): J before the first
                                   // iteration, then after each; iterations + 1 valid
};

// One knot's affine policy: u = clamp(ū + K (x − x̄)) into [lower, upper], x = (q, qd); K (m x 2n), x̄ (2n),
// u (m). Allocates nothing (DdpData::EvaluatePolicy).
void EvaluateAffinePolicy(ConstVecRef u_bar, const Eigen::Ref<const MatrixXd>& K, ConstVecRef x_bar, ConstVecRef q,
                          ConstVecRef qd, const VectorXd& lower, const VectorXd& upper, VecRef u);
// The same a fraction s ∈ [0, 1] of the way from one knot (ū, x̄) to the next (ū_next, x̄_next), K held:
// u = clamp(ū + s (ū_next − ū) + K (x − (x̄ + s (x̄_next − x̄)))). Allocates nothing (MpcPolicy::Evaluate in
// the tick).
void EvaluateAffinePolicy(ConstVecRef u_bar, ConstVecRef u_bar_next, const Eigen::Ref<const MatrixXd>& K,
                          ConstVecRef x_bar, ConstVecRef x_bar_next, double s, ConstVecRef q, ConstVecRef qd,
                          const VectorXd& lower, const VectorXd& upper, VecRef u);

class DdpData {
 public:
  // Sizes every buffer for `model`, which must outlive the data; the
  // references start at zero and the controls at zero with no feedback (Reset).
  explicit DdpData(const DdpModel& model);

  // Polled at every knot of every pass, the first rollout too (may be null):
  // once set, SolveDdp returns kStopped with the last accepted nominal, so a
  // thread that plans stops within one knot's work.
  const std::atomic<bool>* stop = nullptr;

  // Inputs, set by the caller before SolveDdp; sized here, never resized.
  MatrixXd q_ref;   // (n x N+1) q_ref,k per knot
  MatrixXd qd_ref;  // (n x N+1)
  MatrixXd u_ref;   // (m x N)
  std::vector<Pose> pose_ref;  // (N+1) the frame's pose per knot (DdpFrameCost; identity at the origin until set)

  // The solution of the last SolveDdp (or what ShiftSolution and Reset left):
  const MatrixXd& x() const { return x_; }                                    // (2n x N+1) x̄_k = (q̄_k, q̄d_k)
  const MatrixXd& u() const { return u_; }                                    // (m x N) ū_k, within the limits
  const MatrixXd& K(int k) const { return K_[static_cast<std::size_t>(k)]; }  // (m x 2n) feedback gain
  const MatrixXd& k_feedforward() const { return kff_; }                      // (m x N) k_k of the last backward pass
  const MatrixXd& Qu() const { return Qu_; }  // (m x N) ∂Q_k/∂u at ū_k of the last backward pass
  const DdpResult& result() const { return result_; }
  // The effects this data's rollouts and derivatives take (the model's
  // config().effects, less its `off`, as switched since: Effects::SetEnabled).
  Effects& effects();
  const Effects& effects() const;

  // The affine policy of knot k: u = clamp(ū_k + K_k (x − x̄_k)), u (m).
  void EvaluatePolicy(int k, ConstVecRef q, ConstVecRef qd, VecRef u) const;

  // Warm start: the solution `knots` (>= 0) knots later. ū_k, x̄_k and K_k
  // become those of knot k + knots, the last one repeated past the end,
  // so the next SolveDdp starts from the previous policy's rollout.
  void ShiftSolution(int knots);
  // The same by a fractional number of knots (>= 0): the whole ones as above,
  // then ū_k, x̄_k and K_k interpolated linearly toward knot k + 1 by the
  // fraction (the last ones held), for a plan that starts between knots.
  void ShiftSolution(double knots);
  // Cold start: ū = 0 (clamped into the limits by the first rollout), no feedback.
  void Reset();
  // Cold start holding u (m) at every knot (clamped into the limits by the
  // first rollout), no feedback: Reset, then ū_k = u. No allocation.
  void HoldControls(ConstVecRef u);

 private:
  friend const DdpResult& SolveDdp(const DdpModel& model, DdpData& data, ConstVecRef q0, ConstVecRef qd0);
  friend struct DdpPasses;

  const DdpModel* model_;
  std::unique_ptr<PlantModel> plant_;
  std::unique_ptr<Integrator> integrator_;
  std::unique_ptr<StepDerivatives> step_;
  std::unique_ptr<KinematicsData> kinematics_;  // the frame cost's; null without one
  MatrixXd x_, u_, x_try_, u_try_;   // nominal and candidate trajectories
  std::vector<MatrixXd> A_, B_, K_;  // (2n x 2n), (2n x m), (m x 2n) per knot
  MatrixXd kff_, Qu_;                // (m x N)
  MatrixXd B_full_;                  // (2n x n)
  VectorXd tau_, q_, qd_, dx_, x0_;  // (n), (n), (n), (2n), (2n)
  // Backward pass scratch.
  VectorXd Vx_, Qx_, Qu_k_, Quu_k_vec_, lo_, hi_, du_;  // (2n), (2n), (m), (m), (m), (m), (m)
  MatrixXd Vxx_, VA_, VB_, Qxx_, Quu_, Qreg_, Qux_, QuuK_, XX_;
  // The box QP's workspace (controllers/ddp.cpp).
  VectorXd qp_grad_, qp_x_trial_, qp_search_, qp_Hx_, qp_rhs_;
  MatrixXd qp_L_;
  std::vector<int> qp_free_, qp_factored_;  // free indices; those chol(H_FF) in qp_L_ is of
  std::vector<char> qp_is_free_;            // (m) the free set as a mask
  DdpResult result_;
};

// (model, data, q0, qd0) => data's solution from x_0 = (q0, qd0) (n each),
// starting from data.u() (and data.K(k) around data.x(): the previous
// policy after ShiftSolution; open loop after Reset). Returns data.result().
// Allocates nothing.
const DdpResult& SolveDdp(const DdpModel& model, DdpData& data, ConstVecRef q0, ConstVecRef qd0);

}  // namespace lagrange
