// What the box-constrained DDP (controllers/ddp.hpp) costs per iteration per
// knot, on the cart-pole (closed form, horizon 1 s at dt 10 ms: 100 knots,
// force limit 10 N) and the Panda (recursive, horizon 0.5 s at dt 10 ms: 50
// knots, Franka's torque limits), with the optimiser stepping by RK4 and by
// semi-implicit Euler; against one ComputeForwardDynamicsDerivatives call of
// the same plant in the same run.
//
// Benchmark names:
//   ddp/<robot>/dFD                  one ComputeForwardDynamicsDerivatives (the baseline)
//   ddp/<robot>/<integrator>/solve   one receding-horizon solve of one iteration: ShiftSolution(1), then
//                                    SolveDdp from the plan's next state (a rollout under the shifted policy,
//                                    the step derivatives along it, the backward pass with its box QPs, the
//                                    line search's rollouts); the plan restarts cold every 100 solves
// After the table: per robot and integrator, the solve's CPU time, per knot, as a multiple of dFD,
// and solves per second on one core.
//
//   build/bench/ddp_bench [--benchmark_filter=cartpole]

#include <cstdio>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "controllers/ddp.hpp"
#include "plant/urdf.hpp"

namespace lagrange::bench {
namespace {

constexpr int kRestart = 100;  // solves before the plan restarts cold

struct Problem {
  std::string name;
  std::shared_ptr<const Dynamics> dynamics;
  DdpConfig config;
  VectorXd q0, q_target;
};

std::vector<Problem> Problems() {
  std::vector<Problem> out;
  {
    const PlantSpec spec = DefaultPlantSpec(PlantType::kCartPole);
    Problem p{"cartpole", MakeDynamics(spec, FastestMethod(spec.type())), {}, VectorXd::Zero(2), VectorXd(2)};
    p.config.dt = 0.01;
    p.config.horizon = 100;
    p.config.actuated = {0};
    p.config.tau_lower = VectorXd::Constant(1, -10.0);
    p.config.tau_upper = VectorXd::Constant(1, 10.0);
    p.config.weights = {VectorXd::Constant(2, 1.0), VectorXd::Constant(2, 0.01), VectorXd::Constant(1, 0.01),
                        VectorXd::Constant(2, 300.0), VectorXd::Constant(2, 1.0)};
    p.q_target << 0.0, std::numbers::pi;
    out.push_back(std::move(p));
  }
  {
    const PlantSpec spec = UrdfPlantSpec(
        std::make_shared<const UrdfRobot>(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf")));
    Problem p{"panda", MakeDynamics(spec, FastestMethod(spec.type())), {}, VectorXd(7), VectorXd(7)};
    p.config.dt = 0.01;
    p.config.horizon = 50;
    p.config.tau_upper = (VectorXd(7) << 87, 87, 87, 87, 12, 12, 12).finished();
    p.config.tau_lower = -p.config.tau_upper;
    p.config.weights = {VectorXd::Constant(7, 10.0), VectorXd::Constant(7, 0.1), VectorXd::Constant(7, 1e-3),
                        VectorXd::Constant(7, 1000.0), VectorXd::Constant(7, 10.0)};
    p.q0 << 0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785;  // Franka's ready pose
    p.q_target << 0.6, -0.3, 0.4, -1.8, 0.3, 1.9, 0.5;
    out.push_back(std::move(p));
  }
  return out;
}

void TimeDerivatives(benchmark::State& bm, const std::shared_ptr<const Dynamics>& model) {
  const int n = model->num_dofs();
  std::mt19937 rng{42};
  const std::vector<State> states = RandomStates(model->joint_types(), 16, rng);
  const std::unique_ptr<DynamicsData> data = model->MakeData();
  VectorXd qdd(n);
  MatrixXd a(n, n), b(n, n), c(n, n);
  std::size_t k = 0;
  for (auto _ : bm) {
    const State& s = states[k];
    model->ComputeForwardDynamicsDerivatives(*data, s.q, s.qd, s.tau, DynamicsTerms{}, qdd, a, b, c);
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
    k = k + 1 == states.size() ? 0 : k + 1;
  }
}

void TimeSolve(benchmark::State& bm, const Problem& problem, IntegratorType integrator) {
  DdpConfig config = problem.config;
  config.integrator = integrator;
  config.options.max_iterations = 1;
  const DdpModel model(problem.dynamics, config);
  DdpData data(model);
  data.q_ref.colwise() = problem.q_target;
  const int n = model.num_dofs();
  VectorXd q = problem.q0, qd = VectorXd::Zero(n);
  int solves = 0, iterations = 0;
  for (auto _ : bm) {
    if (solves % kRestart == 0) {
      data.Reset();
      q = problem.q0;
      qd.setZero();
    } else {
      data.ShiftSolution(1);
      q = data.x().col(0).head(n);
      qd = data.x().col(0).tail(n);
    }
    iterations += SolveDdp(model, data, q, qd).iterations;
    ++solves;
    benchmark::ClobberMemory();
  }
  bm.counters["knots"] = model.horizon();
  bm.counters["iterations_per_solve"] = static_cast<double>(iterations) / std::max(1, solves);
}

const char* Name(IntegratorType type) { return type == IntegratorType::kRk4 ? "rk4" : "semi-implicit-euler"; }

constexpr IntegratorType kIntegrators[] = {IntegratorType::kRk4, IntegratorType::kSemiImplicitEuler};

void Register() {
  for (const Problem& p : Problems()) {
    benchmark::RegisterBenchmark(("ddp/" + p.name + "/dFD").c_str(),
                                 [model = p.dynamics](benchmark::State& bm) { TimeDerivatives(bm, model); });
    for (IntegratorType integrator : kIntegrators) {
      benchmark::RegisterBenchmark(("ddp/" + p.name + "/" + Name(integrator) + "/solve").c_str(),
                                   [p, integrator](benchmark::State& bm) { TimeSolve(bm, p, integrator); });
    }
  }
}

void PrintSummary(const Collector& c) {
  std::printf(
      "\nsummary (CPU time; x dFD: a multiple of one ComputeForwardDynamicsDerivatives of the plant, this run)\n"
      "%-9s %-20s %5s %10s %12s %12s %10s\n",
      "robot", "integrator", "knots", "solve us", "per knot ns", "knot x dFD", "solves/s");
  for (const Problem& p : Problems()) {
    const double dfd = c.Time("ddp/" + p.name + "/dFD");
    for (IntegratorType integrator : kIntegrators) {
      const double solve = c.Time("ddp/" + p.name + "/" + Name(integrator) + "/solve");
      if (solve <= 0.0) continue;  // filtered out
      const double per_knot = solve / p.config.horizon;
      std::printf("%-9s %-20s %5d %10.1f %12.0f %12s %10.0f\n", p.name.c_str(), Name(integrator), p.config.horizon,
                  solve / 1e3, per_knot, dfd > 0.0 ? std::to_string(per_knot / dfd).substr(0, 5).c_str() : "-",
                  1e9 / solve);
    }
  }
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) {
  return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::Register, lagrange::bench::PrintSummary);
}
