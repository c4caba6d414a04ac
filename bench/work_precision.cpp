// Work-precision and long-horizon energy (issue 6, items 1 and 2).
//
// work_precision.csv   every integrator on three undamped, unforced problems:
//                      error at the final time, largest energy error on the way,
//                      cost in ns of CPU per simulated second
// reference.csv        how each reference final state was obtained and checked
// long_horizon.csv     10⁶ steps of the arm at 1 ms: energy error over time
//
// Problems (plants with their default parameters, gravity and Coriolis on):
//   pendulum  θ0 = 2 rad at rest, for 10 s; the exact solution is
//             sin(θ/2) = k sn(K − ω0 t | k), θ̇ = −2 k ω0 cn(K − ω0 t | k), with
//             k = sin(θ0/2), ω0 = √(g/L), K = std::comp_ellint_1(k), sn and cn
//             by the arithmetic-geometric mean (checked: θ(4K/ω0) = θ0, the
//             exact period, and E(t) = E(0))
//   arm2      q0 = (−0.6, 0.8) rad at rest, for 5 s
//   cartpole  q0 = (0 m, 2 rad) at rest, for 10 s
// For arm2 and cartpole the reference is Dormand–Prince at rtol 1e-13, checked
// against dopri5 at rtol 1e-12 and the variational integrator at 4 µs and 2 µs
// (its error estimated by Richardson extrapolation, order 2).
//
// Fixed-step integrators run at h from 10 ms to 10 µs (h is adjusted to land on
// the final time); dopri5 runs over the whole interval in one call at rtol
// 1e-3 .. 1e-12 (atol = rtol / 100). Cost is the thread's CPU time in a
// separate pass with no energy bookkeeping, repeated until the passes add up
// to 0.2 s, fastest pass kept.

#include <time.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "plant/integrators.hpp"
#include "plant/plant_factory.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;

struct Problem {
  std::string name;
  PlantSpec spec;
  VectorXd q0, qd0;
  double t_final = 0.0;    // s
  VectorXd q_ref, qd_ref;  // the final state: exact, or the reference's
  std::string reference;   // how q_ref was obtained
};

struct Run {
  IntegratorConfig config;
  double h = 0.0;                // s, the actual step (0 for dopri5)
  std::int64_t steps = 0;        // steps (accepted steps for dopri5)
  std::int64_t evaluations = 0;  // acceleration or residual evaluations
  double q_error = 0.0;          // max_i |q_i(T) − q_ref_i|, rad or m
  double qd_error = 0.0;         // max_i |qd_i(T) − qd_ref_i|, rad/s or m/s
  double energy_error = 0.0;     // max_t |E(t) − E(0)|, J
  double ns_per_sim_s = 0.0;     // CPU cost per simulated second
  bool ok = true;                // the integrator met its tolerance and the state stayed finite
};

struct Settings {
  std::vector<double> steps;  // fixed step sizes, s
  std::vector<double> rtols;  // dopri5
  double min_timed = 0.2;     // s of timed passes per point
  std::int64_t long_steps = 1'000'000;
};

PlantModel MakeModel(const PlantSpec& spec) { return PlantModel(MakeDynamics(spec, FastestMethod(spec.type())), {}); }

double Seconds(std::chrono::steady_clock::duration d) { return std::chrono::duration<double>(d).count(); }

// CPU time of this thread, s: what a pass costs, whatever else the machine runs.
double ThreadCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// ---- the problems -------------------------------------------------------

// Jacobi sn(u | k) and cn(u | k) by the arithmetic-geometric mean
// (Abramowitz & Stegun 16.4), accurate to rounding for 0 <= k < 1.
struct SnCn {
  double sn, cn;
};

SnCn JacobiSnCn(double u, double k) {
  constexpr int kMaxLevels = 16;
  double a[kMaxLevels + 1], c[kMaxLevels + 1];
  a[0] = 1.0;
  double b = std::sqrt(1.0 - k * k);
  c[0] = k;
  int levels = 0;
  while (levels < kMaxLevels && std::abs(c[levels]) > 1e-17) {
    a[levels + 1] = 0.5 * (a[levels] + b);
    c[levels + 1] = 0.5 * (a[levels] - b);
    b = std::sqrt(a[levels] * b);
    ++levels;
  }
  double phi = std::ldexp(a[levels] * u, levels);
  for (int n = levels; n > 0; --n) phi = 0.5 * (phi + std::asin(c[n] / a[n] * std::sin(phi)));
  return {std::sin(phi), std::cos(phi)};
}

// The point pendulum released at rest from θ0: (θ, θ̇) at time t.
struct PendulumExact {
  double theta0, omega0;  // rad, rad/s
  double k() const { return std::sin(0.5 * theta0); }
  double period() const { return 4.0 * std::comp_ellint_1(k()) / omega0; }  // s
  std::pair<double, double> At(double t) const {
    const SnCn e = JacobiSnCn(std::comp_ellint_1(k()) - omega0 * t, k());
    return {2.0 * std::asin(k() * e.sn), -2.0 * k() * omega0 * e.cn};
  }
};

PendulumExact ExactPendulum(const Problem& p) {
  const auto& params = std::get<PendulumParams>(p.spec.params);
  return {p.q0[0], std::sqrt(params.g / params.L)};
}

Problem PendulumProblem() {
  Problem p;
  p.name = "pendulum";
  p.spec = DefaultPlantSpec(PlantType::kPendulum);
  p.q0 = VectorXd::Constant(1, 2.0);
  p.qd0 = VectorXd::Zero(1);
  p.t_final = 10.0;
  const auto [theta, theta_dot] = ExactPendulum(p).At(p.t_final);
  p.q_ref = VectorXd::Constant(1, theta);
  p.qd_ref = VectorXd::Constant(1, theta_dot);
  p.reference = "exact: elliptic-function solution";
  return p;
}

// The exact solution's own checks: the period against θ0, energy along the way.
void CheckPendulumReference(const Problem& p, std::ofstream& csv) {
  const PendulumExact exact = ExactPendulum(p);
  const auto [theta_T, theta_dot_T] = exact.At(exact.period());
  PlantModel model = MakeModel(p.spec);
  const double e0 = model.Energy(p.q0, p.qd0);
  double energy = 0.0;
  for (int i = 1; i <= 1000; ++i) {
    const auto [theta, theta_dot] = exact.At(p.t_final * i / 1000.0);
    energy =
        std::max(energy, std::abs(model.Energy(VectorXd::Constant(1, theta), VectorXd::Constant(1, theta_dot)) - e0));
  }
  csv << p.name << ",exact solution after one period 4K/omega0 against (theta0 0),"
      << std::max(std::abs(theta_T - p.q0[0]), std::abs(theta_dot_T)) << ",\n";
  csv << p.name << ",exact solution: max |E(t) - E(0)| in J at 1000 times," << energy << ",\n";
}

Problem ArmProblem() {
  Problem p;
  p.name = "arm2";
  p.spec = DefaultPlantSpec(PlantType::kArm2);
  p.q0 = VectorXd(2);
  p.q0 << -0.6, 0.8;
  p.qd0 = VectorXd::Zero(2);
  p.t_final = 5.0;
  return p;
}

Problem CartPoleProblem() {
  Problem p;
  p.name = "cartpole";
  p.spec = DefaultPlantSpec(PlantType::kCartPole);
  p.q0 = VectorXd(2);
  p.q0 << 0.0, 2.0;
  p.qd0 = VectorXd::Zero(2);
  p.t_final = 10.0;
  return p;
}

// ---- one run ----------------------------------------------------------------

// (problem, config, steps of h) => final (q, qd); the energy error when asked.
bool Integrate(const Problem& p, const IntegratorConfig& c, std::int64_t steps, double h, Run& run, bool track_energy) {
  PlantModel model = MakeModel(p.spec);
  std::unique_ptr<Integrator> integrator = MakeIntegrator(c, model.num_dofs());
  const VectorXd tau = VectorXd::Zero(model.num_dofs());
  VectorXd q = p.q0, qd = p.qd0;
  const double e0 = model.Energy(q, qd);
  bool ok = true;
  for (std::int64_t k = 0; k < steps && ok; ++k) {
    ok = integrator->Step(model, static_cast<double>(k) * h, h, tau, q, qd) && q.allFinite() && qd.allFinite();
    if (track_energy) run.energy_error = std::max(run.energy_error, std::abs(model.Energy(q, qd) - e0));
  }
  run.q_error = (q - p.q_ref).lpNorm<Eigen::Infinity>();
  run.qd_error = (qd - p.qd_ref).lpNorm<Eigen::Infinity>();
  run.evaluations = integrator->stats().evaluations;
  run.steps = c.type == IntegratorType::kDormandPrince ? integrator->stats().accepted : steps;
  return ok;
}

// Fastest of repeated passes over [0, T] in `steps` calls, ns of CPU per simulated second.
double TimeIntegration(const Problem& p, const IntegratorConfig& c, std::int64_t steps, double h, double min_timed) {
  double best = std::numeric_limits<double>::infinity(), total = 0.0;
  do {
    Run scratch;
    const double start = ThreadCpuSeconds();
    Integrate(p, c, steps, h, scratch, false);
    const double s = ThreadCpuSeconds() - start;
    best = std::min(best, s);
    total += s;
  } while (total < min_timed);
  return best * 1e9 / p.t_final;
}

Run FixedStepRun(const Problem& p, IntegratorType type, double h_nominal, double min_timed) {
  Run run;
  run.config.type = type;
  const auto steps = std::max<std::int64_t>(1, std::llround(p.t_final / h_nominal));
  run.h = p.t_final / static_cast<double>(steps);
  run.ok = Integrate(p, run.config, steps, run.h, run, true);
  run.ns_per_sim_s = TimeIntegration(p, run.config, steps, run.h, min_timed);
  return run;
}

// dopri5 over [0, T] in one call. Its energy error is sampled at as many equal
// intervals as that call took steps (a second run, cut at those points).
Run AdaptiveRun(const Problem& p, double rtol, double min_timed) {
  Run run;
  run.config.type = IntegratorType::kDormandPrince;
  run.config.rtol = rtol;
  run.config.atol = rtol / 100.0;
  run.config.max_steps = 10'000'000;
  run.ok = Integrate(p, run.config, 1, p.t_final, run, false);
  run.ns_per_sim_s = TimeIntegration(p, run.config, 1, p.t_final, min_timed);
  Run sampled;
  const std::int64_t chunks = std::max<std::int64_t>(1, run.steps);
  Integrate(p, run.config, chunks, p.t_final / static_cast<double>(chunks), sampled, true);
  run.energy_error = sampled.energy_error;
  return run;
}

// ---- references -------------------------------------------------------------

struct FinalState {
  VectorXd q, qd;
};

FinalState Solve(const Problem& p, const IntegratorConfig& c, std::int64_t steps) {
  PlantModel model = MakeModel(p.spec);
  std::unique_ptr<Integrator> integrator = MakeIntegrator(c, model.num_dofs());
  const VectorXd tau = VectorXd::Zero(model.num_dofs());
  FinalState s{p.q0, p.qd0};
  const double h = p.t_final / static_cast<double>(steps);
  for (std::int64_t k = 0; k < steps; ++k) integrator->Step(model, static_cast<double>(k) * h, h, tau, s.q, s.qd);
  return s;
}

IntegratorConfig Dopri(double rtol) {
  IntegratorConfig c;
  c.type = IntegratorType::kDormandPrince;
  c.rtol = rtol;
  c.atol = rtol / 100.0;
  c.max_steps = 10'000'000;
  return c;
}

double Distance(const FinalState& a, const FinalState& b) {
  return std::max((a.q - b.q).lpNorm<Eigen::Infinity>(), (a.qd - b.qd).lpNorm<Eigen::Infinity>());
}

// dopri5 at rtol 1e-13 as p's reference; the checks go to `csv`.
void SetReference(Problem& p, double var_step, std::ofstream& csv) {
  const FinalState ref = Solve(p, Dopri(1e-13), 1);
  const FinalState looser = Solve(p, Dopri(1e-12), 1);
  IntegratorConfig var;
  var.type = IntegratorType::kVariational;
  const auto n_coarse = std::llround(p.t_final / var_step);
  const FinalState coarse = Solve(p, var, n_coarse);
  const FinalState fine = Solve(p, var, 2 * n_coarse);
  const double richardson = Distance(fine, coarse) / 3.0;  // error of `fine`, order 2
  p.q_ref = ref.q;
  p.qd_ref = ref.qd;
  p.reference = "dopri5 rtol 1e-13";
  csv << p.name << ",dopri5 rtol 1e-12," << Distance(ref, looser) << ",\n";
  csv << p.name << ",variational h " << std::llround(var_step * 0.5e6) << " us," << Distance(ref, fine) << ","
      << richardson << "\n";
}

// ---- output -----------------------------------------------------------------

void WriteRunHeader(std::ofstream& csv) {
  csv << "plant,integrator,h_s,rtol,steps,evaluations,q_error,qd_error,max_energy_error_J,ns_per_sim_s,ok,"
         "t_final_s,reference\n";
}

void WriteRun(std::ofstream& csv, const Problem& p, const Run& r) {
  const bool adaptive = r.config.type == IntegratorType::kDormandPrince;
  csv << p.name << ',' << ToString(r.config.type) << ',' << (adaptive ? 0.0 : r.h) << ','
      << (adaptive ? r.config.rtol : 0.0) << ',' << r.steps << ',' << r.evaluations << ',' << r.q_error << ','
      << r.qd_error << ',' << r.energy_error << ',' << r.ns_per_sim_s << ',' << (r.ok ? 1 : 0) << ',' << p.t_final
      << ",\"" << p.reference << "\"\n";
}

void SweepProblem(const Problem& p, const Settings& s, std::ofstream& csv) {
  for (IntegratorType type : {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4,
                              IntegratorType::kVariational}) {
    for (double h : s.steps) WriteRun(csv, p, FixedStepRun(p, type, h, s.min_timed));
    std::cerr << "work_precision: " << p.name << " " << ToString(type) << " done\n";
  }
  for (double rtol : s.rtols) WriteRun(csv, p, AdaptiveRun(p, rtol, s.min_timed));
  std::cerr << "work_precision: " << p.name << " dopri5 done\n";
}

// ---- long horizon -------------------------------------------------------------

// (integrator) => every 1000 steps: the largest |E − E0| in the block and E − E0 at its end.
void LongHorizon(IntegratorType type, std::int64_t steps, std::ofstream& csv) {
  constexpr double kH = 1e-3;            // s
  constexpr std::int64_t kBlock = 1000;  // steps per row
  constexpr double kDiverged = 1e6;      // J: stop recording beyond this
  const Problem p = ArmProblem();
  PlantModel model = MakeModel(p.spec);
  IntegratorConfig c;
  c.type = type;
  std::unique_ptr<Integrator> integrator = MakeIntegrator(c, 2);
  const VectorXd tau = VectorXd::Zero(2);
  VectorXd q = p.q0, qd = p.qd0;
  const double e0 = model.Energy(q, qd);
  double block_max = 0.0;
  const auto start = std::chrono::steady_clock::now();
  for (std::int64_t k = 1; k <= steps; ++k) {
    integrator->Step(model, static_cast<double>(k - 1) * kH, kH, tau, q, qd);
    const double de = model.Energy(q, qd) - e0;
    block_max = std::max(block_max, std::abs(de));
    if (!std::isfinite(de) || std::abs(de) > kDiverged) {
      csv << ToString(type) << ',' << static_cast<double>(k) * kH << ",inf,inf\n";
      break;
    }
    if (k % kBlock == 0) {
      csv << ToString(type) << ',' << static_cast<double>(k) * kH << ',' << block_max << ',' << de << '\n';
      block_max = 0.0;
    }
  }
  std::cerr << "work_precision: long horizon " << ToString(type) << " done in "
            << Seconds(std::chrono::steady_clock::now() - start) << " s\n";
}

// The steps and tolerances swept, and the long horizon's steps; fewer with --quick.
Settings SweepSettings(bool quick) {
  Settings s{{1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5},
             {1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12}};
  if (quick) {
    s.steps = {1e-2, 1e-3, 1e-4};
    s.rtols = {1e-4, 1e-8, 1e-12};
    s.min_timed = 0.0;
    s.long_steps = 100'000;
  }
  return s;
}

int Main(int argc, char** argv) {
  std::string out = "bench/results";
  bool quick = false;
  CLI::App app{"work_precision: error against cost for every integrator, and long-horizon energy"};
  app.add_option("--out", out, "Folder for the CSV files")->capture_default_str();
  app.add_flag("--quick", quick, "Fewer points and 10^5 long-horizon steps (a smoke run)");
  CLI11_PARSE(app, argc, argv);
  fs::create_directories(out);
  const Settings s = SweepSettings(quick);
  std::ofstream refs(fs::path(out) / "reference.csv");
  refs.precision(17);
  refs << "plant,check,max_state_difference,estimated_error_of_check\n";
  std::vector<Problem> problems{PendulumProblem(), ArmProblem(), CartPoleProblem()};
  for (Problem& p : problems) {
    if (p.q_ref.size() == 0)
      SetReference(p, quick ? 1e-4 : 4e-6, refs);
    else
      CheckPendulumReference(p, refs);
  }
  std::ofstream runs(fs::path(out) / "work_precision.csv");
  runs.precision(17);
  WriteRunHeader(runs);
  for (const Problem& p : problems) SweepProblem(p, s, runs);

  std::ofstream energy(fs::path(out) / "long_horizon.csv");
  energy.precision(17);
  energy << "integrator,t_s,max_abs_energy_error_J,energy_error_J\n";
  for (IntegratorType type : {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4,
                              IntegratorType::kDormandPrince, IntegratorType::kVariational}) {
    LongHorizon(type, s.long_steps, energy);
  }
  return 0;
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
