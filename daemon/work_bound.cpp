#include "daemon/work_bound.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "plant/plant_model.hpp"

namespace lagrange {
namespace {

constexpr int kWarmUpCalls = 20;
constexpr int kBatches = 20;        // 20 batches of 10: the ~200 timed calls
constexpr int kCallsPerBatch = 10;  // a batch amortises the clock read over several calls
// The most one measurement may take, warm-up included: a slow evaluation (a
// Lagrangian 64-link chain takes ~10 ms) is timed over fewer batches, at
// least one call, so start-up stays short whatever the scene.
constexpr double kMeasureBudget = 0.05;  // s

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

}  // namespace

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
  using Clock = std::chrono::steady_clock;
  const auto seconds_since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  const Clock::time_point begin = Clock::now();
  // Warm up, and find how many calls a batch can afford.
  int calls = kCallsPerBatch;
  for (int i = 0; i < kWarmUpCalls && seconds_since(begin) < 0.1 * kMeasureBudget; ++i) {
    model.ComputeAcceleration(0.0, config.q0, config.qd0, tau, qdd);
  }
  double fastest = std::numeric_limits<double>::infinity();
  for (int b = 0; b < kBatches; ++b) {
    const Clock::time_point start = Clock::now();
    for (int i = 0; i < calls; ++i) model.ComputeAcceleration(0.0, config.q0, config.qd0, tau, qdd);
    const double batch = seconds_since(start);
    fastest = std::min(fastest, batch / calls);
    if (seconds_since(begin) > kMeasureBudget) break;
    if (batch > kMeasureBudget / kBatches) calls = 1;  // slow calls: one per batch
  }
  return fastest;
}

std::array<double, 3> MeasureEvaluationCosts(const InstanceConfig& config) {
  std::array<double, 3> costs{};
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

std::vector<WorkBound> MeasureWorkBounds(const Scene& scene) {
  std::vector<WorkBound> bounds;
  for (const InstanceConfig& inst : scene.instances) {
    bounds.push_back(
        {inst.name, WorstCaseEvaluations(inst.integrator, inst.plant.num_dofs()), MeasureEvaluationSeconds(inst)});
  }
  return bounds;
}

std::optional<std::string> CheckWorkBounds(const Scene& scene, const std::vector<WorkBound>& bounds) {
  for (std::size_t i = 0; i < bounds.size() && i < scene.instances.size(); ++i) {
    const WorkBound& b = bounds[i];
    if (b.tick_s() <= scene.period) continue;
    const IntegratorConfig& integrator = scene.instances[i].integrator;
    return fmt::format(
        "{}: instances[{}] ({}): {} worst case {} evaluations × {:.3g} µs = {:.4g} ms per tick does not fit the "
        "period {:.4g} ms; lower {}, or lengthen the period",
        scene.file, i, b.instance, ToString(integrator.type), b.evaluations, b.evaluation_s * 1e6, b.tick_s() * 1e3,
        scene.period * 1e3, WhatToLower(integrator, scene.period / b.evaluation_s));
  }
  return std::nullopt;
}

}  // namespace lagrange
