#pragma once
// One running plant instance, the tick's data for one InstanceModel
// (sim/instance_model.hpp): its plant (data for the shared dynamics
// models, the effects' switches), integrators, controllers, trajectory and
// state. Everything is allocated in the constructor; nothing after allocates.
//
// One step: setpoint → controller (with its torque limits) → integrate the
// scene's sub-steps → qdd at the new state.
//
// A floating base (InstanceModel::floating): the instance steps the full
// state q (nq), v (nv) on its manifold (FloatingIntegrator, the scene's
// explicit-euler, semi-implicit-euler, rk4 or variational), the joints' force (the
// command through every effect: saturation, damping, friction, limits, pushes)
// held over each sub-step, the base's zero; q(), qd(), qdd() are the joints'
// part of it (n), floating_q() and floating_v() the whole. Its energies are
// the floating model's (T of the whole robot, V its gravity potential plus the
// stops' springs), and its energy balance counts the joints' forces' work
// exactly, each force held over its sub-step (see energy_balance()).
// On MuJoCo (a mujoco plant with floating_base: true) MuJoCo steps that full
// state instead (its free joint the base, its contacts holding it up), the
// joints' force held over the tick, the base's zero; the energies are
// MuJoCo's (it keeps no energy balance: accounting() false), and the floating
// model (the URDF's) gives the centre of mass and momentum of the state MuJoCo
// reached. Controllers on a floating base see its
// pose and twist (Controller::Compute's floating form).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "controllers/controller.hpp"
#include "controllers/mpc.hpp"
#include "controllers/task_space.hpp"
#include "controllers/trajectory.hpp"
#include "plant/energy_balance.hpp"
#include "plant/floating_integrator.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_model.hpp"
#include "plant/stepped_plant.hpp"
#include "sim/instance_model.hpp"
#include "sim/scene.hpp"

namespace lagrange {

class Instance {
 public:
  // The tick's data for `model` (which it keeps: it may be shared by other threads).
  explicit Instance(std::shared_ptr<const InstanceModel> model);
  // The same on a model of its own (an offline run, a test). Throws as BuildInstanceModel.
  explicit Instance(const InstanceConfig& config);

  const InstanceModel& instance_model() const { return *instance_model_; }
  const InstanceConfig& config() const { return instance_model_->config; }
  const std::string& name() const { return config().name; }
  int num_dofs() const { return model_.num_dofs(); }

  double t() const { return t_; }  // simulated time, s
  std::int64_t steps() const { return steps_; }
  // Moves the step count (and t) forward to `steps` if it is behind: an
  // external plant's time is the wall's, skipped ticks included.
  void CatchUp(std::int64_t steps, double dt) {
    if (steps <= steps_) return;
    steps_ = steps;
    t_ = static_cast<double>(steps_) * dt;
  }
  const VectorXd& q() const { return q_; }
  const VectorXd& qd() const { return qd_; }
  const VectorXd& qdd() const { return qdd_; }  // at the current state under the last applied tau
  const VectorXd& tau() const {
    return tau_;
  }  // applied generalized force of the last step (after limits and saturation)
  const VectorXd& q_des() const { return q_des_; }

  // A floating base (instance_model().floating_base()): the full state, q (nq)
  // and v (nv) in the free-flyer conventions (plant/rigid_tree.hpp); empty otherwise.
  bool floating_base() const { return floating_ != nullptr; }
  const VectorXd& floating_q() const { return fq_; }
  const VectorXd& floating_v() const { return fv_; }
  // a = v̇ (nv) at the current state under the last command, the base's six
  // (the time derivatives of its body-axes twist) then qdd(); empty otherwise.
  const VectorXd& floating_a() const { return fa_; }
  // How often the floating model evaluated gravity and Coriolis terms through
  // the instance's data (stepping, ComputeForces, the base's motion). Only for a floating base.
  const StageCounts& floating_counts() const { return fdata_->counts(); }
  // A floating base's centre of mass c (m, world) and momentum (world axes:
  // linear N·s, angular about c N·m·s, the centroidal momentum A_G v) at the
  // current state. No allocation. Only for a floating base.
  struct BaseMotion {
    Eigen::Vector3d com = Eigen::Vector3d::Zero();
    Eigen::Vector3d angular = Eigen::Vector3d::Zero();
    Eigen::Vector3d linear = Eigen::Vector3d::Zero();
  };
  BaseMotion ComputeBaseMotion();

  // The scene trajectory's setpoint at the current time.
  void SampleTrajectory(Setpoint& out) const;
  // The scene's trajectory ahead: column k of q, qd (n x K each) its sample
  // at t + k dt (an mpc plan's reference per knot). Allocates nothing.
  void SampleTrajectoryAhead(double dt, MatrixXd& q, MatrixXd& qd);
  // Starts the scene trajectory over from the current state, now (an
  // external plant's first measured state: Trajectory::StartFrom). Reset
  // starts it from the scene's initial state again. Allocates nothing.
  void RestartTrajectory();

  // Why a step failed (static strings, so the tick can report them without
  // formatting), or null when it did not.
  using StepFailure = const char*;
  // Arrays (one object each), so a failure can be compared by address.
  static constexpr char kControllerNotFinite[] = "the controller's output was not finite";
  static constexpr char kIntegratorFailed[] = "the integrator failed its tolerance";

  // (setpoint) => control, then (q, qd) at t + dt (an external plant: the
  // control only, (q, qd) stay the measured ones). Non-null when the
  // controller faulted (non-finite law) or the integrator failed, naming
  // which; the state is then left as the integrator produced it and the
  // caller decides.
  StepFailure Step(double dt, const Setpoint& setpoint);
  // The same under the controller at `index` instead of the active one (a fallback).
  StepFailure Step(double dt, const Setpoint& setpoint, std::size_t index);
  // A step under the scene's own trajectory.
  StepFailure Step(double dt);
  // A step under a given commanded force, no controller (q_des unchanged).
  StepFailure StepWithTorque(double dt, ConstVecRef tau_cmd);
  // An external plant's measured state (n each); no allocation.
  void SetMeasured(ConstVecRef q, ConstVecRef qd) {
    q_ = q;
    qd_ = qd;
    energies_cached_ = false;
  }
  bool external_plant() const { return external_; }
  // The external controller at `index`, or null for another type.
  ExternalController* external_controller(std::size_t index) { return externals_[index]; }
  // The mpc controller at `index`, or null for another type: where lagranged
  // hands it the optimiser thread's plans (MpcController::SetPolicy: no
  // allocation) after set_plan_inline(false); offline it plans inline.
  MpcController* mpc_controller(std::size_t index) { return mpcs_[index]; }
  const MpcController* mpc_controller(std::size_t index) const { return mpcs_[index]; }
  // The task-space controller at `index` (cartesian-impedance, operational-space),
  // or null for another type: where the tick sets a pose target
  // (TaskSpaceController::SetPoseTarget, MoveTo: no allocation) and reads the
  // frame's commanded pose and error.
  TaskSpaceController* task_space_controller(std::size_t index) { return task_spaces_[index]; }
  const TaskSpaceController* task_space_controller(std::size_t index) const { return task_spaces_[index]; }
  // The state to return to after a fault: steps, q, qd.
  struct Saved {
    std::int64_t steps = 0;
    double t = 0.0;
    VectorXd q, qd;
    EnergyBalance balance;
    double rest_power = 0.0, power_end = 0.0;
    VectorXd floating_q, floating_v;  // a floating base's full state (empty otherwise)
  };
  Saved MakeSaved() const { return {steps_, t_, q_, qd_, balance_, rest_power_, power_end_, fq_, fv_}; }
  void Save(Saved& out) const;
  // Restores a saved state with zero torque and acceleration; no allocation.
  void Restore(const Saved& saved);
  // Puts the instance at (q, qd) (n each) at the current time, as a user
  // moves a simulated robot by hand (Python's Instance.q = ...): the next
  // step starts there, under the same controller and trajectory; q̈ follows
  // at it under the last applied tau; the energy balance is re-based, so ε
  // runs on continuously (the jump in energy is no work done); a stepped
  // plant's simulator is set there too. No allocation.
  void SetState(ConstVecRef q, ConstVecRef qd);
  // A floating base's pose and twist, as SetState sets the joints': base_q (p
  // (m), then the unit quaternion x, y, z, w; 7) and base_v (v_b (m/s), ω_b
  // (rad/s), base axes; 6); the joints stay. floating_base() only. No allocation.
  void SetBaseState(ConstVecRef base_q, ConstVecRef base_v);
  // Both at once, settled once: the joints as SetState, the base as SetBaseState. floating_base() only.
  void SetState(ConstVecRef q, ConstVecRef qd, ConstVecRef base_q, ConstVecRef base_v);

  Controller& controller() { return *controllers_[active_]; }
  const Controller& controller() const { return *controllers_[active_]; }
  // Names of the controllers this instance can run (the scene's, plus none), by index.
  std::vector<std::string> controller_names() const;
  // Switches to a configured controller by name and resets it.
  std::optional<std::string> SelectController(std::string_view name);
  // The same by index into controller_names(); no allocation.
  void SelectController(std::size_t index);
  std::size_t active_controller() const { return active_; }
  Controller& controller(std::size_t index) { return *controllers_[index]; }

  // Back to the initial state at t = 0 with the scene's first controller,
  // and every controller's gains back to the scene's.
  void Reset();

  // T and V at the current state: the balance's, when it computed them at
  // this state; a stepped (mujoco) plant's are its simulator's; a floating
  // base's the whole robot's (V: gravity's potential when on, plus the stops' springs).
  double KineticEnergy() {
    if (stepped_) return stepped_->kinetic_energy();
    if (energies_cached_) return kinetic_;
    return floating_ ? floating_->ComputeKineticEnergy(*fdata_, fq_, fv_) : model_.KineticEnergy(q_, qd_);
  }
  double PotentialEnergy() {
    if (stepped_) return stepped_->potential_energy();
    if (energies_cached_) return potential_;
    return floating_ ? FloatingPotentialEnergy() : model_.PotentialEnergy(q_);
  }
  // MuJoCo steps the plant (the scene's plant: {type: mujoco}); model() is then the controllers' model only.
  // Null for every other plant.
  const SteppedPlantData* stepped_plant() const { return stepped_.get(); }

  PlantModel& model() { return model_; }
  const Integrator& integrator() const { return *integrator_; }
  // What the last step's integration did (Integrator::work): on a floating base, the floating integrator's
  // sub-steps over the tick (integrator() is then the joints' and never steps).
  const IntegratorWork& integrator_work() const { return floating_ ? fwork_ : integrator_->work(); }

  // Run-time switching, between steps. Every integrator type and every method
  // the plant has were built in the constructor, so none of these allocates.
  // Each returns why it was refused (a static string, the scene reader's
  // wording where it has the same rule; nothing changed), or null.
  //   SetIntegrator  an external plant's (not integrated), kVariationalNeedsCoriolis,
  //                  CheckIntegratorConfig; the integrator starts over as one
  //                  built with these settings (dopri5's step proposal, the
  //                  variational Jacobian)
  //   SetEffect      an effect whose parameters the scene does not give,
  //                  coriolis off under the variational integrator; the energy
  //                  balance is re-based so ε runs on continuously (V may jump)
  //   SetMethod      a method the plant does not have (NoMethodReason)
  // q̈ of the current state is left as it is until the next step.
  const char* SetIntegrator(const IntegratorConfig& config);
  // Why SetIntegrator would refuse `config`, changing nothing; null when it would not.
  const char* CheckIntegrator(const IntegratorConfig& config) const;
  const char* SetEffect(EffectKind kind, bool on);
  const char* SetMethod(Method method);
  Method method() const { return model_.method(); }

  // The energy balance (plant/energy_balance.hpp) over every step since
  // start or Reset. A stepped (mujoco) plant's: E its simulator's T + V,
  // the command's work tau·Δq and the rest's (damping, friction loss, limits,
  // contacts) as the simulator's forces give it (SteppedPlantData::other_work).
  // Otherwise:
  // start or Reset: each step adds its tick, a held command's work exactly
  // (tau·Δq) and the rest's by the trapezoid rule (a continuous law's too). Kept when `accounting` (the
  // scene's telemetry, or its energy_balance bound) is on; it then costs one ComputeEffectForces without
  // gravity and Coriolis terms per step. An external plant keeps none, nor a floating base MuJoCo steps.
  // A floating base (lagrange's): E = T + V of the whole robot (floating model); every joint force, the
  // command and the rest alike, is held over each sub-step, so W adds its work exactly (HeldWork: Σ over the
  // sub-steps of Δqᵀ (tau_applied + disturbance + damping + friction + limits − limit_springs); the base's
  // force is zero) and nothing goes through the trapezoid rule (quadrature_bound() stays 0): ε is the
  // integrator's, plus a stop spring's hold error while a joint is past a stop.
  bool accounting() const { return accounting_; }
  const EnergyBalance& energy_balance() const { return balance_; }
  double power() const { return power_end_; }  // W, at the last step's end under its command
  // Every effect's force at the current state under the last step's command
  // (what <NAME>_FORCES carries); `out` sized for this plant. No allocation.
  // A stepped (mujoco) plant's are its simulator's own terms, constraint
  // forces and contacts (SteppedPlantData::ComputeForces). A floating base's
  // are the joints' rows (n) of its nv: gravity and coriolis the floating
  // model's G(q) and C(q, v) v (each only when its effect is on), so that
  //   [M(q) floating_a()]_joints = NetForce = tau_applied + ... − coriolis − gravity,
  // while the base's rows, unactuated, are M_b(q) v̇ + (C v)_b + G_b = 0.
  void ComputeForces(EffectForces& out);

 private:
  // The active controller as a law evaluated at every integrator stage.
  class StageLaw final : public ControlLaw {
   public:
    void Bind(Controller& controller, const Setpoint& setpoint);
    void Compute(double t, ConstVecRef q, ConstVecRef qd, VecRef tau_cmd) override;
    bool ok = true;  // false once the law gave a non-finite torque

   private:
    Controller* controller_ = nullptr;
    const Setpoint* setpoint_ = nullptr;
  };

  StepFailure Integrate(double dt, ConstVecRef tau_cmd);
  // After a step of length dt from (q_start_, qd_start_), with
  // tau_applied_start applied at its start (`held`: over all of it): adds the
  // tick to the balance.
  void Account(double dt, ConstVecRef tau_applied_start, bool held);
  // Restarts the balance at the current state.
  void ResetBalance();
  // power_end_ and rest_power_ at the current state under tau_cmd_ (the
  // effects as they are now), without a tick to account.
  void ComputePowers();
  StepFailure IntegrateContinuous(double dt, const Setpoint& setpoint, Controller& law);
  // A stepped plant's step of length dt under tau_ (held), and its balance.
  StepFailure StepPlant(double dt);
  // Puts a stepped plant's simulator at the current state (the full q, v of a floating base).
  void SetSteppedState();
  // A floating base's tick: its forces' work over the tick (`held_work`, J) to the balance.
  void AccountHeld(double dt, double held_work);
  // (q, v) => kinetic_, potential_ afresh (a floating base's: the whole robot's); returns T + V, J.
  double ComputeEnergies();
  // A floating base's V at fq_: gravity's potential when on, plus the stops' springs, J.
  double FloatingPotentialEnergy();
  // (q, v) => out's gravity and coriolis rows: the floating model's G and C v, joints' rows, each when on.
  void ComputeFloatingBiasRows(EffectForces& out);
  // After SetState or SetBaseState: the simulator there, q̈ under the last command, the balance re-based.
  void SettleAtNewState();
  // SetState's and SetBaseState's placing, before SettleAtNewState.
  void PlaceJoints(ConstVecRef q, ConstVecRef qd);
  void PlaceBase(ConstVecRef base_q, ConstVecRef base_v);
  // A floating stepped plant's forces (ComputeForces) through fforces_.
  void ComputeFloatingSteppedForces(EffectForces& out);
  // A floating base's step of length dt under tau_cmd (held), on its manifold.
  StepFailure StepFloating(double dt, ConstVecRef tau_cmd);
  // (t, q, qd, tau_cmd) => qdd_ at the current state (the floating model's for a floating base).
  void ComputeAcceleration(double t, ConstVecRef tau_cmd);

  std::shared_ptr<const InstanceModel> instance_model_;
  bool external_;  // the plant is outside: nothing is integrated
  std::unique_ptr<SteppedPlantData> stepped_;  // MuJoCo steps the plant; null: lagrange integrates model_
  PlantModel model_;
  // A floating base: its model (the instance model's), data, integrators by
  // IntegratorType (null but explicit-euler, semi-implicit-euler and rk4), the
  // one in use and its sub-steps, the full state and scratch: tau and a (nv).
  const FloatingDynamics* floating_ = nullptr;
  std::unique_ptr<FloatingData> fdata_;
  std::vector<std::unique_ptr<FloatingIntegrator>> fintegrators_;
  FloatingIntegrator* fintegrator_ = nullptr;
  IntegratorWork fwork_;  // the floating integrator's work over the last tick (integrator_work)
  int fsubsteps_ = 1;
  VectorXd fq_, fv_, ftau_, fa_;
  VectorXd fzero_, fbias_;  // (nv) a zero acceleration; G or C v (ComputeFloatingBiasRows' scratch)
  MatrixXd fjc_;  // (3 x nv) the centre of mass's Jacobian (ComputeBaseMotion's scratch)
  std::unique_ptr<EffectForces> fforces_;                 // a floating stepped plant's forces, nv rows (null otherwise)
  Integrator* integrator_;                                // the one in use, one of integrators_
  std::vector<std::unique_ptr<Integrator>> integrators_;  // by IntegratorType
  std::vector<std::unique_ptr<Controller>> controllers_;  // [0] is the scene's controller
  std::size_t active_ = 0;
  std::vector<bool> continuous_;                   // by controller index
  std::vector<ExternalController*> externals_;     // by controller index, null for other types
  std::vector<MpcController*> mpcs_;               // by controller index, null for other types
  std::vector<TaskSpaceController*> task_spaces_;  // by controller index, null for other types
  std::vector<Gains> scene_gains_;                 // by controller index: what Reset restores
  StageLaw stage_law_;
  std::unique_ptr<Trajectory> trajectory_;
  double trajectory_start_ = 0.0;  // s: the instance time the trajectory's time counts from
  double t_ = 0.0;
  std::int64_t steps_ = 0;
  VectorXd q_, qd_, qdd_, tau_, tau_cmd_, q_des_;
  Setpoint setpoint_;  // scratch for Step(dt)
  Setpoint ahead_;     // scratch for SampleTrajectoryAhead
  // Energy balance.
  bool accounting_;
  EnergyBalance balance_;
  EffectForces forces_;      // scratch: the effects at a step's end
  VectorXd q_start_;         // scratch: q at a step's start
  VectorXd qd_start_;        // scratch: qd at a step's start
  VectorXd tau_start_;       // scratch: a continuous law's applied force at a step's start
  double rest_power_ = 0.0;  // the non-command power at the last step's end (power_end_ − qdᵀ tau_applied)
  double power_end_ = 0.0;
  // T and V of the current state as Account computed them (the health check
  // reads them instead of computing M(q) again); false once the state or V changes.
  bool energies_cached_ = false;
  double kinetic_ = 0.0, potential_ = 0.0;
};

}  // namespace lagrange
