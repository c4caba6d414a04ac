#include "sim/work_bound.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "plant/floating_integrator.hpp"
#include "plant/plant_model.hpp"
#include "protocol/status.hpp"
#include "sim/instance.hpp"
#include "sim/instance_model.hpp"

namespace lagrange {
namespace {

constexpr int kWarmUpCalls = 20;
constexpr int kBatches = kMaxCostSamples;  // 20 batches of 10: the ~200 timed calls
constexpr int kCallsPerBatch = 10;         // a batch amortises the clock read over several calls
// The most one measurement may take, warm-up included: a slow evaluation (a
// Lagrangian 64-link chain takes ~10 ms) is timed over fewer batches, at
// least one call, so start-up stays short whatever the scene.
constexpr double kMeasureBudget = 0.05;  // s

using Steady = std::chrono::steady_clock;

double SecondsSince(Steady::time_point t) { return std::chrono::duration<double>(Steady::now() - t).count(); }

// FastestOfSamples on the steady clock, from now.
double FastestSample(double budget, const std::function<double()>& sample) {
  const Steady::time_point begin = Steady::now();
  return FastestOfSamples(sample, budget, [&] { return SecondsSince(begin); });
}

// The instance's initial state (q0, qd0): on a floating base the whole state, the base's pose and twist
// leading it (nq and nv), whether MuJoCo or lagrange integrates it. Its callers bind references to the pair's
// members, not a structured binding: their lambdas capture them, which clang 14 (scripts/fuzz's) refuses.
std::pair<VectorXd, VectorXd> InitialState(const InstanceConfig& config) {
  if (!config.floating) return {config.q0, config.qd0};
  VectorXd q(kFreeFlyerNq + config.q0.size()), qd(kFreeFlyerNv + config.qd0.size());
  q << config.floating->q0, config.q0;
  qd << config.floating->v0, config.qd0;
  return {q, qd};
}

std::int64_t SaturatingMul(std::int64_t a, std::int64_t b) {
  if (a != 0 && b > std::numeric_limits<std::int64_t>::max() / a) return std::numeric_limits<std::int64_t>::max();
  return a * b;
}

// What the scene can change, with the largest max_steps that would fit for dopri5.
std::string WhatToLower(const IntegratorConfig& config, double evaluations_that_fit) {
  if (config.type != IntegratorType::kDormandPrince) return "integrator.substeps";
  const double max_steps = LargestMaxStepsThatFit(evaluations_that_fit, config.substeps);
  if (max_steps < 1.0) return "integrator.max_steps or integrator.substeps";
  return fmt::format("integrator.max_steps (at most {:.0f} fits) or integrator.substeps", max_steps);
}

// "rk4 worst case 5 evaluations × 0.03 µs + 2.1 µs"; a MuJoCo plant's
// integrator by MuJoCo's name ("mujoco-implicit worst case 1 evaluations ...":
// one evaluation is one tick of MuJoCo's steps).
std::string Describe(const WorkBound& b, const InstanceConfig& instance) {
  const std::optional<MujocoIntegrator> mujoco =
      instance.mujoco ? std::optional(instance.mujoco->integrator) : std::nullopt;
  return fmt::format("{} worst case {} evaluations × {:.3g} µs + {:.3g} µs",
                     IntegratorName(instance.integrator.type, instance.external.has_value(), mujoco), b.evaluations,
                     b.evaluation_s * 1e6, b.overhead_s * 1e6);
}

}  // namespace

double FastestOfSamples(const std::function<double()>& sample, double budget, const std::function<double()>& elapsed) {
  double fastest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < kMaxCostSamples && (k < kMinCostSamples || elapsed() < budget); ++k) {
    fastest = std::min(fastest, sample());
  }
  return fastest;
}

double LargestMaxStepsThatFit(double evaluations_that_fit, int substeps) {
  return std::floor(((evaluations_that_fit - 1.0) / std::max(1, substeps) - 1.0) / 6.0);
}

std::int64_t WorstCaseEvaluations(const IntegratorConfig& config, int num_dofs) {
  std::int64_t per_step = 1;
  switch (config.type) {
    case IntegratorType::kExplicitEuler:
    case IntegratorType::kSemiImplicitEuler: per_step = 1; break;
    case IntegratorType::kRk4: per_step = 4; break;
    case IntegratorType::kDormandPrince: per_step = 1 + SaturatingMul(6, config.max_steps); break;
    case IntegratorType::kVariational:
      per_step = 3 + 2 * (static_cast<std::int64_t>(num_dofs) + 1) + config.newton_max_iterations;
      break;
  }
  const std::int64_t steps = SaturatingMul(per_step, std::max(1, config.substeps));
  return steps == std::numeric_limits<std::int64_t>::max() ? steps : steps + 1;
}

double MeasureEvaluationSeconds(const InstanceConfig& config) {
  PlantModel model(MakeDynamics(config.plant, config.method), config.effects);
  const int n = model.num_dofs();
  const VectorXd tau = VectorXd::Zero(n);
  VectorXd qdd(n);
  const Steady::time_point begin = Steady::now();
  // Warm up, and find how many calls a batch can afford.
  int calls = kCallsPerBatch;
  for (int i = 0; i < kWarmUpCalls && SecondsSince(begin) < 0.1 * kMeasureBudget; ++i) {
    model.ComputeAcceleration(0.0, config.q0, config.qd0, tau, qdd);
  }
  return FastestOfSamples(
      [&] {
        const Steady::time_point start = Steady::now();
        for (int i = 0; i < calls; ++i) model.ComputeAcceleration(0.0, config.q0, config.qd0, tau, qdd);
        const double batch = SecondsSince(start);
        const double each = batch / calls;
        if (batch > kMeasureBudget / kBatches) calls = 1;  // slow calls: one per batch
        return each;
      },
      kMeasureBudget, [&] { return SecondsSince(begin); });
}

double MeasureSteppedSeconds(const InstanceConfig& config) {
  const std::unique_ptr<SteppedPlantData> data = config.mujoco->model->MakeData();
  const std::pair<VectorXd, VectorXd> state = InitialState(config);
  const VectorXd &q0 = state.first, &qd0 = state.second;
  VectorXd q = q0, qd = qd0, qdd(qd0.size());
  const VectorXd tau = VectorXd::Zero(qd0.size());
  const double fastest = FastestSample(kMeasureBudget, [&] {
    data->SetState(q0, qd0);  // every step from the initial state
    const Steady::time_point start = Steady::now();
    data->Step(tau, q, qd, qdd);
    return SecondsSince(start);
  });
  return std::isfinite(fastest) ? fastest : 0.0;
}

std::array<double, 3> MeasureEvaluationCosts(const InstanceConfig& config) {
  std::array<double, 3> costs{};
  if (config.mujoco) {  // one tick of MuJoCo's steps, by whichever method the controllers' model is derived
    const double step = MeasureSteppedSeconds(config);
    for (const Method m : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
      if (HasMethod(config.plant.type(), m)) costs[static_cast<std::size_t>(m)] = step;
    }
    return costs;
  }
  for (const Method m : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
    if (!HasMethod(config.plant.type(), m)) continue;
    InstanceConfig c = config;
    c.method = m;
    // Every effect a command can switch on, on: the costliest combination.
    c.effects.off.clear();
    c.effects.gravity = true;
    c.effects.coriolis = true;
    costs[static_cast<std::size_t>(m)] = MeasureEvaluationSeconds(c);
  }
  return costs;
}

namespace {

// The tick's work for an active mpc controller beyond its step (daemon/runtime.cpp): the state offered to
// its optimiser (OfferState) with the reference over the plan's N + 1 knots, the trajectory sampled ahead
// (the worst case: a streamed setpoint is copied), and with a frame its target (PoseReference) and the task
// record's measured pose, error and twist (MeasureTask: the frame's Jacobian). Buffers sized once.
class MpcTickWork {
 public:
  explicit MpcTickWork(const MpcController& mpc)
      : q_ref_(MatrixXd::Zero(mpc.ddp_model()->num_dofs(), mpc.ddp_model()->horizon() + 1)), qd_ref_(q_ref_) {}
  void Run(Instance& instance, MpcController& mpc) {
    instance.SampleTrajectoryAhead(mpc.ddp_model()->dt(), q_ref_, qd_ref_);
    if (!mpc.has_frame()) return;
    mpc.PoseReference(instance.t(), instance.q());
    mpc.MeasureTask(instance.t(), instance.q(), instance.qd(), pose_, commanded_, error_, twist_);
  }

 private:
  MatrixXd q_ref_, qd_ref_;
  Pose pose_, commanded_;
  Vector6d error_, twist_;
};

// One explicit Euler step makes the fewest evaluations, whatever the scene's
// integrator would (a stiff scene's dopri5 tick may take seconds).
InstanceConfig OverheadConfig(const InstanceConfig& config) {
  InstanceConfig c = config;
  c.integrator = IntegratorConfig{};
  c.integrator.type = IntegratorType::kExplicitEuler;
  return c;
}

}  // namespace

double MeasureTickOverheadSeconds(Instance& instance, double evaluation_s) {
  const double period = 1e-3;  // the step's length does not change its work
  // Under every controller the instance has (a command may switch to any), the costliest.
  const std::size_t controllers = instance.controller_names().size();
  double costliest = 0.0;
  // An mpc controller's tick evaluates a plan (a zero plan here, as costly as any); the plan is made on a
  // thread of its own (daemon/mpc_worker.hpp), bounded apart (MpcBoundRefusal). Reset drops it: given again.
  MpcPolicy plan;
  for (std::size_t j = 0; j < controllers; ++j) {
    if (MpcController* mpc = instance.mpc_controller(j)) {
      mpc->set_plan_inline(false);
      plan = mpc->policy();
      plan.sequence = 1;
      plan.dt = mpc->ddp_model()->dt();
    }
  }
  const auto give_plan = [&] {
    if (MpcController* mpc = instance.mpc_controller(instance.active_controller())) mpc->SetPolicy(plan);
  };
  for (std::size_t k = 0; k < controllers; ++k) {
    instance.SelectController(k);
    give_plan();
    MpcController* mpc = instance.mpc_controller(k);
    std::optional<MpcTickWork> mpc_work;
    if (mpc != nullptr) mpc_work.emplace(*mpc);
    costliest = std::max(costliest, FastestSample(kMeasureBudget / static_cast<double>(controllers), [&] {
                           const Steady::time_point start = Steady::now();
                           instance.Step(period);
                           if (mpc_work) mpc_work->Run(instance, *mpc);
                           const double step = SecondsSince(start);
                           const auto evaluations = static_cast<double>(instance.integrator_work().evaluations + 1);
                           instance.Reset();  // every step from the initial state
                           give_plan();
                           return step - evaluations * evaluation_s;
                         }));
  }
  return std::max(0.0, costliest);
}

double MeasureForcesSeconds(const InstanceConfig& config) {
  Instance instance(config);
  EffectForces forces(static_cast<int>(config.q0.size()));
  const double fastest = FastestSample(kMeasureBudget, [&] {
    const Steady::time_point start = Steady::now();
    instance.ComputeForces(forces);
    return SecondsSince(start);
  });
  return std::isfinite(fastest) ? fastest : 0.0;
}

double MeasureMpcIterationSeconds(const Instance& instance) {
  const InstanceConfig& config = instance.config();
  for (std::size_t k = 0; k < instance.controller_names().size(); ++k) {
    const MpcController* mpc = instance.mpc_controller(k);
    if (mpc == nullptr) continue;
    DdpConfig one = mpc->ddp_model()->config();
    one.options.max_iterations = 1;
    const DdpModel model(mpc->ddp_model()->dynamics(), std::move(one));
    DdpData data(model);
    data.q_ref.colwise() = config.q0;
    const double fastest = FastestSample(kMeasureBudget, [&] {
      data.Reset();
      const Steady::time_point start = Steady::now();
      SolveDdp(model, data, config.q0, config.qd0);
      return SecondsSince(start);
    });
    return std::isfinite(fastest) ? fastest : 0.0;
  }
  return 0.0;
}

std::optional<std::string> MpcBoundRefusal(const DaemonModel& model) {
  for (std::size_t i = 0; i < model.instances.size(); ++i) {
    const InstanceModel& m = model.instances[i];
    for (const ControllerModel& c : m.controllers) {
      if (!c.mpc) continue;
      const MpcOptions& o = c.config.mpc;
      const double solve = o.iterations * m.mpc_iteration_s;
      const double replan = MpcReplanPeriod(o);
      const double horizon = o.horizon * o.dt;
      if (solve + replan <= horizon) continue;
      return fmt::format(
          "{}: instances[{}] ({}): the mpc plan would run out before the next one: a solve ({} iterations x {:.3g} "
          "ms measured) plus replan_period {:.4g} s exceed its horizon of {:.4g} s ({} knots x {:.4g} s); lower "
          "iterations or horizon, or lengthen dt",
          model.file, i, m.name(), o.iterations, m.mpc_iteration_s * 1e3, replan, horizon, o.horizon, o.dt);
    }
  }
  return std::nullopt;
}

namespace {

double MeasureFloatingEvaluationSeconds(const InstanceModel& m) {
  const std::pair<VectorXd, VectorXd> state = InitialState(m.config);
  const VectorXd &q = state.first, &v = state.second;
  const std::unique_ptr<FloatingData> data = m.floating->MakeData();
  const VectorXd tau = VectorXd::Zero(v.size());
  VectorXd a(v.size());
  const double fastest = FastestSample(kMeasureBudget, [&] {
    const Steady::time_point start = Steady::now();
    m.floating->ComputeForwardDynamics(*data, q, v, tau, DynamicsTerms{}, a);
    return SecondsSince(start);
  });
  return std::isfinite(fastest) ? fastest : 0.0;
}

double MeasureFloatingResidualSeconds(const InstanceModel& m) {
  IntegratorConfig config = m.config.integrator;
  config.type = IntegratorType::kVariational;
  FloatingIntegrator integrator(config, *m.floating);
  const std::pair<VectorXd, VectorXd> state = InitialState(m.config);
  const VectorXd &q0 = state.first, &v0 = state.second;
  VectorXd q = q0, v = v0;
  const VectorXd tau = VectorXd::Zero(v0.size());
  const double h = 1e-3 / std::max(1, config.substeps);  // a step's length barely changes its work
  const double fastest = FastestSample(kMeasureBudget, [&] {
    integrator.Reconfigure(config);  // forgets the kept Jacobian: the step rebuilds it, as its worst case does
    q = q0;
    v = v0;
    const std::int64_t before = integrator.stats().evaluations;
    const Steady::time_point start = Steady::now();
    integrator.Step(h, tau, DynamicsTerms{}, q, v);
    const double step = SecondsSince(start);
    return step / static_cast<double>(std::max<std::int64_t>(1, integrator.stats().evaluations - before));
  });
  return std::isfinite(fastest) ? fastest : 0.0;
}

}  // namespace

void MeasureCosts(InstanceModel& m) {
  Instance instance(OverheadConfig(m.config));  // one private Instance for the tick's rest and the plan
  m.mpc_iteration_s = MeasureMpcIterationSeconds(instance);
  m.evaluation_s = MeasureEvaluationCosts(m.config);
  if (m.floating_base() && !m.config.mujoco) {
    // Every method steps the floating model (plant/floating_integrator.hpp): its forward dynamics is the
    // evaluation, whichever method the joints' model uses.
    const double floating = MeasureFloatingEvaluationSeconds(m);
    for (double& cost : m.evaluation_s) {
      if (cost > 0.0) cost = floating;
    }
    m.floating_residual_s = MeasureFloatingResidualSeconds(m);
  }
  m.tick_overhead_s = MeasureTickOverheadSeconds(instance, m.evaluation_s[static_cast<std::size_t>(m.config.method)]);
  m.forces_s = m.external_plant() ? 0.0 : MeasureForcesSeconds(m.config);
}

void MeasureCosts(DaemonModel& model) {
  for (InstanceModel& m : model.instances) MeasureCosts(m);
}

WorkBound WorkBoundOf(const InstanceModel& m, const IntegratorConfig& config, Method method, bool forces) {
  const double cost = m.evaluation_s[static_cast<std::size_t>(method)];
  const double overhead = m.tick_overhead_s + (forces ? m.forces_s : 0.0);
  if (m.external_plant()) return {m.name(), 0, cost, overhead};  // nothing is integrated
  if (m.config.mujoco) return {m.name(), 1, cost, overhead};     // the cost is one tick of MuJoCo's steps
  if (m.floating_base()) {  // integrated on the manifold, over nv; a variational step's evaluation is a residual
    const double each =
        config.type == IntegratorType::kVariational && m.floating_residual_s > 0.0 ? m.floating_residual_s : cost;
    return {m.name(), WorstCaseEvaluations(config, m.num_dofs + kFreeFlyerNv), each, overhead};
  }
  return {m.name(), WorstCaseEvaluations(config, m.num_dofs), cost, overhead};
}

std::vector<WorkBound> WorkBoundsOf(const DaemonModel& model) {
  std::vector<WorkBound> bounds;
  for (const InstanceModel& m : model.instances) {
    bounds.push_back(WorkBoundOf(m, m.config.integrator, m.config.method, m.config.forces));
  }
  return bounds;
}

std::optional<std::string> CheckWorkBounds(const DaemonModel& model) {
  const std::vector<WorkBound> bounds = WorkBoundsOf(model);
  double total = 0.0;
  std::size_t largest = 0;
  std::string parts;
  for (std::size_t i = 0; i < bounds.size(); ++i) {
    total += bounds[i].tick_s();
    if (bounds[i].tick_s() > bounds[largest].tick_s()) largest = i;
    parts += fmt::format("{}{}: {} = {:.3g} ms", parts.empty() ? "" : ", ", bounds[i].instance,
                         Describe(bounds[i], model.instances[i].config), bounds[i].tick_s() * 1e3);
  }
  const double budget = kTickBudgetFraction * model.period;
  if (bounds.empty() || total <= budget) return MpcBoundRefusal(model);
  const WorkBound& b = bounds[largest];
  const double free = budget - (total - b.tick_s()) - b.overhead_s;
  return fmt::format(
      "{}: the instances' worst case per tick, {:.4g} ms ({}), does not fit {:.0f} % of the period {:.4g} ms; for "
      "instances[{}] ({}), the largest, lower {}, or lengthen the period",
      model.file, total * 1e3, parts, kTickBudgetFraction * 100, model.period * 1e3, largest, b.instance,
      WhatToLower(model.instances[largest].config.integrator, b.evaluation_s > 0 ? free / b.evaluation_s : 0.0));
}

int DefaultMaxSteps(const InstanceModel& m, int substeps, double seconds_free) {
  const int scene = m.config.integrator.max_steps;
  const double costliest = *std::max_element(m.evaluation_s.begin(), m.evaluation_s.end());
  if (costliest <= 0.0) return scene;
  const double fit = LargestMaxStepsThatFit((seconds_free - m.tick_overhead_s) / costliest, substeps);
  if (fit < 1.0) return 0;
  return static_cast<int>(std::min<double>(scene, fit));
}

}  // namespace lagrange
