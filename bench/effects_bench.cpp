// Effects cost (issue 6, item 4): time per RK4 step (h = 1 ms) of each plant
// with each effect on and off, beside a step with no effects layer at all.
//
// Benchmark names: effects/<plant>/<case>, case one of
//   bare          the same RK4 step on the dynamics alone: no Effects object
//   default       PlantModel with gravity and Coriolis on, every optional effect off
//   no-gravity    default without G;  no-coriolis  default without C qd
//   damping, friction, limits, saturation, disturbance   default plus that one effect
//   all           every effect on
// and calib/sincos, the machine baseline. The counter `off_stage_runs`
// counts how often a stage that is off ran: it must be 0.
//
// The plant steps on from a modest state (q = 0.3 rad or m per joint, at
// rest) under zero command and is put back there every 1000 steps (1 s).
// Plants: pendulum, arm2, cartpole, chain7, and the Panda (config/robots/
// panda.urdf; bare and default only: what the integrator API costs over
// RK4's stages on a robot, issue 37).

#include <memory>
#include <string>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "plant/integrators.hpp"

namespace lagrange::bench {
namespace {

constexpr double kStep = 1e-3;  // s
constexpr int kStepsPerRestart = 1000;

enum class Case {
  kBare,
  kDefault,
  kNoGravity,
  kNoCoriolis,
  kDamping,
  kFriction,
  kLimits,
  kSaturation,
  kDisturbance,
  kAll
};

constexpr Case kAllCases[] = {Case::kBare,     Case::kDefault, Case::kNoGravity,  Case::kNoCoriolis,  Case::kDamping,
                              Case::kFriction, Case::kLimits,  Case::kSaturation, Case::kDisturbance, Case::kAll};

std::string_view ToString(Case c) {
  switch (c) {
    case Case::kBare: return "bare";
    case Case::kDefault: return "default";
    case Case::kNoGravity: return "no-gravity";
    case Case::kNoCoriolis: return "no-coriolis";
    case Case::kDamping: return "damping";
    case Case::kFriction: return "friction";
    case Case::kLimits: return "limits";
    case Case::kSaturation: return "saturation";
    case Case::kDisturbance: return "disturbance";
    case Case::kAll: return "all";
  }
  return "?";
}

// The effects of one case for n joints (the scene-reference values of README.md).
EffectsConfig EffectsFor(Case c, int n) {
  EffectsConfig e = DefaultEffects();
  const bool all = c == Case::kAll;
  if (c == Case::kNoGravity) e.gravity = false;
  if (c == Case::kNoCoriolis) e.coriolis = false;
  if (all || c == Case::kDamping) e.damping = VectorXd::Constant(n, 0.1);
  if (all || c == Case::kFriction) e.friction = CoulombFriction{VectorXd::Constant(n, 0.2), 0.01};
  if (all || c == Case::kLimits)
    e.limits = JointLimits{VectorXd::Constant(n, -2.5), VectorXd::Constant(n, 2.5), 1e4, 50};
  if (all || c == Case::kSaturation) e.saturation = VectorXd::Constant(n, 5.0);
  if (all || c == Case::kDisturbance) e.disturbance.push_back({0.5, 0.05, VectorXd::Ones(n)});
  return e;
}

// Runs of the stages that the case switched off (gravity and Coriolis included).
std::int64_t OffStageRuns(const EffectsConfig& e, const StageCounts& c) {
  std::int64_t runs = 0;
  if (!e.gravity) runs += c.gravity;
  if (!e.coriolis) runs += c.coriolis;
  if (!e.damping) runs += c.damping;
  if (!e.friction) runs += c.friction;
  if (!e.limits) runs += c.limits;
  if (!e.saturation) runs += c.saturation;
  if (e.disturbance.empty()) runs += c.disturbance;
  return runs;
}

// Times `step(t, q, qd)` (one step of kStep under zero command) from q = 0.3
// per joint at rest, put back there every kStepsPerRestart steps.
template <class StepFn>
void TimeSteps(benchmark::State& bm, int n, StepFn&& step) {
  const VectorXd q0 = VectorXd::Constant(n, 0.3);
  VectorXd q = q0, qd = VectorXd::Zero(n);
  int k = 0;
  for (auto _ : bm) {
    step(k * kStep, q, qd);
    benchmark::DoNotOptimize(q.data());
    benchmark::ClobberMemory();
    if (++k == kStepsPerRestart) {
      k = 0;
      q = q0;
      qd.setZero();
    }
  }
}

// RK4's stages (the Rk4 integrator's own, plant/integrators.hpp) on the dynamics alone.
void TimeBare(benchmark::State& bm, const PlantSpec& spec) {
  std::unique_ptr<Dynamics> d = MakeDynamics(spec, FastestMethod(spec.type()));
  const std::unique_ptr<DynamicsData> d_data = d->MakeData();
  const int n = d->num_dofs();
  const VectorXd tau = VectorXd::Zero(n);
  Rk4 rk4(IntegratorConfig{}, n);
  auto acceleration = [&](double, ConstVecRef q, ConstVecRef qd, VecRef qdd) {
    d->ComputeForwardDynamics(*d_data, q, qd, tau, DynamicsTerms{}, qdd);
  };
  TimeSteps(bm, n, [&](double t, VectorXd& q, VectorXd& qd) { rk4.Stages(acceleration, t, kStep, q, qd); });
}

void TimeCase(benchmark::State& bm, const PlantSpec& spec, Case c) {
  const int n = spec.num_dofs();
  const EffectsConfig effects = EffectsFor(c, n);
  PlantModel model(MakeDynamics(spec, FastestMethod(spec.type())), effects);
  std::unique_ptr<Integrator> rk4 = MakeIntegrator(IntegratorConfig{}, n);
  const VectorXd tau = VectorXd::Zero(n);
  TimeSteps(bm, n, [&](double t, VectorXd& q, VectorXd& qd) { rk4->Step(model, t, kStep, tau, q, qd); });
  bm.counters["off_stage_runs"] = static_cast<double>(OffStageRuns(effects, model.counts()));
}

void RegisterAll() {
  std::vector<NamedPlant> plants = FixedPlants();
  plants.push_back(Chain(7));
  plants.push_back(ShippedRobotPlant("panda"));  // bare and default only: the integrator's fixed cost on a robot
  for (const NamedPlant& p : plants) {
    for (Case c : kAllCases) {
      if (p.name == "panda" && c != Case::kBare && c != Case::kDefault) continue;
      const std::string name = "effects/" + p.name + "/" + std::string(ToString(c));
      if (c == Case::kBare) {
        benchmark::RegisterBenchmark(name.c_str(), [spec = p.spec](benchmark::State& bm) { TimeBare(bm, spec); });
      } else {
        benchmark::RegisterBenchmark(name.c_str(), [spec = p.spec, c](benchmark::State& bm) { TimeCase(bm, spec, c); });
      }
    }
  }
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::RegisterAll); }
