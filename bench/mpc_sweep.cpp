// What accuracy costs in time, for MPC (issue 35): the work-precision diagram of control.
//
// mpc_sweep.csv   one row per closed-loop offline run of a shipped mpc scene with its mpc keys overridden
//
// Scenes (loaded from config/, run as `lagrangectl simulate` runs them: the planner inline every
// replan_period of simulated time, deterministic; the plant integrated as the scene says, rk4 at 1 ms):
//   cartpole  config/cartpole_mpc_swingup.yaml for 6 s. Success: |θ − π| < 0.05 rad and |x| <= 0.5 m held
//             over the last 1 s, and |x| <= 0.5 m throughout (the rail); first_ok_s: the first time it was
//             upright and on the rail; held_since_s: from when it stayed so.
//   panda     config/panda_mpc_reach.yaml for 3 s. Success: the flange within 5 mm and 0.05 rad of the
//             scene's target held over the last 0.5 s, and no applied τ beyond the box; held_since_s: the
//             time it arrived to stay. tau_bound: the joints (1-based) held at their limit >= 10 ticks.
// Swept per scene: the plan's horizon N (knots), its dt, DDP iterations per solve and the optimiser's
// integrator (explicit Euler, semi-implicit Euler, rk4); replan_period and the weights stay the scene's.
//
// tracking_cost: the time integral, along the ACTUAL path (every 1 ms step), of the shipped scene's stage
// cost ½(Σ w_q e_q² + Σ w_q̇ e_q̇² + Σ w_τ τ² + w_pos ‖e_p‖² + w_rot ‖e_R‖²) with its weights (the same
// for every run of a scene, whatever the plan optimised), e the error to the scene's setpoint or pose target.
// Solve time: CPU time of this thread (CLOCK_THREAD_CPUTIME_ID) of each step that planned, less the mean of
// the steps that did not (the tick's own work); mean and worst over the run. fits_horizon: worst solve +
// replan_period <= N dt (lagranged's bound, sim/work_bound.hpp, with the worst solve measured);
// fits_replan: worst solve <= replan_period (a solve would be done before the next is due, live).
// front: on the Pareto front of (mean solve time, tracking_cost) among the scene's successful runs.

#include <time.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "bench/mpc_front.hpp"
#include "controllers/task_trajectory.hpp"
#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "sim/offline.hpp"
#include "sim/scene.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Setting {
  int horizon = 0;
  double dt = 0.0;
  int iterations = 0;
  IntegratorType integrator = IntegratorType::kSemiImplicitEuler;
};

bool SameSetting(const Setting& s, const MpcOptions& o) {
  return s.horizon == o.horizon && std::abs(s.dt - o.dt) < 1e-12 && s.iterations == o.iterations &&
         s.integrator == o.integrator;
}

// A scene, what counts as success on it, and the grid swept on it.
struct Case {
  std::string robot;
  std::string file;       // under the config folder
  double duration = 0.0;  // s
  double held = 0.0;      // s the success condition must hold to the end
  std::vector<int> horizons;
  std::vector<double> dts;
  std::vector<int> iterations;
  std::vector<IntegratorType> integrators;
};

struct Result {
  Setting setting;
  bool shipped = false;
  std::string status = "ok";  // ok, faulted: ..., refused: ...
  bool success = false;
  double first_ok_s = kNan, held_since_s = kNan;
  double worst_x = kNan;                                            // m, cart-pole
  double final_position_error = kNan, final_rotation_error = kNan;  // m, rad, with a frame
  std::string tau_bound;                                            // 1-based joints held at their limit
  bool tau_exceeded = false;
  double tracking_cost = 0.0;
  std::int64_t solves = 0, failed_solves = 0;
  double mean_solve = kNan, worst_solve = kNan;  // s of CPU
  bool fits_horizon = false, fits_replan = false;
  bool front = false;
  bool deterministic = true;  // every repeat took the same path
};

// The shipped scene's stage cost at one state (the tracking cost's integrand), and the pose error with a frame.
class StageCost {
 public:
  explicit StageCost(const InstanceConfig& c)
      : o_(c.controller.mpc),
        n_(static_cast<int>(c.q0.size())),
        actuated_(MpcActuated(o_, n_, c.plant.type() == PlantType::kCartPole)),
        w_(MpcWeights(o_, n_, static_cast<int>(actuated_.size()))) {
    if (o_.frame.empty()) return;
    kinematics_ = std::make_unique<Kinematics>(MakeRigidTree(c.plant));
    frame_ = *kinematics_->FrameIndex(o_.frame);
    data_ = kinematics_->MakeData();
    target_ = *o_.trajectory.target;  // the shipped reach holds one target
  }
  bool has_frame() const { return frame_ >= 0; }
  const Vector6d& pose_error() const { return error_; }

  // ½(...) at the instance's state, setpoint and applied τ; updates pose_error().
  double Rate(const Instance& inst, Setpoint& sp) {
    inst.SampleTrajectory(sp);
    double r = w_.q.dot((inst.q() - sp.q).cwiseAbs2()) + w_.qd.dot((inst.qd() - sp.qd).cwiseAbs2());
    for (std::size_t j = 0; j < actuated_.size(); ++j) {
      const double tau = inst.tau()[actuated_[j]];
      r += w_.tau[static_cast<Eigen::Index>(j)] * tau * tau;
    }
    if (has_frame()) {
      kinematics_->ComputeFramePlacement(*data_, inst.q(), frame_);
      error_ = PoseError(target_, Pose{data_->position(frame_), Eigen::Quaterniond(data_->rotation(frame_))});
      r += o_.pose_weight[0] * error_.head<3>().squaredNorm() + o_.pose_weight[1] * error_.tail<3>().squaredNorm();
    }
    return 0.5 * r;
  }

 private:
  MpcOptions o_;
  int n_;
  std::vector<int> actuated_;
  DdpWeights w_;
  std::unique_ptr<Kinematics> kinematics_;
  std::unique_ptr<KinematicsData> data_;
  int frame_ = -1;
  Pose target_;
  Vector6d error_ = Vector6d::Zero();
};

// The success condition at one sample: the cart-pole upright on its rail, or the flange at its target.
bool AtGoal(const Instance& inst, const StageCost& cost) {
  if (cost.has_frame()) return cost.pose_error().head<3>().norm() < 5e-3 && cost.pose_error().tail<3>().norm() < 0.05;
  return std::abs(inst.q()[1] - std::numbers::pi) < 0.05 && std::abs(inst.q()[0]) <= 0.5;
}

// One closed-loop run of `config` (its mpc keys already overridden) for `duration` s at `period`.
void RunOne(const InstanceConfig& config, double period, const Case& c, Result& out) {
  std::vector<Instance> instances;
  instances.emplace_back(config);
  StageCost cost(config);
  Setpoint sp(static_cast<int>(config.q0.size()));
  const VectorXd& limits = config.torque_limits;
  std::vector<int> saturated(static_cast<std::size_t>(limits.size()), 0);
  HeldSince held;
  double worst_x = 0.0, plan_s = 0.0, plan_worst = 0.0, other_s = 0.0;
  std::int64_t plans = 0, others = 0;
  const auto observe = [&](std::size_t, Instance& inst) {
    if (inst.steps() == 0) return;
    out.tracking_cost += cost.Rate(inst, sp) * period;
    const bool ok = AtGoal(inst, cost);
    if (ok && std::isnan(out.first_ok_s)) out.first_ok_s = inst.t();
    held.Add(inst.t(), ok);
    if (!cost.has_frame()) worst_x = std::max(worst_x, std::abs(inst.q()[0]));
    for (Eigen::Index i = 0; i < limits.size(); ++i) {
      const double tau = std::abs(inst.tau()[i]);
      if (tau > limits[i] * (1.0 + 1e-12)) out.tau_exceeded = true;
      if (tau >= limits[i] * (1.0 - 1e-12)) ++saturated[static_cast<std::size_t>(i)];
    }
  };
  const auto step = [&](std::size_t, Instance& inst) {
    const MpcController* mpc = inst.mpc_controller(inst.active_controller());
    const bool plans_now = mpc != nullptr && mpc->plan_due(inst.t());
    const double start = ThreadCpuSeconds();
    const Instance::StepFailure failure = inst.Step(period);
    const double s = ThreadCpuSeconds() - start;
    if (plans_now) {
      plan_s += s;
      plan_worst = std::max(plan_worst, s);
      ++plans;
    } else {
      other_s += s;
      ++others;
    }
    return failure;
  };
  const auto steps = std::llround(c.duration / period);
  const std::vector<OfflineFault> faults = RunOfflineChecked(instances, period, steps, observe, step);
  if (!faults.empty()) out.status = std::string("faulted: ") + faults.front().reason;
  const MpcController* mpc = instances.front().mpc_controller(0);
  out.failed_solves = mpc != nullptr ? mpc->failed_solves() : 0;
  out.solves = plans;
  const double tick = others > 0 ? other_s / static_cast<double>(others) : 0.0;
  out.mean_solve = plans > 0 ? plan_s / static_cast<double>(plans) - tick : kNan;
  out.worst_solve = plans > 0 ? plan_worst - tick : kNan;
  const MpcOptions& o = config.controller.mpc;
  out.fits_horizon = out.worst_solve + MpcReplanPeriod(o) <= o.horizon * o.dt;
  out.fits_replan = out.worst_solve <= MpcReplanPeriod(o);
  out.held_since_s = held.Since();
  if (cost.has_frame()) {
    out.final_position_error = cost.pose_error().head<3>().norm();
    out.final_rotation_error = cost.pose_error().tail<3>().norm();
  } else {
    out.worst_x = worst_x;
  }
  for (std::size_t i = 0; i < saturated.size(); ++i) {
    if (saturated[i] >= 10) out.tau_bound += (out.tau_bound.empty() ? "" : ";") + std::to_string(i + 1);
  }
  const double t_end = static_cast<double>(steps) * period;
  out.success =
      faults.empty() && held.HeldFor(c.held, t_end) && !out.tau_exceeded && (cost.has_frame() || worst_x <= 0.5);
}

// The same run `repeats` times (it is deterministic: the same path each time, checked): the timings of the
// one whose mean solve was fastest, the least disturbed by whatever else the machine ran.
void RunRepeated(const InstanceConfig& config, double period, const Case& c, int repeats, Result& out) {
  const Result blank = out;
  RunOne(config, period, c, out);
  for (int i = 1; i < repeats; ++i) {
    Result again = blank;
    RunOne(config, period, c, again);
    // Bit for bit: the same path gives the same sum in the same order.
    if (again.tracking_cost != out.tracking_cost || again.success != out.success) out.deterministic = false;
    if (again.mean_solve < out.mean_solve) {
      out.mean_solve = again.mean_solve;
      out.worst_solve = again.worst_solve;
      out.fits_horizon = again.fits_horizon;
      out.fits_replan = again.fits_replan;
    }
  }
}

std::vector<Result> SweepCase(const Case& c, const fs::path& config_dir, int repeats) {
  const Scene scene = LoadScene((config_dir / c.file).string());
  const InstanceConfig& shipped = scene.instances.front();
  const bool cart_pole = shipped.plant.type() == PlantType::kCartPole;
  const int n = static_cast<int>(shipped.q0.size());
  std::vector<Result> results;
  for (IntegratorType integrator : c.integrators) {
    for (int horizon : c.horizons) {
      for (double dt : c.dts) {
        for (int iterations : c.iterations) {
          Result r;
          r.setting = {horizon, dt, iterations, integrator};
          r.shipped = SameSetting(r.setting, shipped.controller.mpc);
          InstanceConfig config = shipped;
          MpcOptions& o = config.controller.mpc;
          o.horizon = horizon;
          o.dt = dt;
          o.iterations = iterations;
          o.integrator = integrator;
          if (const auto why = ValidateMpc(o, n, cart_pole, scene.period)) {
            r.status = "refused: " + *why;
          } else {
            try {
              RunRepeated(config, scene.period, c, repeats, r);
            } catch (const std::exception& e) {
              r.status = std::string("refused: ") + e.what();
            }
          }
          std::printf("%s N=%d dt=%g it=%d %s: %s%s%s, cost %.4g, solve mean %.3g ms worst %.3g ms\n", c.robot.c_str(),
                      horizon, dt, iterations, std::string(ToString(integrator)).c_str(),
                      r.success ? "success" : "failure", r.status == "ok" ? "" : (" (" + r.status + ")").c_str(),
                      r.deterministic ? "" : " (NOT deterministic)", r.tracking_cost, 1e3 * r.mean_solve,
                      1e3 * r.worst_solve);
          std::fflush(stdout);
          results.push_back(r);
        }
      }
    }
  }
  std::vector<FrontPoint> points;
  for (const Result& r : results) points.push_back({r.mean_solve, r.tracking_cost, r.success});
  const std::vector<bool> on = ParetoFront(points);
  for (std::size_t i = 0; i < results.size(); ++i) results[i].front = on[i];
  return results;
}

// A CSV field: the text quoted, its quotes doubled.
std::string Quoted(const std::string& text) {
  std::string q = "\"";
  for (char ch : text) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return q + "\"";
}

void WriteRows(std::ostream& csv, const std::string& robot, const std::vector<Result>& results) {
  for (const Result& r : results) {
    const Setting& s = r.setting;
    csv << robot << ',' << s.horizon << ',' << s.dt << ',' << s.horizon * s.dt << ',' << s.iterations << ','
        << ToString(s.integrator) << ',' << r.shipped << ',' << Quoted(r.status) << ',' << r.success << ','
        << r.first_ok_s << ',' << r.held_since_s << ',' << r.worst_x << ',' << r.final_position_error << ','
        << r.final_rotation_error << ',' << r.tau_bound << ',' << r.tau_exceeded << ',' << r.tracking_cost << ','
        << r.solves << ',' << r.failed_solves << ',' << 1e3 * r.mean_solve << ',' << 1e3 * r.worst_solve << ','
        << r.fits_horizon << ',' << r.fits_replan << ',' << r.front << ',' << r.deterministic << '\n';
  }
}

// The grids: a modest one (a few minutes on one core), and --quick's (a smoke run in seconds).
std::vector<Case> Cases(bool quick) {
  const std::vector<IntegratorType> all{IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler,
                                        IntegratorType::kRk4};
  const std::vector<IntegratorType> two{IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4};
  if (quick) {
    return {{"cartpole", "cartpole_mpc_swingup.yaml", 6.0, 1.0, {50, 100}, {0.02}, {1, 2}, two},
            {"panda", "panda_mpc_reach.yaml", 3.0, 0.5, {12, 25}, {0.02}, {1, 2}, two}};
  }
  return {{"cartpole", "cartpole_mpc_swingup.yaml", 6.0, 1.0, {50, 100, 200}, {0.01, 0.02, 0.04}, {1, 2, 4}, all},
          {"panda", "panda_mpc_reach.yaml", 3.0, 0.5, {12, 25, 50}, {0.01, 0.02, 0.04}, {1, 2, 4}, all}};
}

int Main(int argc, char** argv) {
  std::string out = "bench/results";
  std::string config_dir = std::string(LAGRANGE_SOURCE_DIR) + "/config";
  bool quick = false;
  int repeats = 3;
  CLI::App app{"mpc_sweep: closed-loop tracking cost and success against solve time for the shipped mpc scenes"};
  app.add_option("--out", out, "Folder for mpc_sweep.csv")->capture_default_str();
  app.add_option("--config-dir", config_dir, "Where the shipped scenes are")->capture_default_str();
  app.add_flag("--quick", quick, "A smaller grid, each run once (a smoke run)");
  app.add_option("--repeats", repeats, "Runs of each setting; the timings of the fastest are kept")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  CLI11_PARSE(app, argc, argv);
  if (quick) repeats = 1;
  fs::create_directories(out);
  std::ofstream csv(fs::path(out) / "mpc_sweep.csv");
  csv.precision(10);
  csv << "robot,horizon,dt_s,horizon_s,iterations,integrator,shipped,status,success,first_ok_s,held_since_s,"
         "worst_abs_x_m,final_position_error_m,final_rotation_error_rad,tau_bound_joints,tau_exceeded,"
         "tracking_cost,solves,failed_solves,mean_solve_ms,worst_solve_ms,fits_horizon,fits_replan,front,"
         "deterministic\n";
  for (const Case& c : Cases(quick)) WriteRows(csv, c.robot, SweepCase(c, config_dir, repeats));
  return 0;
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
