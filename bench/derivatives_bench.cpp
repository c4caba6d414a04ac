// What the exact derivatives of the dynamics cost (plant/dynamics.hpp), per
// robot, against one forward-dynamics call and against differencing it, all in
// one run: arm2 and the cart-pole (closed form), a 7-link planar chain
// (recursive), the Panda, the UR5 and the Panda with its hand (a prismatic
// finger and its mimic; recursive, spatial). The model is the plant's fastest
// exact path (the default); the Lagrangian one (nested duals) beside it.
//
// Benchmark names: deriv/<robot>/<what>, what one of
//   FD            ComputeForwardDynamics: the baseline, one call
//   dFD           ComputeForwardDynamicsDerivatives: qdd, ∂qdd/∂q, ∂qdd/∂qd, ∂qdd/∂tau
//   dID           ComputeInverseDynamicsDerivatives: ∂tau/∂q, ∂tau/∂qd, M
//   dFD_forward   ∂qdd/∂q and ∂qdd/∂qd by forward differences of FD: 2n + 1 calls (no ∂qdd/∂tau)
//   dFD_central   the same by central differences: 4n + 1 calls (the LQR's Linearize before exact derivatives)
//   dID_central   ∂tau/∂q and ∂tau/∂qd by central differences of inverse dynamics: 4n calls
//   dFD_lagrangian, dID_lagrangian   the Lagrangian path's dFD and dID
//   step_rk4      StepDerivatives: A and B of one RK4 step (4 acceleration derivatives and block products)
// Each call cycles through 16 seeded random states. After Google Benchmark's
// table, a summary: each figure as a multiple of the same robot's FD in this
// run, and the differences over dFD (how many times faster the exact
// derivatives are), the Lagrangian over the recursive.
//
//   build/bench/derivatives_bench [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench/bench_plants.hpp"
#include "bench/gbench.hpp"
#include "plant/integrators.hpp"
#include "plant/urdf.hpp"

namespace lagrange::bench {
namespace {

constexpr int kStates = 16;

struct Robot {
  std::string name;
  PlantSpec spec;
};

std::vector<Robot> Robots() {
  const auto urdf = [](const char* file) {
    return UrdfPlantSpec(
        std::make_shared<const UrdfRobot>(LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + file)));
  };
  return {{"arm2", DefaultPlantSpec(PlantType::kArm2)},
          {"cartpole", DefaultPlantSpec(PlantType::kCartPole)},
          {"chain7", Chain(7).spec},
          {"panda", urdf("panda.urdf")},
          {"ur5", urdf("ur5.urdf")},
          {"panda_hand", urdf("panda_hand.urdf")}};
}

enum class What { kFD, kDFD, kDID, kForward, kCentral, kIdCentral, kStepRk4 };

// Everything one benchmark needs, built before its loop.
struct Bench {
  Bench(std::shared_ptr<const Dynamics> model, int n)
      : dynamics(std::move(model)),
        data(dynamics->MakeData()),
        plant(dynamics, EffectsConfig{}),
        step(IntegratorType::kRk4, n),
        qdd(n),
        plus(n),
        minus(n),
        x(n),
        a(n, n),
        b(n, n),
        c(n, n),
        A(2 * n, 2 * n),
        B(2 * n, n) {
    std::mt19937 rng{42};
    states = RandomStates(dynamics->joint_types(), kStates, rng);
  }
  std::shared_ptr<const Dynamics> dynamics;
  std::unique_ptr<DynamicsData> data;
  PlantModel plant;
  StepDerivatives step;
  std::vector<State> states;
  VectorXd qdd, plus, minus, x;
  MatrixXd a, b, c, A, B;
};

// One evaluation of `what` at state s.
void Evaluate(Bench& w, What what, const State& s) {
  const Dynamics& d = *w.dynamics;
  const int n = d.num_dofs();
  constexpr double kStep = 1e-6;
  switch (what) {
    case What::kFD: d.ComputeForwardDynamics(*w.data, s.q, s.qd, s.tau, DynamicsTerms{}, w.qdd); break;
    case What::kDFD:
      d.ComputeForwardDynamicsDerivatives(*w.data, s.q, s.qd, s.tau, DynamicsTerms{}, w.qdd, w.a, w.b, w.c);
      break;
    case What::kDID:
      d.ComputeInverseDynamicsDerivatives(*w.data, s.q, s.qd, s.qdd, DynamicsTerms{}, w.a, w.b, w.c);
      break;
    case What::kForward:
    case What::kCentral: {
      const bool central = what == What::kCentral;
      d.ComputeForwardDynamics(*w.data, s.q, s.qd, s.tau, DynamicsTerms{}, w.qdd);
      for (int k = 0; k < 2; ++k) {  // q, then qd
        w.x = k == 0 ? s.q : s.qd;
        for (int j = 0; j < n; ++j) {
          const double x0 = w.x[j];
          w.x[j] = x0 + kStep;
          d.ComputeForwardDynamics(*w.data, k == 0 ? w.x : s.q, k == 0 ? s.qd : w.x, s.tau, DynamicsTerms{}, w.plus);
          if (central) {
            w.x[j] = x0 - kStep;
            d.ComputeForwardDynamics(*w.data, k == 0 ? w.x : s.q, k == 0 ? s.qd : w.x, s.tau, DynamicsTerms{}, w.minus);
          } else {
            w.minus = w.qdd;
          }
          w.x[j] = x0;
          (k == 0 ? w.a : w.b).col(j) = (w.plus - w.minus) / (central ? 2.0 * kStep : kStep);
        }
      }
      break;
    }
    case What::kIdCentral:
      for (int k = 0; k < 2; ++k) {  // q, then qd
        w.x = k == 0 ? s.q : s.qd;
        for (int j = 0; j < n; ++j) {
          const double x0 = w.x[j];
          w.x[j] = x0 + kStep;
          d.ComputeInverseDynamics(*w.data, k == 0 ? w.x : s.q, k == 0 ? s.qd : w.x, s.qdd, DynamicsTerms{}, w.plus);
          w.x[j] = x0 - kStep;
          d.ComputeInverseDynamics(*w.data, k == 0 ? w.x : s.q, k == 0 ? s.qd : w.x, s.qdd, DynamicsTerms{}, w.minus);
          w.x[j] = x0;
          (k == 0 ? w.a : w.b).col(j) = (w.plus - w.minus) / (2.0 * kStep);
        }
      }
      break;
    case What::kStepRk4: w.step.Step(w.plant, 0.0, 1e-3, s.q, s.qd, s.tau, w.A, w.B); break;
  }
}

void Time(benchmark::State& bm, const std::shared_ptr<const Dynamics>& model, What what) {
  Bench w(model, model->num_dofs());
  std::size_t k = 0;
  for (auto _ : bm) {
    Evaluate(w, what, w.states[k]);
    benchmark::DoNotOptimize(w.a.data());
    benchmark::DoNotOptimize(w.A.data());
    benchmark::DoNotOptimize(w.qdd.data());
    benchmark::ClobberMemory();
    k = k + 1 == w.states.size() ? 0 : k + 1;
  }
  bm.counters["dofs"] = model->num_dofs();
}

void Register() {
  const std::pair<What, const char*> fast[] = {{What::kFD, "FD"},
                                               {What::kDFD, "dFD"},
                                               {What::kDID, "dID"},
                                               {What::kForward, "dFD_forward"},
                                               {What::kCentral, "dFD_central"},
                                               {What::kIdCentral, "dID_central"},
                                               {What::kStepRk4, "step_rk4"}};
  for (const Robot& r : Robots()) {
    const std::shared_ptr<const Dynamics> model = MakeDynamics(r.spec, FastestMethod(r.spec.type()));
    const std::shared_ptr<const Dynamics> lagrangian = MakeDynamics(r.spec, Method::kLagrangian);
    for (const auto& [what, name] : fast) {
      benchmark::RegisterBenchmark(("deriv/" + r.name + "/" + name).c_str(),
                                   [model, what](benchmark::State& bm) { Time(bm, model, what); });
    }
    benchmark::RegisterBenchmark(("deriv/" + r.name + "/dFD_lagrangian").c_str(),
                                 [lagrangian](benchmark::State& bm) { Time(bm, lagrangian, What::kDFD); });
    benchmark::RegisterBenchmark(("deriv/" + r.name + "/dID_lagrangian").c_str(),
                                 [lagrangian](benchmark::State& bm) { Time(bm, lagrangian, What::kDID); });
  }
}

// "a / b" with two decimals, or "-" when either was filtered out.
std::string Ratio(double a, double b, const char* format = "%.2f") {
  if (a <= 0.0 || b <= 0.0) return "-";
  char text[32];
  std::snprintf(text, sizeof text, format, a / b);
  return text;
}

void PrintSummary(const Collector& c) {
  std::printf(
      "\nsummary (CPU time per call; × FD: a multiple of the same robot's forward dynamics in this run)\n"
      "%-11s %3s %8s %10s %10s %12s %12s %12s %13s %13s %13s\n",
      "robot", "n", "FD ns", "dFD × FD", "dID × FD", "central/dFD", "forward/dFD", "central/dID", "lagr/rec dFD",
      "lagr/rec dID", "rk4 A,B × FD");
  bool any = false;
  for (const Robot& r : Robots()) {
    const auto t = [&](const char* what) { return c.Time("deriv/" + r.name + "/" + what); };
    const double fd = t("FD");
    if (fd <= 0.0) continue;  // filtered out
    any = true;
    std::printf("%-11s %3d %8.0f %10s %10s %12s %12s %12s %13s %13s %13s\n", r.name.c_str(), r.spec.num_dofs(), fd,
                Ratio(t("dFD"), fd).c_str(), Ratio(t("dID"), fd).c_str(), Ratio(t("dFD_central"), t("dFD")).c_str(),
                Ratio(t("dFD_forward"), t("dFD")).c_str(), Ratio(t("dID_central"), t("dID")).c_str(),
                Ratio(t("dFD_lagrangian"), t("dFD"), "%.0f").c_str(),
                Ratio(t("dID_lagrangian"), t("dID"), "%.0f").c_str(), Ratio(t("step_rk4"), fd, "%.1f").c_str());
  }
  if (!any) return;
  // The targets (34): the Panda's dFD within 5 FD calls and 3 times
  // faster than central differences; every model with n >= 3 faster than
  // differencing (forward differences, the cheaper of the two).
  const auto t = [&](const std::string& robot, const char* what) { return c.Time("deriv/" + robot + "/" + what); };
  const double fd = t("panda", "FD"), dfd = t("panda", "dFD"), central = t("panda", "dFD_central");
  if (fd > 0.0 && dfd > 0.0 && central > 0.0) {
    std::printf("target panda dFD <= 5 x FD: %s (%.2f)\n", dfd <= 5.0 * fd ? "met" : "MISSED", dfd / fd);
    std::printf("target panda central/dFD >= 3: %s (%.2f)\n", central >= 3.0 * dfd ? "met" : "MISSED", central / dfd);
  }
  for (const Robot& r : Robots()) {
    const double exact = t(r.name, "dFD"), forward = t(r.name, "dFD_forward");
    if (r.spec.num_dofs() < 3 || exact <= 0.0 || forward <= 0.0) continue;
    std::printf("target %s dFD faster than forward differences: %s (%.2f)\n", r.name.c_str(),
                exact < forward ? "met" : "MISSED", forward / exact);
  }
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) {
  return lagrange::bench::RunBenchmarks(argc, argv, lagrange::bench::Register, lagrange::bench::PrintSummary);
}
