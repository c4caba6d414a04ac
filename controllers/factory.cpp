#include "controllers/factory.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "base/escape.hpp"
#include "controllers/lqr.hpp"
#include "plant/eigenvalues.hpp"

namespace lagrange {
namespace {

bool IsCartPoleOnly(ControllerType t) { return t == ControllerType::kCartPolePd || t == ControllerType::kSwingUp; }

// The controller's model: the plant's own (shared) when the config changes
// nothing and it was built for the method, else one of its own.
std::shared_ptr<const Dynamics> ControllerModel(const ControllerConfig& c, const PlantSpec& plant,
                                                const MethodModels& shared) {
  const PlantSpec& spec = c.model ? *c.model : plant;
  const Method method = c.model_method.value_or(FastestMethod(spec.type()));
  if (!c.model && shared[static_cast<std::size_t>(method)]) return shared[static_cast<std::size_t>(method)];
  return MakeDynamics(spec, method);
}

VectorXd Equilibrium(const LqrOptions& o, const PlantSpec& plant) {
  if (o.equilibrium) return *o.equilibrium;
  VectorXd q0 = VectorXd::Zero(plant.num_dofs());
  if (plant.type() == PlantType::kCartPole) q0[1] = std::numbers::pi;
  return q0;
}

std::vector<int> Actuated(const LqrOptions& o, const PlantSpec& plant) {
  if (o.actuated) return *o.actuated;
  if (plant.type() == PlantType::kCartPole) return {0};
  std::vector<int> all(static_cast<std::size_t>(plant.num_dofs()));
  for (int i = 0; i < plant.num_dofs(); ++i) all[static_cast<std::size_t>(i)] = i;
  return all;
}

// The initial q of a config (n), zeros when it gives none.
VectorXd StartQ(const ControllerConfig& c, const PlantSpec& plant) {
  return c.q0.size() == plant.num_dofs() ? c.q0 : VectorXd::Zero(plant.num_dofs());
}

// c = λmax(W⁻¹ diag W) of a symmetric "mass" W (n x n: M, or the task's Λ),
// through the symmetric diag(W)^½ W⁻¹ diag(W)^½; NaN when W is not positive
// definite or its diagonal not positive. c >= 1 (its eigenvalues average 1),
// and ρ(W⁻¹ diag(k)) <= 1 for every k_i <= W_ii / c: the corner of that box is
// its worst point, because ρ grows with every k_i.
double CouplingFactor(const MatrixXd& W) {
  const VectorXd diag = W.diagonal();
  const Eigen::LLT<MatrixXd> llt(W);
  if (llt.info() != Eigen::Success || !(diag.array() > 0.0).all()) return std::numeric_limits<double>::quiet_NaN();
  const MatrixXd scaled = diag.cwiseSqrt().asDiagonal() * llt.solve(MatrixXd(diag.cwiseSqrt().asDiagonal()));
  return SymmetricEigenvalues(scaled).maxCoeff();
}

// Λ(q0) (task_space.hpp) of a task-space config's frame on the robot `spec`
// (the plant's, for the gain bounds; the controller's model, for its damping).
// The frame must exist (ValidateTaskSpace).
Matrix6d StartTaskInertia(const ControllerConfig& c, const PlantSpec& spec) {
  const std::unique_ptr<Dynamics> dynamics = MakeDynamics(spec, FastestMethod(spec.type()));
  const Kinematics kinematics(MakeRigidTree(spec));
  return TaskInertiaAt(*dynamics, kinematics, *FindTaskFrame(kinematics, c.task.frame), StartQ(c, spec),
                       c.task.singularity);
}

// The gains a task-space controller is built with: a cartesian-impedance
// config without kd gets D_i = 2 ζ sqrt(K_i Λ_ii(q0)) from its model's Λ
// (task_space.hpp); everything else as given.
Gains ResolvedGains(const ControllerConfig& c, const PlantSpec& plant) {
  if (c.type != ControllerType::kCartesianImpedance || c.gains.kd.size() != 0 || c.gains.kp.size() != kTaskDims) {
    return c.gains;
  }
  const Vector6d lambda = StartTaskInertia(c, c.model ? *c.model : plant).diagonal();
  Gains g = c.gains;
  g.kd = 2.0 * c.task.damping_ratio * (c.gains.kp.cwiseProduct(lambda)).cwiseSqrt();
  return g;
}

// The task-space rules of task_space.hpp, held over c.period from c.q0.
GainBounds TaskGainBounds(const ControllerConfig& c, const PlantSpec& plant) {
  GainBounds b = GainBounds::UnboundedTask();
  const double h = c.period;
  if (!(h > 0.0)) return b;
  char at[48];
  std::snprintf(at, sizeof at, " at h = %.6g s", h);
  if (c.type == ControllerType::kOperationalSpace) {  // unit-mass task error dynamics: computed torque's rule
    b.kp_max.setConstant(1.0 / (h * h));
    b.kd_max.setConstant(2.0 / h);
    b.kp_rule = std::string("Kp·h² <= 1") + at;
    b.kd_rule = std::string("Kd·h <= 2") + at;
    return b;
  }
  const Matrix6d lambda = StartTaskInertia(c, plant);
  const double coupling = CouplingFactor(lambda);  // NaN bounds (Λ not positive definite) admit nothing
  b.kp_max = lambda.diagonal() / (coupling * h * h);
  b.kd_max = 2.0 * lambda.diagonal() / (coupling * h);
  char with[80];
  std::snprintf(with, sizeof with, " with c = λmax(Λ⁻¹diag(Λ)) = %.6g, Λ = Λ(q0)", coupling);
  b.kp_rule = std::string("K_i·h²·c/Λ_ii <= 1") + at + with;
  b.kd_rule = std::string("D_i·h·c/Λ_ii <= 2") + at + with;
  return b;
}

// A task-space config's own keys: the robot has the frame and 6 joints or
// more, the posture task's gains fit the joint PD's bounds, the trajectory
// and the singularity damping are well formed.
std::optional<std::string> ValidateTaskSpace(const ControllerConfig& c, const PlantSpec& plant) {
  const int n = plant.num_dofs();
  if (n < kTaskDims) {
    return "type: " + std::string(ToString(c.type)) + " needs a robot of at least 6 joints (a frame's 6-D pose), got " +
           std::to_string(n);
  }
  for (const PlantSpec* spec : {&plant, c.model ? &*c.model : nullptr}) {
    if (spec == nullptr) continue;
    const Kinematics kinematics(MakeRigidTree(*spec));
    if (FindTaskFrame(kinematics, c.task.frame)) continue;
    std::string names;
    for (const std::string& f : kinematics.frame_names()) names += (names.empty() ? "" : ", ") + Escape(f, 64);
    return std::string("frame: expected a frame of ") + (spec == &plant ? "the robot" : "the controller's model") +
           " (" + names + "), got '" + Escape(c.task.frame, 64) + "'";
  }
  const TaskSpaceOptions& t = c.task;
  if (!(std::isfinite(t.damping_ratio) && t.damping_ratio > 0.0)) {
    return std::string("damping_ratio: expected a positive number");
  }
  if (!(std::isfinite(t.singularity.threshold) && t.singularity.threshold > 0.0)) {
    return std::string("singularity.threshold: expected a positive number (σmin(J) below which damping ramps in)");
  }
  if (!(std::isfinite(t.singularity.max_damping) && t.singularity.max_damping > 0.0)) {
    return std::string("singularity.max_damping: expected a positive number (λ² at σmin(J) = 0)");
  }
  const NullSpaceOptions& ns = t.null_space;
  if (ns.posture && (ns.posture->size() != n || !ns.posture->allFinite())) {
    return "null_space.posture: expected " + std::to_string(n) + " finite values (one per joint)";
  }
  const Gains posture{ns.kp.size() > 0 ? ns.kp : VectorXd::Zero(n), ns.kd.size() > 0 ? ns.kd : VectorXd::Zero(n)};
  GainBounds pd =
      c.continuous ? GainBounds::Unbounded(n) : ComputeGainBounds(ControllerType::kPd, plant, c.q0, c.period);
  if (auto fault = FindGainFault(posture, pd)) return "null_space." + DescribeGainFault(*fault, posture, pd);
  if (auto err = ValidatePoseTrajectory(t.trajectory)) return "trajectory." + *err;
  return std::nullopt;
}

// The weights as given, identity where left out.
MatrixXd LqrQ(const LqrOptions& o, int n) { return o.Q.size() > 0 ? o.Q : MatrixXd::Identity(2 * n, 2 * n); }
MatrixXd LqrR(const LqrOptions& o, int m) { return o.R.size() > 0 ? o.R : MatrixXd::Identity(m, m); }

std::optional<std::string> ValidateLqr(const LqrOptions& o, const PlantSpec& plant) {
  const int n = plant.num_dofs();
  if (!o.equilibrium && plant.type() != PlantType::kCartPole) {
    return std::string("equilibrium: expected the configuration to balance about (one value per joint)");
  }
  if (o.equilibrium && o.equilibrium->size() != n) {
    return "equilibrium: expected " + std::to_string(n) + " values (one per joint), got " +
           std::to_string(o.equilibrium->size());
  }
  const std::vector<int> act = Actuated(o, plant);
  if (act.empty()) return std::string("actuated: expected at least one joint");
  for (int j : act) {
    if (j < 0 || j >= n) return "actuated: expected joint indices from 0 to " + std::to_string(n - 1);
  }
  const int m = static_cast<int>(act.size());
  if (o.Q.size() > 0 && (o.Q.rows() != 2 * n || o.Q.cols() != 2 * n)) {
    return "Q: expected " + std::to_string(2 * n) + " x " + std::to_string(2 * n) + " (state (q, qd))";
  }
  if (o.R.size() > 0 && (o.R.rows() != m || o.R.cols() != m)) {
    return "R: expected " + std::to_string(m) + " x " + std::to_string(m) + " (one per actuated joint)";
  }
  return CheckLqrWeights(LqrQ(o, n), LqrR(o, m));
}

std::unique_ptr<Controller> MakeLqr(const ControllerConfig& c, const PlantSpec& plant, const VectorXd& limits,
                                    const MethodModels& shared) {
  const int n = plant.num_dofs();
  const std::shared_ptr<const Dynamics> model = ControllerModel(c, plant, shared);
  const std::vector<int> act = Actuated(c.lqr, plant);
  const int m = static_cast<int>(act.size());
  if (c.lqr.discrete) {
    const LinearModel lin =
        LinearizeStep(model, Equilibrium(c.lqr, plant), act, c.integrator.type, c.integrator.substeps, c.period);
    const LqrResult lqr = DiscreteLinearQuadraticRegulator(lin.A, lin.B, LqrQ(c.lqr, n), LqrR(c.lqr, m));
    return std::make_unique<StateFeedbackController>("lqr", model->joint_types(), limits, act, lqr.K, lin.u0);
  }
  const LinearModel lin = Linearize(*model, Equilibrium(c.lqr, plant), act);
  const LqrResult lqr = LinearQuadraticRegulator(lin.A, lin.B, LqrQ(c.lqr, n), LqrR(c.lqr, m));
  return std::make_unique<StateFeedbackController>("lqr", model->joint_types(), limits, act, lqr.K, lin.u0);
}

}  // namespace

bool HasGains(ControllerType type) {
  return type == ControllerType::kPd || type == ControllerType::kGravityCompensation ||
         type == ControllerType::kComputedTorque || type == ControllerType::kCartPolePd || IsTaskSpace(type);
}

GainBounds ComputeGainBounds(ControllerType type, const PlantSpec& plant, const VectorXd& q0, double h) {
  const int n = plant.num_dofs();
  if (IsTaskSpace(type)) {  // the default frame, damping and q0
    ControllerConfig c;
    c.type = type;
    c.q0 = q0;
    c.period = h;
    return TaskGainBounds(c, plant);
  }
  GainBounds b = GainBounds::Unbounded(n);
  if (!HasGains(type) || !(h > 0.0)) return b;
  char at[48];
  std::snprintf(at, sizeof at, " at h = %.6g s", h);
  if (type == ControllerType::kComputedTorque) {
    b.kp_max.setConstant(1.0 / (h * h));
    b.kd_max.setConstant(2.0 / h);
    b.kp_rule = std::string("Kp·h² <= 1") + at;
    b.kd_rule = std::string("Kd·h <= 2") + at;
    return b;
  }
  MatrixXd M(n, n);
  const std::unique_ptr<Dynamics> model = MakeDynamics(plant, FastestMethod(plant.type()));
  model->ComputeMassMatrix(*model->MakeData(), q0.size() == n ? q0 : VectorXd::Zero(n), M);
  char mass[64];
  if (type == ControllerType::kCartPolePd) {
    b.any_sign = true;
    b.kp_max.setConstant(M(0, 0) / (h * h));
    b.kd_max.setConstant(2.0 * M(0, 0) / h);
    std::snprintf(mass, sizeof mass, " with M_xx = %.6g kg", M(0, 0));
    b.kp_rule = std::string("|Kp|·h²/M_xx <= 1") + at + mass;
    b.kd_rule = std::string("|Kd|·h/M_xx <= 2") + at + mass;
    return b;
  }
  // Two boxes keep every mode of M⁻¹Kp h² within 1 (and of M⁻¹Kd h within 2),
  // and gains within either are accepted: the same bound λmin(M) on every
  // joint, or bounds in proportion to each joint's own M_ii, w = diag(M)/c
  // with c = λmax(M⁻¹ diag M) (ρ(M⁻¹ diag(k)) grows with every k_i, so the
  // corner of each box is its worst point). The second is what lets a
  // robot's heavy shoulder take more than its light wrist.
  const double lambda = SymmetricEigenvalues(M).minCoeff();
  b.kp_max.setConstant(lambda / (h * h));
  b.kd_max.setConstant(2.0 * lambda / h);
  std::snprintf(mass, sizeof mass, " with λmin(M(q0)) = %.6g", lambda);
  b.kp_rule = std::string("Kp·h²/λmin(M) <= 1") + at + mass;
  b.kd_rule = std::string("Kd·h/λmin(M) <= 2") + at + mass;
  if (n < 2) return b;  // one joint: the two boxes are one
  const VectorXd diag = M.diagonal();
  const double c = CouplingFactor(M);
  if (!(std::isfinite(c) && c > 0.0)) return b;  // M(q0) not positive definite
  b.kp_max_per_joint = diag / (c * h * h);
  b.kd_max_per_joint = 2.0 * diag / (c * h);
  std::snprintf(mass, sizeof mass, " with c = λmax(M⁻¹diag(M)) = %.6g", c);
  b.kp_rule_per_joint = std::string("Kp_i·h²·c/M_ii <= 1") + at + mass;
  b.kd_rule_per_joint = std::string("Kd_i·h·c/M_ii <= 2") + at + mass;
  return b;
}

GainBounds ComputeGainBounds(const ControllerConfig& c, const PlantSpec& plant) {
  if (c.continuous) {  // not held over a tick: the integrator's stages decide (sub-steps, variational)
    GainBounds b = IsTaskSpace(c.type) ? GainBounds::UnboundedTask() : GainBounds::Unbounded(plant.num_dofs());
    b.any_sign = c.type == ControllerType::kCartPolePd;
    return b;
  }
  if (IsTaskSpace(c.type)) return TaskGainBounds(c, plant);
  return ComputeGainBounds(c.type, plant, c.q0, c.period);
}

std::optional<std::string> CheckGains(ControllerType type, const Gains& gains, const GainBounds& bounds) {
  if (!HasGains(type)) return std::string(ToString(type)) + " has no adjustable gains";
  if (auto fault = FindGainFault(gains, bounds)) return DescribeGainFault(*fault, gains, bounds);
  return std::nullopt;
}

std::optional<std::string> CheckGains(ControllerType type, std::span<const double> kp, std::span<const double> kd,
                                      const GainBounds& bounds) {
  const Gains g{Eigen::Map<const VectorXd>(kp.data(), static_cast<Eigen::Index>(kp.size())),
                Eigen::Map<const VectorXd>(kd.data(), static_cast<Eigen::Index>(kd.size()))};
  return CheckGains(type, g, bounds);
}

std::optional<std::string> CheckGains(ControllerType type, int n, const Gains& gains) {
  GainBounds bounds = IsTaskSpace(type) ? GainBounds::UnboundedTask() : GainBounds::Unbounded(n);
  bounds.any_sign = type == ControllerType::kCartPolePd;
  return CheckGains(type, gains, bounds);
}

const char* FloatingBaseRefusal(ControllerType type) {
  switch (type) {
    case ControllerType::kNone:
    case ControllerType::kPd: return nullptr;
    case ControllerType::kComputedTorque:
      return "computed-torque cannot run a floating base: it commands M q̈_d + C q̇ + G on every degree of freedom, "
             "and the base's six are unactuated";
    case ControllerType::kLqr:
      return "lqr cannot run a floating base: its gain acts on every degree of freedom, and the base's six are "
             "unactuated (a linearisation about a free base has no equilibrium under gravity)";
    case ControllerType::kMpc:
      return "mpc cannot run a floating base: its plan is over a fixed-base model whose every joint is actuated, "
             "and the base's six are not";
    case ControllerType::kGravityCompensation:
      return "gravity-compensation cannot run a floating base: holding it up against gravity needs contact forces, "
             "and it has none (pd with gravity_compensation: stance balances G over the feet in contact)";
    case ControllerType::kCartesianImpedance:
    case ControllerType::kOperationalSpace:
      return "a task-space controller cannot run a floating base yet: its frame's Jacobian and its C q̇ + G "
             "terms are a fixed base's";
    case ControllerType::kExternal:
      return "external cannot run a floating base yet: its state_t carries the joints only, not the base it "
             "would need to control them";
    case ControllerType::kCartPolePd:
    case ControllerType::kSwingUp: return "a cart-pole controller needs a cart-pole, not a floating base";
  }
  return "unknown controller type";
}

std::optional<std::string> ValidateController(const ControllerConfig& c, const PlantSpec& plant) {
  const int n = plant.num_dofs();
  if (IsCartPoleOnly(c.type) && plant.type() != PlantType::kCartPole) {
    return "type: " + std::string(ToString(c.type)) + " needs a cartpole plant, got " +
           std::string(ToString(plant.type()));
  }
  if (c.model) {
    if (c.model->type() != plant.type() || c.model->num_dofs() != n) {
      return std::string("model: expected the plant's type and size");
    }
    if (JointTypesOf(*c.model) != JointTypesOf(plant)) {
      return std::string("model: expected the plant's joint types in order (revolute or prismatic)");
    }
    if (auto err = ValidatePlantSpec(*c.model)) return "model.params." + err->key + ": " + err->message;
  }
  if (c.model_method && !HasMethod(c.model ? c.model->type() : plant.type(), *c.model_method)) {
    return std::string("model.method: ") + std::string(ToString(plant.type())) + " has no " +
           std::string(ToString(*c.model_method)) + " path";
  }
  if (!c.wrap.empty() && static_cast<int>(c.wrap.size()) != n) {
    return "wrap: expected " + std::to_string(n) + " flags (one per joint), got " + std::to_string(c.wrap.size());
  }
  if (c.q0.size() != 0 && c.q0.size() != n) {
    return "q0: expected " + std::to_string(n) + " values (one per joint), got " + std::to_string(c.q0.size());
  }
  if (!(std::isfinite(c.period) && c.period > 0.0)) return std::string("period: expected a positive number of seconds");
  if (IsTaskSpace(c.type)) {
    if (auto err = ValidateTaskSpace(c, plant)) return err;
  }
  if (c.stance.on || !c.stance.feet.empty()) {
    if (c.type != ControllerType::kPd) return std::string("gravity_compensation: stance is a pd controller's option");
    if (const std::string why = StanceProblem(c.stance, MakeRigidTree(plant).frame_names()); !why.empty()) return why;
    if (c.model || c.model_method) {
      return std::string(
          "model: expected none with gravity_compensation: stance (its model is the robot's on its "
          "floating base, the instance's)");
    }
    if (c.pd.acceleration_feedforward) {
      return std::string(
          "acceleration_feedforward: expected false with gravity_compensation: stance (M of a "
          "floating base is not the joints')");
    }
  }
  if (HasGains(c.type)) {
    if (auto err = CheckGains(c.type, ResolvedGains(c, plant), ComputeGainBounds(c, plant))) return err;
  }
  if (c.type == ControllerType::kLqr || c.type == ControllerType::kSwingUp) {
    if (auto err = ValidateLqr(c.lqr, plant)) return err;
    if (c.lqr.discrete && c.continuous) {
      return std::string("design: discrete is the design of a law held over the tick (continuous: false)");
    }
    if (const char* reason = c.lqr.discrete ? NoStepDerivativesReason(c.integrator.type) : nullptr) {
      return "design: discrete needs the step derivatives of the instance's integrator: " + std::string(reason);
    }
    if (c.lqr.discrete && c.integrator.substeps < 1) return std::string("design: expected integrator substeps >= 1");
  }
  if (c.type == ControllerType::kExternal) {
    if (!(std::isfinite(c.external.torque_timeout) && c.external.torque_timeout > 0.0)) {
      return std::string("torque_timeout: expected a positive number of seconds");
    }
    if (c.continuous) return std::string("continuous: an external controller's torque is held over the tick");
  }
  if (c.type == ControllerType::kMpc) {
    if (auto err = ValidateMpc(c.mpc, n, plant.type() == PlantType::kCartPole, c.period)) return err;
    if (!c.mpc.frame.empty()) {
      const Kinematics kinematics(MakeRigidTree(c.model ? *c.model : plant));
      if (!MpcFrame(c.mpc, kinematics)) {
        std::string names;
        for (const std::string& f : kinematics.frame_names()) names += (names.empty() ? "" : ", ") + Escape(f, 64);
        return "frame: expected a frame of the " + std::string(c.model ? "controller's model" : "robot") + " (" +
               names + "), got '" + Escape(c.mpc.frame, 64) + "'";
      }
    }
    if (c.continuous) return std::string("continuous: mpc follows its plan's policy once per tick");
  }
  if (c.continuous && c.type == ControllerType::kSwingUp) {
    return std::string("continuous: swing-up keeps a mode and runs once per tick");
  }
  if (c.type == ControllerType::kSwingUp) {
    const SwingUpOptions& s = c.swing_up;
    for (const auto& [key, v] : {std::pair{"energy_gain", s.energy_gain}, std::pair{"max_accel", s.max_accel},
                                 std::pair{"switch_angle", s.switch_angle}, std::pair{"switch_rate", s.switch_rate}}) {
      if (!(std::isfinite(v) && v > 0.0)) return std::string(key) + ": expected a positive number";
    }
    if (!(s.cart_gain >= 0.0) || !(s.cart_damping >= 0.0)) return std::string("cart_gain, cart_damping: expected >= 0");
  }
  return std::nullopt;
}

namespace {

std::unique_ptr<Controller> MakeTaskSpace(const ControllerConfig& c, const PlantSpec& plant, const VectorXd& limits,
                                          const MethodModels& shared) {
  auto kinematics = std::make_shared<const Kinematics>(MakeRigidTree(c.model ? *c.model : plant));
  const int frame = *FindTaskFrame(*kinematics, c.task.frame);
  const Gains gains = ResolvedGains(c, plant);
  const std::vector<JointType> joints = JointTypesOf(plant);
  std::shared_ptr<const Dynamics> model = ControllerModel(c, plant, shared);
  if (c.type == ControllerType::kCartesianImpedance) {
    return std::make_unique<CartesianImpedanceController>(joints, limits, gains, c.task, StartQ(c, plant),
                                                          std::move(model), std::move(kinematics), frame);
  }
  return std::make_unique<OperationalSpaceController>(joints, limits, gains, c.task, StartQ(c, plant), std::move(model),
                                                      std::move(kinematics), frame);
}

// The controller for a validated config.
std::unique_ptr<Controller> MakeLaw(const ControllerConfig& c, const PlantSpec& plant, const VectorXd& torque_limits,
                                    const MethodModels& shared, const EffectsConfig& plant_effects,
                                    std::shared_ptr<const FloatingDynamics> floating) {
  const std::vector<JointType> joints = JointTypesOf(plant);
  if (c.stance.on) {
    return std::make_unique<StancePdController>(joints, torque_limits, c.gains, c.pd.velocity_feedforward, c.stance,
                                                std::move(floating));
  }
  switch (c.type) {
    case ControllerType::kNone: return std::make_unique<ZeroController>(joints, torque_limits);
    case ControllerType::kPd:
    case ControllerType::kGravityCompensation: {
      PdOptions options = c.pd;
      options.gravity_compensation = c.type == ControllerType::kGravityCompensation;
      const bool needs_model = options.gravity_compensation || options.acceleration_feedforward;
      return std::make_unique<PdController>(joints, torque_limits, c.gains, options,
                                            needs_model ? ControllerModel(c, plant, shared) : nullptr);
    }
    case ControllerType::kComputedTorque:
      return std::make_unique<ComputedTorqueController>(joints, torque_limits, c.gains,
                                                        ControllerModel(c, plant, shared));
    case ControllerType::kCartPolePd: return std::make_unique<CartPolePdController>(joints, torque_limits, c.gains);
    case ControllerType::kLqr: return MakeLqr(c, plant, torque_limits, shared);
    case ControllerType::kSwingUp: {
      std::unique_ptr<Controller> balancer = MakeLqr(c, plant, torque_limits, shared);
      if (!c.wrap.empty()) balancer->set_wrapped_joints(c.wrap);
      return std::make_unique<SwingUpController>(joints, torque_limits, c.swing_up, ControllerModel(c, plant, shared),
                                                 std::move(balancer));
    }
    case ControllerType::kExternal:
      return std::make_unique<ExternalController>(
          joints, torque_limits, c.external.compensate_gravity ? ControllerModel(c, plant, shared) : nullptr,
          c.external.compensate_gravity);
    case ControllerType::kCartesianImpedance:
    case ControllerType::kOperationalSpace: return MakeTaskSpace(c, plant, torque_limits, shared);
    case ControllerType::kMpc: {
      std::shared_ptr<const Kinematics> kinematics =
          c.mpc.frame.empty() ? nullptr : std::make_shared<const Kinematics>(MakeRigidTree(c.model ? *c.model : plant));
      return std::make_unique<MpcController>(
          joints, torque_limits,
          MakeMpcModel(c.mpc, ControllerModel(c, plant, shared), MpcEffects(plant_effects), torque_limits,
                       plant.type() == PlantType::kCartPole, std::move(kinematics)),
          MpcReplanPeriod(c.mpc), c.mpc.trajectory);
    }
  }
  throw std::invalid_argument("unknown controller");
}

}  // namespace

std::unique_ptr<Controller> MakeController(const ControllerConfig& c, const PlantSpec& plant,
                                           const VectorXd& torque_limits, const MethodModels& plant_models,
                                           const EffectsConfig& plant_effects,
                                           std::shared_ptr<const FloatingDynamics> floating) {
  if (auto err = ValidateController(c, plant)) throw std::invalid_argument(*err);
  std::unique_ptr<Controller> controller =
      MakeLaw(c, plant, torque_limits, plant_models, plant_effects, std::move(floating));
  controller->set_gain_bounds(ComputeGainBounds(c, plant));
  if (!c.wrap.empty()) controller->set_wrapped_joints(c.wrap);
  return controller;
}

}  // namespace lagrange
