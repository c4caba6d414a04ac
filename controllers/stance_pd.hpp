#pragma once
// Joint PD with gravity compensation for a robot standing on its feet: a
// legged robot on a floating base (plant/floating_dynamics.hpp), whose
// weight the ground carries through the feet in contact. A scene's
// `controller: {type: pd, gravity_compensation: stance, feet: [...]}`.
//
// Law:    tau = Kp e + Kd ė + tau_g, e = q_d − q, ė = qd_d − qd (the joints', as PdController);
//         tau_g from static equilibrium on the feet in contact C,
//           G(q) = Sᵀ tau_g + J_cᵀ λ      (nv rows: the base's six, then the joints')
//         J_c (3|C| x nv) the feet frames' linear Jacobians (world axes), λ their
//         ground forces (N, world axes). The base's rows, J_c,baseᵀ λ = G_base (6
//         equations), are solved for the least-norm λ of least residual,
//         λ = A⁺ G_base with A = J_c,baseᵀ (four feet leave 12 unknowns for 6
//         equations; one or two feet cannot resist every wrench), through
//         A⁺ = Aᵀ (A Aᵀ)⁺ and the eigen-decomposition of the 6 x 6 A Aᵀ
//         (eigenvalues below 1e-12 of the largest taken as zero), and the joints' rows give
//           tau_g = G_joints − J_c,jointsᵀ λ.
//         A foot is in contact when its frame is at most contact_height above
//         the ground plane z = 0 (world); with no foot in contact (the robot
//         in the air) tau_g = 0: gravity loads no joint of a falling body.
// Gains:  Kp_i N·m/rad, Kd_i N·m·s/rad, >= 0, bounded as PdController's
//         (controllers/joint_controllers.hpp) by the joints' model with the base fixed.
// Inputs: the base's pose and twist (Controller::Compute's floating form), q, qd;
//         setpoint (q_d, qd_d).
// Output: tau (n).
// State:  none; contact_count() and contact_forces() report the last law's C and λ.
// The model is the robot's on its floating base (its gravity included); the
// foot frames its frames (names checked at construction). Every buffer is
// sized at construction: the law allocates nothing.

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "controllers/controller.hpp"
#include "plant/floating_dynamics.hpp"

namespace lagrange {

// The most feet a stance may have (a quadruped's four, a humanoid's two
// soles of four corners each): λ's size is fixed at 3 of each.
inline constexpr int kMaxStanceFeet = 8;

// gravity_compensation: stance, feet: [...], contact_height: m.
struct StanceOptions {
  bool on = false;                // gravity_compensation: stance
  std::vector<std::string> feet;  // the feet's frames, in the robot's names
  // m: a foot whose frame is at most this high (world z) is in contact: the
  // A1's 0.02 m foot spheres (frame at the centre) on the ground at z = 0, with 1 cm to spare.
  double contact_height = 0.03;
};

// Why `stance` cannot run on a robot of these frames ("feet: ..."), or an empty string.
std::string StanceProblem(const StanceOptions& stance, const std::vector<std::string>& frames);

class StancePdController final : public Controller {
 public:
  // Throws std::invalid_argument with StanceProblem's reason, or for a null model.
  StancePdController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains, bool velocity_feedforward,
                     StanceOptions stance, std::shared_ptr<const FloatingDynamics> model);
  std::string_view name() const override { return "pd"; }
  Gains gains() const override { return gains_; }
  bool has_gains() const override { return true; }

  // The feet in contact at the last law (in `feet` order, the first contact_count()).
  int contact_count() const { return contacts_; }
  // λ of the last law: 3 per foot in contact (N, world axes), in that order.
  Eigen::Ref<const VectorXd> contact_forces() const { return lambda_.head(3 * contacts_); }

 protected:
  // Without the base's pose no stance is known: the PD terms alone. Never run
  // by an instance (a floating base's tick calls the floating form).
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;
  void ComputeFloatingLaw(double t, ConstVecRef base_q, ConstVecRef base_v, ConstVecRef q, ConstVecRef qd,
                          const Setpoint& sp, VecRef tau) override;
  void ApplyGains(const Gains& gains) override;

 private:
  static constexpr int kMaxRows = 3 * kMaxStanceFeet;
  using Matrix6d = Eigen::Matrix<double, 6, 6>;

  // (base_q, q) => tau_g (n), contacts_ and lambda_.
  void ComputeStanceGravity(ConstVecRef base_q, ConstVecRef q, VecRef tau_g);

  Gains gains_;
  bool velocity_feedforward_;
  double contact_height_;
  std::vector<int> feet_;                          // frame indices into the model's tree().frames
  std::shared_ptr<const FloatingDynamics> model_;  // shared, immutable
  std::unique_ptr<FloatingData> data_;             // this controller's data for it
  VectorXd fq_, zero_v_, G_;                       // (nq) the full q, (nv) zero, G(q)
  Eigen::Matrix<double, 6, Eigen::Dynamic> J_;     // (6 x nv) one foot's Jacobian
  MatrixXd joint_rows_;                            // (3 kMaxStanceFeet x n) J_c,joints
  Eigen::Matrix<double, 6, kMaxRows> base_rows_ = Eigen::Matrix<double, 6, kMaxRows>::Zero();  // A: 3|C| columns used
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxRows, 1> lambda_;
  int contacts_ = 0;
};

}  // namespace lagrange
