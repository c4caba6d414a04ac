#include "controllers/mpc.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "base/number_text.hpp"

namespace lagrange {

namespace {

// A weight vector as given, or `fallback` on every entry when empty.
VectorXd WeightOr(const VectorXd& given, int size, double fallback) {
  return given.size() > 0 ? given : VectorXd::Constant(size, fallback);
}

std::optional<std::string> CheckWeights(const char* key, const VectorXd& w, int size, bool positive) {
  if (w.size() == 0) return std::nullopt;
  const bool ok = w.size() == size && w.allFinite() && (positive ? (w.array() > 0.0).all() : (w.array() >= 0.0).all());
  if (ok) return std::nullopt;
  return std::string("weights.") + key + ": expected one number or " + std::to_string(size) + " finite values " +
         (positive ? "> 0" : ">= 0") + (size == 1 ? "" : " (one per " + std::string(positive ? "actuated joint" : "joint") + ")");
}

// The effects the optimiser models when the plant has them on (MpcEffects, MpcPlanner::FollowEffects): the
// smooth ones; the rest stay out (mpc.hpp, MpcEffects).
constexpr std::array<EffectKind, 3> kModelledEffects{EffectKind::kGravity, EffectKind::kCoriolis,
                                                     EffectKind::kDamping};

}  // namespace

std::vector<int> MpcActuated(const MpcOptions& o, int n, bool cart_pole) {
  if (o.actuated) return *o.actuated;
  if (cart_pole) return {0};
  std::vector<int> all(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
  return all;
}

std::optional<int> MpcFrame(const MpcOptions& o, const Kinematics& kinematics) {
  if (o.frame.empty()) return std::nullopt;
  return kinematics.FrameIndex(o.frame);
}

std::optional<std::string> ValidateMpc(const MpcOptions& o, int n, bool cart_pole, double period) {
  if (o.horizon < 1 || o.horizon > kMaxMpcHorizon) {
    return "horizon: expected 1 to " + std::to_string(kMaxMpcHorizon) + " knots";
  }
  if (!(std::isfinite(o.dt) && o.dt >= period && o.dt <= 1.0)) {
    return "dt: expected " + FormatDouble(period) + " to 1 s (at least the tick's period)";
  }
  if (const char* reason = NoStepDerivativesReason(o.integrator)) {
    return "integrator: expected explicit-euler, semi-implicit-euler or rk4 (" + std::string(reason) + ")";
  }
  if (o.iterations < 1 || o.iterations > kMaxMpcIterations) {
    return "iterations: expected 1 to " + std::to_string(kMaxMpcIterations) + " per solve";
  }
  if (!(std::isfinite(o.replan_period) && o.replan_period >= 0.0 && o.replan_period <= o.horizon * o.dt)) {
    return "replan_period: expected 0 (every knot) to the horizon's " + FormatDouble(o.horizon * o.dt) + " s";
  }
  if (o.replan_period > 0.0 && o.replan_period < period) {
    return "replan_period: expected at least the tick's period (" + FormatDouble(period) + " s), or 0";
  }
  const std::vector<int> act = MpcActuated(o, n, cart_pole);
  if (act.empty()) return std::string("actuated: expected at least one joint");
  for (std::size_t k = 0; k < act.size(); ++k) {
    if (act[k] < 0 || act[k] >= n || (k > 0 && act[k] <= act[k - 1])) {
      return "actuated: expected ascending joint indices from 0 to " + std::to_string(n - 1);
    }
  }
  const int m = static_cast<int>(act.size());
  if (auto e = CheckWeights("q", o.q, n, false)) return e;
  if (auto e = CheckWeights("qd", o.qd, n, false)) return e;
  if (auto e = CheckWeights("tau", o.tau, m, true)) return e;
  if (auto e = CheckWeights("q_terminal", o.q_terminal, n, false)) return e;
  if (auto e = CheckWeights("qd_terminal", o.qd_terminal, n, false)) return e;
  for (const auto& [key, w] : {std::pair{"pose_weight", &o.pose_weight}, std::pair{"pose_terminal_weight", &o.pose_terminal_weight}}) {
    if (!(w->allFinite() && (w->array() >= 0.0).all())) {
      return std::string(key) + ": expected [position (1/m²), rotation (1/rad²)], finite and >= 0";
    }
    if (o.frame.empty() && !w->isZero(0.0)) return std::string(key) + ": expected a frame (frame: NAME) to weigh";
  }
  if (!o.frame.empty() && o.pose_weight.isZero(0.0) && o.pose_terminal_weight.isZero(0.0)) {
    return std::string("pose_weight: expected a weight > 0 on the frame's pose (here or in pose_terminal_weight)");
  }
  if (o.frame.empty() && o.trajectory.target) {
    return std::string("trajectory: expected a frame (frame: NAME) to move");
  }
  if (!o.frame.empty()) {
    if (auto e = ValidatePoseTrajectory(o.trajectory)) return "trajectory." + *e;
  }
  return std::nullopt;
}

DdpWeights MpcWeights(const MpcOptions& o, int n, int m) {
  const bool frame = !o.frame.empty();  // the pose error replaces the joint error
  return {WeightOr(o.q, n, frame ? 0.0 : 1.0), WeightOr(o.qd, n, 0.01), WeightOr(o.tau, m, 0.01),
          WeightOr(o.q_terminal, n, frame ? 0.0 : 100.0), WeightOr(o.qd_terminal, n, 1.0)};
}

EffectsConfig MpcEffects(const EffectsConfig& plant) {
  EffectsConfig e;
  e.gravity = plant.gravity;
  e.coriolis = plant.coriolis;
  e.damping = plant.damping;
  for (EffectKind kind : plant.off) {
    if (std::find(kModelledEffects.begin(), kModelledEffects.end(), kind) != kModelledEffects.end()) e.off.push_back(kind);
  }
  return e;
}

std::shared_ptr<const DdpModel> MakeMpcModel(const MpcOptions& o, std::shared_ptr<const Dynamics> dynamics,
                                             const EffectsConfig& effects, const VectorXd& torque_limits,
                                             bool cart_pole, std::shared_ptr<const Kinematics> kinematics) {
  const int n = dynamics->num_dofs();
  DdpConfig c;
  c.integrator = o.integrator;
  c.dt = o.dt;
  c.horizon = o.horizon;
  c.actuated = MpcActuated(o, n, cart_pole);
  const int m = static_cast<int>(c.actuated.size());
  c.tau_upper.resize(m);
  for (int j = 0; j < m; ++j) {
    const double limit = torque_limits[c.actuated[static_cast<std::size_t>(j)]];
    if (!std::isfinite(limit)) {
      throw std::invalid_argument("torque_limits: mpc needs a finite limit on every actuated joint (joint " +
                                  std::to_string(c.actuated[static_cast<std::size_t>(j)]) + ")");
    }
    c.tau_upper[j] = limit;
  }
  c.tau_lower = -c.tau_upper;
  c.weights = MpcWeights(o, n, m);
  if (!o.frame.empty()) {
    const std::optional<int> index = kinematics ? MpcFrame(o, *kinematics) : std::nullopt;
    if (!index) throw std::invalid_argument("frame: expected one of the model's frames, got '" + o.frame + "'");
    c.frame_cost = {std::move(kinematics), *index, o.pose_weight[0], o.pose_weight[1], o.pose_terminal_weight[0],
                    o.pose_terminal_weight[1]};
  }
  c.options.max_iterations = o.iterations;
  c.effects = effects;
  return std::make_shared<const DdpModel>(std::move(dynamics), std::move(c));
}

MpcPolicy::MpcPolicy(int n, int m, int N)
    : horizon(N), u(MatrixXd::Zero(m, N)), K(MatrixXd::Zero(m, 2 * n * N)), x(MatrixXd::Zero(2 * n, N + 1)) {}

std::int64_t MpcPolicy::Knot(double t) const {
  return static_cast<std::int64_t>(std::floor((t - start) / dt + 1e-9));  // a tick that lands on a knot is in it
}

void MpcPolicy::Evaluate(double t, ConstVecRef q, ConstVecRef qd, const VectorXd& lower, const VectorXd& upper,
                         VecRef out) const {
  const auto n = q.size();
  const auto k = static_cast<Eigen::Index>(std::clamp<std::int64_t>(Knot(t), 0, horizon - 1));
  // The time within knot k as a fraction of dt: 0 before the plan's start, 1 once its horizon has run out
  // (x̄_N, the plan's end). ū goes linearly toward ū_{k+1} (the last knot's ū is held: there is no ū_N).
  const double s = std::clamp((t - start) / dt - static_cast<double>(k), 0.0, 1.0);
  const auto next = std::min<Eigen::Index>(k + 1, horizon - 1);
  EvaluateAffinePolicy(u.col(k), u.col(next), K.middleCols(2 * n * k, 2 * n), x.col(k), x.col(k + 1), s, q, qd, lower,
                       upper, out);
}

MpcPlanner::MpcPlanner(std::shared_ptr<const DdpModel> model)
    : model_(std::move(model)),
      data_(*model_),
      dynamics_data_(model_->dynamics()->MakeData()),
      gravity_(VectorXd::Zero(model_->num_dofs())),
      hold_(VectorXd::Zero(model_->num_controls())) {}

MpcPolicy MpcPlanner::MakePolicy() const {
  return MpcPolicy(model_->num_dofs(), model_->num_controls(), model_->horizon());
}

void MpcPlanner::Reset() {
  data_.Reset();
  warm_ = false;
}

void MpcPlanner::FollowEffects(const EffectFlags& plant) {
  Effects& modelled = data_.effects();
  for (EffectKind kind : kModelledEffects) {
    const bool on = FlagOf(plant, kind);
    if (FlagOf(modelled.flags(), kind) != on) modelled.SetEnabled(kind, on);  // damping the model lacks: stays off
  }
}

DdpStatus MpcPlanner::Plan(double t, ConstVecRef q, ConstVecRef qd, const Eigen::Ref<const MatrixXd>& q_ref,
                           const Eigen::Ref<const MatrixXd>& qd_ref, MpcPolicy& out, const std::atomic<bool>* stop,
                           const PoseTarget* pose) {
  const DdpModel& model = *model_;
  const int n = model.num_dofs(), N = model.horizon();
  // Warm start: the previous plan from the knot this one starts at.
  if (warm_ && t >= last_start_) {
    // Whole knots and the fraction between (a plan may start between knots); round-off below 1e-9 of a knot dropped.
    const double knots = (t - last_start_) / model.dt();
    const double nearest = std::round(knots);
    data_.ShiftSolution(std::min<double>(N, std::abs(knots - nearest) < 1e-9 ? nearest : knots));
  } else if (data_.effects().flags().gravity && q.allFinite()) {
    model.dynamics()->ComputeGravityForce(*dynamics_data_, q, gravity_);
    for (int j = 0; j < model.num_controls(); ++j) hold_[j] = gravity_[model.actuated()[static_cast<std::size_t>(j)]];
    data_.HoldControls(hold_);
  } else {
    data_.Reset();
  }
  if (q_ref.cols() == N + 1 && qd_ref.cols() == N + 1) {
    data_.q_ref = q_ref;
    data_.qd_ref = qd_ref;
  } else {
    data_.q_ref.colwise() = q_ref.col(0);
    data_.qd_ref.colwise() = qd_ref.col(0);
  }
  if (pose != nullptr && model.has_frame_cost()) {
    PoseSetpoint sample;
    for (int k = 0; k <= N; ++k) {
      pose->Sample(t + k * model.dt(), sample);
      data_.pose_ref[static_cast<std::size_t>(k)] = sample.pose;
    }
  }
  data_.stop = stop;
  const DdpResult& r = SolveDdp(model, data_, q, qd);
  data_.stop = nullptr;
  warm_ = IsUsable(r.status) || r.status == DdpStatus::kStopped;
  last_start_ = t;
  if (!warm_) data_.Reset();
  out.sequence = ++sequence_;
  out.start = t;
  out.dt = model.dt();
  out.horizon = N;
  out.status = r.status;
  out.iterations = r.iterations;
  out.cost_before = r.cost_history.size() > 0 ? r.cost_history[0] : r.cost;
  out.cost = r.cost;
  out.u = data_.u();
  out.x = data_.x();
  for (int k = 0; k < N; ++k) out.K.middleCols(2 * n * k, 2 * n) = data_.K(k);
  return r.status;
}

MpcController::MpcController(std::vector<JointType> joints, VectorXd torque_limits,
                             std::shared_ptr<const DdpModel> model, double replan_period,
                             PoseTrajectoryConfig trajectory)
    : Controller(std::move(joints), std::move(torque_limits)),
      model_(std::move(model)),
      replan_period_(replan_period),
      planner_(std::make_unique<MpcPlanner>(model_)),
      policy_(planner_->MakePolicy()),
      candidate_(planner_->MakePolicy()),
      u_(VectorXd::Zero(model_->num_controls())),
      reference_{MatrixXd::Zero(model_->num_dofs(), model_->horizon() + 1),
                 MatrixXd::Zero(model_->num_dofs(), model_->horizon() + 1)},
      scene_trajectory_(trajectory),
      target_(std::move(trajectory)) {
  if (model_->has_frame_cost()) kinematics_data_ = model_->config().frame_cost.kinematics->MakeData();
}

void MpcController::SetPoseTarget(const PoseSetpoint& setpoint) { target_.Set(setpoint); }

void MpcController::MoveTo(const Pose& target, double duration) { target_.MoveTo(target, duration); }

void MpcController::HoldPoseTarget(double t) { target_.Hold(t); }

void MpcController::MeasureTask(double t, ConstVecRef q, ConstVecRef qd, Pose& pose, Pose& commanded,
                                Vector6d& error, Vector6d& twist) {
  const DdpFrameCost& f = model_->config().frame_cost;
  PoseReference(t, q);
  f.kinematics->ComputeFrameJacobian(*kinematics_data_, q, f.frame, FrameAxes::kWorldAligned);
  pose.position = kinematics_data_->position(f.frame);
  pose.orientation = Eigen::Quaterniond(kinematics_data_->rotation(f.frame));
  PoseSetpoint now;
  target_.Sample(t, now);
  commanded = now.pose;
  error = PoseError(commanded, pose);
  twist.noalias() = kinematics_data_->jacobian(f.frame, FrameAxes::kWorldAligned) * qd;
}

const PoseTarget& MpcController::PoseReference(double t, ConstVecRef q) {
  if (target_.start_pending() && kinematics_data_) {
    const DdpFrameCost& f = model_->config().frame_cost;
    f.kinematics->ComputeFramePlacement(*kinematics_data_, q, f.frame);
    target_.Begin(t, {kinematics_data_->position(f.frame), Eigen::Quaterniond(kinematics_data_->rotation(f.frame))});
  }
  return target_;
}

void MpcController::set_plan_inline(bool on) {
  if (on && !planner_) planner_ = std::make_unique<MpcPlanner>(model_);
  if (!on) planner_.reset();
}

void MpcController::Reset() {
  policy_.sequence = 0;
  planned_ = false;
  solves_ = failed_ = 0;
  failed_by_status_.fill(0);
  reference_ready_ = false;
  if (planner_) planner_->Reset();
  target_.Start(scene_trajectory_);
}

void MpcController::ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  // Offline: a solve every replan_period of simulated time; a failed one's policy is not taken (the last
  // usable one is followed, its last knot held once its horizon runs out).
  if (plan_due(t)) {
    const PoseTarget* pose = has_frame() ? &PoseReference(t, q) : nullptr;
    const DdpStatus status = reference_ready_
                                 ? planner_->Plan(t, q, qd, reference_.q, reference_.qd, candidate_, nullptr, pose)
                                 : planner_->Plan(t, q, qd, sp.q, sp.qd, candidate_, nullptr, pose);
    reference_ready_ = false;
    ++solves_;
    if (IsUsable(status)) {
      std::swap(policy_, candidate_);
    } else {
      ++failed_;
      ++failed_by_status_[static_cast<std::size_t>(status)];
    }
    planned_ = true;
    next_plan_ = t + replan_period_;
  }
  tau.setZero();
  if (policy_.sequence == 0) return;
  policy_.Evaluate(t, q, qd, model_->tau_lower(), model_->tau_upper(), u_);
  const std::vector<int>& act = model_->actuated();
  for (std::size_t j = 0; j < act.size(); ++j) tau[act[j]] = u_[static_cast<Eigen::Index>(j)];
}

}  // namespace lagrange
