#pragma once
// The longest a tick can take, bounded before the loop starts.
//
// A tick is one call per instance of the integrator over the period; an
// adaptive or implicit integrator may evaluate the right-hand side many times
// in it. The daemon only reads signals between ticks, so a tick that can run
// for seconds (dopri5 on a stiff scene, max_steps 1e7: 13.7 s) makes SIGTERM
// take that long. lagranged refuses a scene whose worst case does not fit:
//
//   worst case per tick = evaluations(integrator, n) × cost of one evaluation ≤ period
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
// instance's initial state, on a private model, timed in batches; the fastest
// batch is taken, so a loaded machine does not inflate it (the bound is about
// the scene, not about the machine's load).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "daemon/scene.hpp"

namespace lagrange {

// dopri5: the largest max_steps whose worst case, s·(1 + 6·max_steps) + 1,
// stays within `evaluations_that_fit` (< 1: none does).
double LargestMaxStepsThatFit(double evaluations_that_fit, int substeps);

// Worst-case right-hand-side evaluations of one tick (see above).
std::int64_t WorstCaseEvaluations(const IntegratorConfig& config, int num_dofs);

// The cost of one ComputeAcceleration for `config` at (q0, qd0), zero torque, s.
double MeasureEvaluationSeconds(const InstanceConfig& config);

// The same by every method the plant has (by Method; 0 for a method it lacks),
// with every effect the scene configures on (gravity, Coriolis and those in
// effects.off included): the costliest combination a command can switch to,
// for the run-time method and integrator commands (InstanceModel::evaluation_s, BuildOptions::measure_costs).
std::array<double, 3> MeasureEvaluationCosts(const InstanceConfig& config);

struct WorkBound {
  std::string instance;
  std::int64_t evaluations = 0;  // worst case per tick
  double evaluation_s = 0.0;     // measured cost of one
  double tick_s() const { return static_cast<double>(evaluations) * evaluation_s; }
};

// Every instance's bound, measured now.
std::vector<WorkBound> MeasureWorkBounds(const Scene& scene);

// The refusal for the first instance whose worst case exceeds the period:
// "<file>: instances[i] (<name>): <integrator> worst case N evaluations × X µs = Y ms
// per tick does not fit the period P ms; lower <what to lower>, or lengthen the period";
// nullopt when every instance fits.
std::optional<std::string> CheckWorkBounds(const Scene& scene, const std::vector<WorkBound>& bounds);

}  // namespace lagrange
