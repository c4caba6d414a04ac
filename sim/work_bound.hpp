#pragma once
// The longest a tick can take, bounded before the loop starts.
//
// A tick is one call per instance of the integrator over the period; an
// adaptive or implicit integrator may evaluate the right-hand side many times
// in it. The daemon only reads signals between ticks, so a tick that can run
// for seconds (dopri5 on a stiff scene, max_steps 1e7: 13.7 s) makes SIGTERM
// take that long, and instances that each fit but not together overrun every
// tick. So the whole tick is bounded, at load and at every switch command:
//
//   Σ over instances (evaluations(integrator, n) × cost of one evaluation + the rest of its tick)
//       ≤ kTickBudgetFraction × period
//
// Right-hand-side evaluations per tick, s = substeps, n = degrees of freedom
// (each integrator's Step, then one more for q̈ at the new state):
//   explicit-euler, semi-implicit-euler   s·1 + 1
//   rk4                                   s·4 + 1
//   dopri5                                s·(1 + 6·max_steps) + 1   (rejected steps count toward max_steps)
//   variational                           s·(3 + 2(n + 1) + newton_max_iterations) + 1
//                                         (predictor, first residual, two finite-difference
//                                          Jacobians of n + 1 residuals, one residual per
//                                          Newton iteration, the final M(q) solve)
// The cost of one evaluation is PlantModel::ComputeAcceleration at the
// instance's initial state, on a private model, by every method the plant has
// with every configured effect on (what a command can switch to), timed in
// batches; the fastest batch is taken, so a loaded machine does not inflate it
// (the bound is about the scene, not about the machine's load). Every cost is
// the fastest of at least kMinCostSamples samples whatever the time budget
// (FastestOfSamples): one sample the scheduler preempted (12.6 ms for a tick
// of microseconds, on a busy host) cannot become the cost and refuse the scene. The rest of
// its tick (controller, energy balance, health check) is timed the same way,
// under the costliest controller the scene configures; computing the
// per-effect forces (SET_FORCES on) is timed apart and counted while on.

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "sim/scene.hpp"

namespace lagrange {

class Instance;  // sim/instance.hpp

struct InstanceModel;
struct DaemonModel;

// The share of the period the instances' worst cases may take together; the
// rest is kept for the wake-up's lateness and the hand-over to the publisher.
inline constexpr double kTickBudgetFraction = 0.8;

// A cost is timed as the least of several samples (s): a sample is the cost
// plus whatever delayed it (preemption, an interrupt, a cold cache), never
// less. At least kMinCostSamples whatever the budget, then more while less than
// `budget` s have passed by `elapsed` (s since the first sample began), at most
// kMaxCostSamples; +inf if a sample is. `sample` and `elapsed` are injectable so
// that tests can replay a preempted sample without timing anything.
inline constexpr int kMinCostSamples = 5;
inline constexpr int kMaxCostSamples = 20;
double FastestOfSamples(const std::function<double()>& sample, double budget, const std::function<double()>& elapsed);

// dopri5: the largest max_steps whose worst case, s·(1 + 6·max_steps) + 1,
// stays within `evaluations_that_fit` (< 1: none does).
double LargestMaxStepsThatFit(double evaluations_that_fit, int substeps);

// Worst-case right-hand-side evaluations of one tick (see above).
std::int64_t WorstCaseEvaluations(const IntegratorConfig& config, int num_dofs);

// A mujoco plant (MuJoCo steps it) counts one evaluation per tick, whose cost
// is one SteppedPlantData::Step (its substeps of mj_step and the end state's
// mj_forward) from (q0, qd0) under zero force, timed the same way
// (MeasureSteppedSeconds); its integrator is MuJoCo's, so nothing else is.
double MeasureSteppedSeconds(const InstanceConfig& config);
// The cost of one ComputeAcceleration for `config` at (q0, qd0), zero torque,
// s: the fastest of 5 to 20 batches, the batches after the fifth within 50 ms.
double MeasureEvaluationSeconds(const InstanceConfig& config);

// The same by every method the plant has (by Method; 0 for a method it lacks),
// with every effect the scene configures on (gravity, Coriolis and those in
// effects.off included): the costliest combination a command can switch to.
// (InstanceModel::evaluation_s, MeasureCosts.)
std::array<double, 3> MeasureEvaluationCosts(const InstanceConfig& config);

// The rest of one tick of the instance besides its integrator's evaluations
// (the controller, the energy balance, the trajectory, the health check; for
// an mpc controller also what lagranged's tick does for it beyond the step:
// the reference sampled over the plan's N + 1 knots for its optimiser and,
// with a frame, the frame's target and its Jacobian for the task record), s:
// `instance` (MeasureCosts': the scene's, by one explicit Euler step, the
// fewest evaluations) stepped under each controller the scene configures (a
// command may switch to any), its step time less the evaluations it made, the
// fastest of a few batches; the costliest controller's; within 50 ms in all.
// Leaves `instance` reset, under its last controller.
double MeasureTickOverheadSeconds(Instance& instance, double evaluation_s);

// What publishing <NAME>_FORCES adds to its tick (Instance::ComputeForces), s:
// the fastest of a few batches within 50 ms. Counted while forces are on.
double MeasureForcesSeconds(const InstanceConfig& config);

// The optimiser of an mpc controller (controllers/mpc.hpp) runs off the
// tick, on a thread of its own, but it too is bounded before the loop: a plan
// must be replaced before its horizon runs out, or the instance falls back
// every time. One DDP iteration of the plan (its first rollout and one
// iteration, from (q0, qd0) toward q0) is timed the same way, and
//   iterations × iteration_s + replan_period <= horizon × dt
// must hold (MpcBoundRefusal). 0 when `instance` has no mpc controller.
double MeasureMpcIterationSeconds(const Instance& instance);
// "<file>: instances[i] (<name>): the mpc plan ..." when an instance's plan
// would run out before the next one (the rule above), or nullopt. Costs of 0 count 0.
std::optional<std::string> MpcBoundRefusal(const DaemonModel& model);

// A pass over a built model: each instance's costs measured into it
// (evaluation_s by MeasureEvaluationCosts, tick_overhead_s by
// MeasureTickOverheadSeconds, forces_s by MeasureForcesSeconds; an
// external plant's forces are not computed: 0), before the loop starts and
// before CheckWorkBounds. Up to about 150 ms per instance.
void MeasureCosts(InstanceModel& m);
void MeasureCosts(DaemonModel& model);

// One instance's worst case per tick.
struct WorkBound {
  std::string instance;
  std::int64_t evaluations = 0;  // worst case per tick
  double evaluation_s = 0.0;     // cost of one
  double overhead_s = 0.0;       // the rest of its tick
  double tick_s() const { return static_cast<double>(evaluations) * evaluation_s + overhead_s; }
};

// Instance `m` by `config` and `method`, at its measured costs; with
// `forces`, publishing its <NAME>_FORCES too.
WorkBound WorkBoundOf(const InstanceModel& m, const IntegratorConfig& config, Method method, bool forces = false);
// Every instance's, as the scene configures it.
std::vector<WorkBound> WorkBoundsOf(const DaemonModel& model);

// The refusal when the instances' worst cases together exceed
// kTickBudgetFraction of the period: "<file>: the instances' worst case per
// tick, Y ms (arm: rk4 ... = a ms, ...), does not fit 80 % of the period P ms;
// for instances[i] (<name>), the largest, lower <what to lower>, or lengthen
// the period"; then MpcBoundRefusal; nullopt when they fit. Costs of 0 (not measured) count 0.
std::optional<std::string> CheckWorkBounds(const DaemonModel& model);

// dopri5 without max_steps given: the scene's, lowered to the largest that
// fits `seconds_free` at the costliest method the instance has (so that a
// later method switch still fits); 0 when not even one step fits; the
// scene's when no cost is known.
int DefaultMaxSteps(const InstanceModel& m, int substeps, double seconds_free);

}  // namespace lagrange
