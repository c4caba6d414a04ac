// Accuracy against cost, live (issue 14, section 4): one lagranged on the
// default scene, switched every --seconds through the integrator settings
// below while this program streams a sine to the arm; an external lcm-logger
// records the arm's channels, and every live figure comes from the logged
// <ARM>_TELEMETRY. Beside it, the same instance offline (lagrange::Instance,
// the code the daemon's tick runs) through the same settings, and a denser
// curve per integrator family: the offline work-precision curve of this plant
// in this metric (compute per tick against ε growth per second).
//
// Settings, in order: explicit-euler, semi-implicit-euler, rk4, rk4 × 4
// sub-steps, dopri5 rtol 1e-6 atol 1e-9, dopri5 rtol 1e-10 atol 1e-12 (both
// max_steps 200), variational. Each is a SET_INTEGRATOR command on
// <ARM>_COMMAND that must be answered accepted on <ARM>_REPLY.
//
// The motion: q_d = q0 + A sin(2π f t) on both joints (A = 0.5 rad, f = 0.5
// Hz, q0 the scene's initial pose) with its qd and qdd, streamed on
// <ARM>_SETPOINT at 1 kHz from the start (utime: the wall clock) and for
// --settle s before the first switch; offline the same sine, sampled at the
// instance's time, goes into Instance::Step.
//
// A setting's ticks: from --drop s after its switch was applied (the logged
// reply's utime) to the next switch, cut to a whole number of sine periods;
// offline the same counts of ticks. Per setting:
//   compute      live: telemetry compute_us, the instance's share of the tick
//                (commands, control, integration, checks, accounting);
//                offline: the steady-clock time of Instance::Step (control,
//                integration, accounting), in a tight loop and again paced
//                at the scene's period for --paced-seconds (sleeping between
//                ticks as the daemon does). p50 / p99 / max, µs
//   evaluations  right-hand-side (variational: residual) evaluations per tick
//   ε growth     b of the least-squares fit ε(t) ≈ a + b t + the motion's
//                first four harmonics (sin and cos of 2π m f t), t simulated,
//                J/s: the secular drift, with what ε does periodically with
//                the motion taken out (see Growth); the same over each half
//                of the window (their difference is the noise figure); and
//                |ε(end) − ε(start)| / T
//   bound growth (quadrature_bound(end) − quadrature_bound(start)) / T, J/s:
//                the trapezoid rule's own error estimate; ε growth far above
//                it is the integrator's
//   floor        the rounding of ε's running sum, 2⁻⁵² (max|E| + max|W|) √n / T,
//                J/s: no ε growth below it means anything
//
// Files in --out: live.csv (live, one row per setting), live_offline.csv
// (offline: the settings, the same paced, then the curve), live_traces.csv (ε(t) of every
// setting's window, live, offline and replayed, every 50th tick), live.json (the run:
// settings, exits, problems), lagranged_live.log, lcm_logger_live.log, and
// with --keep-log live.lcmlog (lcm-logger's, about 0.5 MB per second). Exits non-zero when a command was refused or not
// answered, a setting has no logged telemetry, or a logged ε or energy is
// not finite (and when the daemon or the logger did not exit cleanly).

#include <signal.h>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <CLI/CLI.hpp>
#include <Eigen/QR>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "bench/harness.hpp"
#include "bench/options.hpp"
#include "bench/stats.hpp"
#include "controllers/trajectory.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "protocol/lcm_log.hpp"
#include "protocol/observer.hpp"
#include "protocol/receive.hpp"
#include "sim/instance.hpp"
#include "sim/scene.hpp"
#include "sim/scene_channels.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kScene = "default.yaml";
constexpr const char* kInstance = "arm";
constexpr double kAmplitude = 0.5;      // rad, both joints
constexpr double kFrequency = 0.5;      // Hz, both joints
constexpr double kStreamRate = 1000.0;  // setpoints per s
constexpr int kDopriMaxSteps = 200;     // internal steps per tick
constexpr double kReplyTimeout = 2.0;   // s
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// config: the folder of default.yaml.
struct Options : DaemonOptions {
  Options() {
    config = SourceConfigDir();
    port = 7751;
  }
  double seconds = 10.0;       // per setting
  double settle = 2.0;         // s of the sine under the scene's integrator before the first switch
  double drop = 0.5;           // s after each switch left out
  double paced_seconds = 3.0;  // per setting, offline paced at the period (compute only)
  bool quick = false;
  bool offline_only = false;  // development: skip the live run
  bool keep_log = false;      // keep live.lcmlog after reading it
};

// ---- settings ------------------------------------------------------------------------------

struct Setting {
  std::string label;
  IntegratorConfig config;
};

Setting Fixed(IntegratorType type, int substeps) {
  Setting s;
  s.config.type = type;
  s.config.substeps = substeps;
  s.label = std::string(ToString(type)) + (substeps > 1 ? " x" + std::to_string(substeps) : "");
  return s;
}

Setting Dopri(double rtol, double atol) {
  Setting s;
  s.config.type = IntegratorType::kDormandPrince;
  s.config.rtol = rtol;
  s.config.atol = atol;
  s.config.max_steps = kDopriMaxSteps;
  std::ostringstream label;
  label << "dopri5 " << rtol << "/" << atol;
  s.label = label.str();
  return s;
}

// The seven, in the order the daemon is switched through them.
std::vector<Setting> LiveSettings() {
  return {Fixed(IntegratorType::kExplicitEuler, 1),
          Fixed(IntegratorType::kSemiImplicitEuler, 1),
          Fixed(IntegratorType::kRk4, 1),
          Fixed(IntegratorType::kRk4, 4),
          Dopri(1e-6, 1e-9),
          Dopri(1e-10, 1e-12),
          Fixed(IntegratorType::kVariational, 1)};
}

// The offline curve: each family over its own knob.
std::vector<Setting> CurveSettings() {
  std::vector<Setting> c;
  for (IntegratorType type :
       {IntegratorType::kExplicitEuler, IntegratorType::kSemiImplicitEuler, IntegratorType::kRk4}) {
    for (int substeps : {1, 2, 4, 8, 16}) c.push_back(Fixed(type, substeps));
  }
  for (int e = 4; e <= 12; ++e) {
    const double rtol = std::pow(10.0, -e);
    c.push_back(Dopri(rtol, rtol / 100.0));
  }
  for (int substeps : {1, 2, 4, 8}) c.push_back(Fixed(IntegratorType::kVariational, substeps));
  return c;
}

// ---- one tick's figures and a window's ------------------------------------------------------------

struct Tick {
  std::int64_t tick = 0, utime = 0;
  double t = 0.0;      // s, simulated
  double clock = 0.0;  // s, the sine's: live the wall clock (utime, from the log's first), offline t
  double eps = 0.0, bound = 0.0, energy = 0.0, work = 0.0;  // J
  double compute_us = 0.0;
  std::int64_t evaluations = 0, rejected = 0, failures = 0;
  double error_estimate = kNaN;  // dopri5's scaled error norm of the tick's last accepted step
  std::int8_t mode = state_t::MODE_RUNNING;
  std::string integrator;
  int substeps = 1;
};

struct Figures {
  std::size_t ticks = 0;      // in the window
  std::int64_t missed = 0;    // tick numbers missing from the window (live: not logged)
  double window_s = 0.0;      // simulated
  double clock_s = 0.0;       // on the sine's clock (live: the wall's; offline = window_s)
  double periods = 0.0;       // sine periods in the window
  Summary compute;            // µs
  double evaluations = kNaN;  // per tick, mean
  std::int64_t rejected = 0, failures = 0;
  double eps_growth = kNaN, eps_growth_first = kNaN, eps_growth_second = kNaN;  // J/s, least squares
  double eps_change_rate = kNaN;                                                // |Δε| / T, J/s
  double bound_growth = kNaN;                                                   // J/s
  double floor = kNaN;                                                          // J/s
  double eps_swing = kNaN;           // J: max − min of ε(t) − b t, what ε does periodically with the motion
  double error_estimate_max = kNaN;  // dopri5: the largest scaled error norm (<= 1)
  double eps_start = kNaN, eps_end = kNaN;  // J
  bool finite = true;
  std::vector<std::pair<double, double>> trace;  // (t s, ε J) every kTraceEvery-th tick of the window
};

constexpr std::size_t kTraceEvery = 50;

// ε(t) = a + b t + Σ_{m=1..kHarmonics} (c_m sin 2πmft + d_m cos 2πmft), least
// squares over ticks [from, to) => b, J/s; t simulated, the harmonics on
// the sine's clock (live, the daemon's simulated time and the wall clock the
// sine is streamed by may drift apart). The harmonics of the motion take
// out what ε does periodically with it (an integrator's energy error along a
// periodic motion is largely periodic itself: RK4's swings by 3e-12 J here
// and drifts by nothing measurable), which a straight line over a finite
// window would read as growth. NaN over less than kMinPeriods.
constexpr int kHarmonics = 4;
constexpr double kMinPeriods = 0.98;  // live: a whole period on the wall clock, less the ticks' start jitter

double Growth(const std::vector<Tick>& v, std::size_t from, std::size_t to) {
  if (to <= from || (v[to - 1].clock - v[from].clock) * kFrequency < kMinPeriods) return kNaN;
  const auto n = static_cast<Eigen::Index>(to - from);
  const double t0 = 0.5 * (v[from].t + v[to - 1].t);
  Eigen::MatrixXd a(n, 2 + 2 * kHarmonics);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Tick& k = v[from + static_cast<std::size_t>(i)];
    a(i, 0) = 1.0;
    a(i, 1) = k.t - t0;
    for (int m = 1; m <= kHarmonics; ++m) {
      const double phase = 2.0 * std::numbers::pi * m * kFrequency * k.clock;
      a(i, 2 * m) = std::sin(phase);
      a(i, 2 * m + 1) = std::cos(phase);
    }
    y(i) = k.eps;
  }
  return a.colPivHouseholderQr().solve(y)(1);
}

// Cuts `v` (at least two ticks) to the longest whole number of sine periods (on the sine's clock) from its first tick.
void CutToWholePeriods(std::vector<Tick>& v) {
  const double whole = std::floor((v.back().clock - v.front().clock) * kFrequency + 1e-6) / kFrequency;
  if (whole <= 0.0) return;
  const double end = v.front().clock + whole + 1e-9;
  v.erase(std::find_if(v.begin(), v.end(), [&](const Tick& k) { return k.clock > end; }), v.end());
}

// The window's compute, evaluations, step counts and error estimates, and the round-off floor of ε's sums.
void Tally(const std::vector<Tick>& v, Figures& f) {
  std::vector<double> compute;
  double evaluations = 0.0, max_e = 0.0, max_w = 0.0;
  for (const Tick& k : v) {
    compute.push_back(k.compute_us);
    evaluations += static_cast<double>(k.evaluations);
    f.rejected += k.rejected;
    f.failures += k.failures;
    max_e = std::max(max_e, std::abs(k.energy));
    max_w = std::max(max_w, std::abs(k.work));
    if (std::isfinite(k.error_estimate)) f.error_estimate_max = std::fmax(f.error_estimate_max, k.error_estimate);
  }
  f.compute = Summarize(std::move(compute));
  f.evaluations = evaluations / static_cast<double>(v.size());
  f.floor =
      std::numeric_limits<double>::epsilon() * (max_e + max_w) * std::sqrt(static_cast<double>(v.size())) / f.window_s;
}

// ε's growth over the window and over each half, and its swing about the growth.
void FitGrowth(const std::vector<Tick>& v, Figures& f) {
  // The halves share the middle tick, so each spans half the window.
  const double mid_clock = v.front().clock + 0.5 * f.clock_s - 1e-9;
  const auto mid = static_cast<std::size_t>(
      std::find_if(v.begin(), v.end(), [&](const Tick& k) { return k.clock >= mid_clock; }) - v.begin());
  f.eps_growth = Growth(v, 0, v.size());
  f.eps_growth_first = Growth(v, 0, std::min(mid + 1, v.size()));
  f.eps_growth_second = Growth(v, mid, v.size());
  if (!std::isfinite(f.eps_growth)) return;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Tick& k : v) {
    const double detrended = k.eps - f.eps_growth * (k.t - v.front().t);
    lo = std::min(lo, detrended);
    hi = std::max(hi, detrended);
  }
  f.eps_swing = hi - lo;
}

// A setting's ticks (after the drop, in time order) => its figures, over the
// longest whole number of sine periods (on the sine's clock) from the first tick.
Figures Analyze(std::vector<Tick> v) {
  Figures f;
  for (const Tick& k : v) f.finite = f.finite && std::isfinite(k.eps) && std::isfinite(k.energy);
  if (v.size() < 2) {
    f.ticks = v.size();
    return f;
  }
  CutToWholePeriods(v);
  f.ticks = v.size();
  for (std::size_t k = 0; k < v.size(); k += kTraceEvery) f.trace.emplace_back(v[k].t, v[k].eps);
  f.window_s = v.back().t - v.front().t;
  f.clock_s = v.back().clock - v.front().clock;
  f.periods = f.clock_s * kFrequency;
  f.missed = (v.back().tick - v.front().tick + 1) - static_cast<std::int64_t>(v.size());
  Tally(v, f);
  FitGrowth(v, f);
  f.eps_start = v.front().eps;
  f.eps_end = v.back().eps;
  f.eps_change_rate = std::abs(f.eps_end - f.eps_start) / f.window_s;
  f.bound_growth = (v.back().bound - v.front().bound) / f.window_s;
  return f;
}

// ---- the live run ---------------------------------------------------------------------------------

struct Reply {
  bool accepted = false;
  std::string reason;
  std::int64_t utime = 0;
};

// The arm's run (the first run id its state is heard from, by a BusObserver
// following the arm) and the replies to this program's commands, as they arrive.
class Observer {
 public:
  Observer(const std::string& url, const std::vector<InstanceChannelNames>& ch, std::size_t arm)
      : bus_(OpenBus(url)),
        daemon_(*bus_, "", ObserverLimits{.instances = 1, .discover = false, .telemetry = false},
                BusObserver::Hooks{.on_state = [this](const std::string&, const state_t& s) {
                  std::int64_t none = 0;
                  run_id_.compare_exchange_strong(none, s.run_id);
                }}) {
    daemon_.Follow(ch[arm].instance);
    SubscribeMessages<reply_t>(*bus_, ch[arm].reply, [this](reply_t&& r) {
      std::lock_guard<std::mutex> lock(mutex_);
      replies_[r.request_id] = {r.accepted != 0, r.reason, r.utime};
    });
  }

  void Run(const std::atomic<bool>& stop) {
    while (!stop.load()) bus_->Handle(20);
  }
  std::int64_t run_id() const { return run_id_.load(); }
  std::optional<Reply> reply(std::int64_t request_id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = replies_.find(request_id);
    return it == replies_.end() ? std::nullopt : std::optional<Reply>(it->second);
  }

 private:
  std::unique_ptr<Bus> bus_;
  std::atomic<std::int64_t> run_id_{0};
  BusObserver daemon_;  // read on the receive thread only (its hook)
  mutable std::mutex mutex_;
  std::map<std::int64_t, Reply> replies_;
};

// q_d = q0 + kAmplitude sin(2π kFrequency t) on every joint of the arm, q0 its initial pose.
std::unique_ptr<Trajectory> ArmSine(const InstanceConfig& arm) {
  return MakeSine(arm.q0, VectorXd::Constant(arm.q0.size(), kAmplitude), VectorXd::Constant(arm.q0.size(), kFrequency));
}

// Publishes the sine on `channel` at kStreamRate (absolute schedule) until `stop`.
void StreamSine(const std::string& url, const std::string& channel, const Trajectory& sine, int n,
                const std::atomic<bool>& stop) {
  std::unique_ptr<Bus> bus = OpenBus(url);
  Setpoint sp(n);
  setpoint_t msg;
  msg.num_dofs = n;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / kStreamRate));
  const auto start = Clock::now();
  auto next = start;
  while (!stop.load()) {
    sine.Sample(std::chrono::duration<double>(Clock::now() - start).count(), sp);
    msg.utime = WallMicros();
    msg.q.assign(sp.q.data(), sp.q.data() + n);
    msg.qd.assign(sp.qd.data(), sp.qd.data() + n);
    msg.qdd.assign(sp.qdd.data(), sp.qdd.data() + n);
    bus->PublishMessage(channel, msg);
    next += period;
    std::this_thread::sleep_until(next);
    if (Clock::now() > next + 10 * period) next = Clock::now();  // a long stall: resume, do not burst
  }
}

command_t IntegratorCommand(const IntegratorConfig& c, std::int64_t request_id) {
  const bool dopri = c.type == IntegratorType::kDormandPrince;
  command_t cmd = CommandMessage(command_t::SET_INTEGRATOR, request_id);
  cmd.setting = std::string(ToString(c.type));
  cmd.substeps = c.substeps;
  cmd.rtol = dopri ? c.rtol : 0.0;
  cmd.atol = dopri ? c.atol : 0.0;
  cmd.max_steps = dopri ? c.max_steps : 0;
  cmd.on = false;
  return cmd;
}

struct Switch {
  std::int64_t request_id = 0;
  std::optional<Reply> reply;  // as received here
};

struct LiveRun {
  std::int64_t run_id = 0;
  std::vector<Switch> switches;  // one per setting, as far as the run went
  std::int64_t end_us = 0;       // the last setting's hold ended, wall clock
  std::string daemon_exit, logger_exit, problem;
  std::string load_before, load_after;
};

// SET_INTEGRATOR on `channel` for each setting in turn, each held --seconds
// once accepted; stops at the first refused or unanswered (r.problem).
void SwitchThrough(const Options& o, const std::string& url, const std::string& channel, const Observer& observer,
                   const std::vector<Setting>& settings, LiveRun& r) {
  std::unique_ptr<Bus> commands = OpenBus(url);
  std::mt19937_64 random{std::random_device{}()};
  for (const Setting& s : settings) {
    Switch sw;
    while (sw.request_id == 0) sw.request_id = static_cast<std::int64_t>(random() >> 1);
    commands->PublishMessage(channel, IntegratorCommand(s.config, sw.request_id));
    Await([&] { return observer.reply(sw.request_id).has_value(); }, kReplyTimeout);
    sw.reply = observer.reply(sw.request_id);
    r.switches.push_back(sw);
    if (!sw.reply) {
      r.problem = "no reply to SET_INTEGRATOR " + s.label + " within " + std::to_string(kReplyTimeout) + " s";
      break;
    }
    if (!sw.reply->accepted) {
      r.problem = "SET_INTEGRATOR " + s.label + " refused: " + sw.reply->reason;
      break;
    }
    std::cerr << "live_bench: " << s.label << " for " << o.seconds << " s\n";
    std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
  }
}

// The daemon from start to exit: once it publishes, the sine streams to the
// arm, and after --settle it is switched through the settings.
void DriveDaemon(const Options& o, const Scene& scene, std::size_t arm, const std::vector<Setting>& settings,
                 const Observer& observer, LiveRun& r) {
  const std::string url = Url(o.port);
  const std::vector<InstanceChannelNames> ch = SceneChannelNames(scene, "");
  const std::unique_ptr<Trajectory> sine = ArmSine(scene.instances[arm]);
  const pid_t daemon = Spawn(LagrangedArgs(o.lagranged, o.Scene(kScene), url), o.File("lagranged_live.log"));
  std::atomic<bool> stop_stream{false};
  std::thread stream;
  if (!Await([&] { return observer.run_id() != 0; }, 20.0)) {
    r.problem = "lagranged published no " + ch[arm].state + " (see lagranged_live.log)";
  } else {
    r.run_id = observer.run_id();
    const int n = scene.instances[arm].plant.num_dofs();
    stream = std::thread([&, n] { StreamSine(url, ch[arm].setpoint, *sine, n, stop_stream); });
    std::this_thread::sleep_for(std::chrono::duration<double>(o.settle));
    SwitchThrough(o, url, ch[arm].command, observer, settings, r);
    r.end_us = WallMicros();
  }
  // The sine streams until the daemon has stopped: without it the arm would go to hold.
  r.daemon_exit = DescribeExit(Terminate(daemon, 10.0).status);
  stop_stream = true;
  if (stream.joinable()) stream.join();
}

// Logger, daemon, the sine, the switches; every child stopped before it returns.
LiveRun RunLive(const Options& o, const Scene& scene, std::size_t arm, const std::vector<Setting>& settings) {
  LiveRun r;
  const std::string url = Url(o.port);
  const std::vector<InstanceChannelNames> ch = SceneChannelNames(scene, "");
  const std::string logged =
      ch[arm].state + "|" + ch[arm].setpoint + "|" + ch[arm].command + "|" + ch[arm].reply + "|" + ch[arm].telemetry;
  r.load_before = LoadAverage();
  // The logger, descheduled on a busy machine, must not lose the states and setpoints the replay needs.
  LcmLogger logger(WithReceiveBuffer(url), logged, o.File("live.lcmlog"), o.File("lcm_logger_live.log"));
  if (!logger.AwaitReady()) {
    r.problem = "lcm-logger did not start recording (see lcm_logger_live.log)";
    r.logger_exit = DescribeExit(logger.Stop().status);
    return r;
  }
  Observer observer(url, ch, arm);
  std::atomic<bool> stop_receive{false};
  std::thread receive([&] { observer.Run(stop_receive); });
  DriveDaemon(o, scene, arm, settings, observer, r);
  stop_receive = true;
  receive.join();
  r.logger_exit = DescribeExit(logger.Stop().status);
  r.load_after = LoadAverage();
  return r;
}

// ---- the log --------------------------------------------------------------------------------------

struct LoggedState {
  std::int64_t utime = 0;  // when the tick ran (wall clock)
  VectorXd q, qd;          // at the tick's end
  std::string q_des_bits;  // Bits of the setpoint's q the tick used
};

struct LoggedSetpoint {
  Setpoint setpoint;
  std::int64_t utime = 0;  // when sent (wall clock)
  std::int64_t index = 0;  // its place in the stream, as logged
};

struct Log {
  std::vector<Tick> ticks;                     // the run's telemetry, in log order
  std::map<std::int64_t, LoggedState> states;  // the run's state_t by tick
  // What this program streamed, by Bits(q): the sine comes back to the same
  // bits (at rest before it starts, and now and then in its periods), so
  // every setpoint with those bits, in log order; the one a tick used is the
  // latest sent before it ran.
  std::unordered_map<std::string, std::vector<LoggedSetpoint>> setpoints;
  std::int64_t setpoint_count = 0;
  std::map<std::int64_t, std::int64_t> reply_utime;  // request_id → the reply's utime
  std::int64_t nonfinite = 0;                        // telemetry with a non-finite ε or energy
  std::int64_t events = 0;
};

// The setpoint a logged tick used: the latest with its q_des bits sent before the tick ran.
const LoggedSetpoint* LatestBefore(const Log& log, const LoggedState& state) {
  const auto it = log.setpoints.find(state.q_des_bits);
  if (it == log.setpoints.end()) return nullptr;
  const LoggedSetpoint* latest = nullptr;
  for (const LoggedSetpoint& sp : it->second) {
    if (sp.utime <= state.utime) latest = &sp;
  }
  return latest != nullptr ? latest : &it->second.front();
}

// A message's vector as an Eigen vector.
Eigen::Map<const VectorXd> View(const std::vector<double>& v) {
  return Eigen::Map<const VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// A telemetry_t as a tick's figures (all but the sine's clock).
Tick TelemetryTick(const telemetry_t& m) {
  Tick k;
  k.tick = m.tick;
  k.utime = m.utime;
  k.t = m.t;
  k.eps = m.energy_residual;
  k.bound = m.quadrature_bound;
  k.energy = m.energy;
  k.work = m.work;
  k.compute_us = m.compute_us;
  k.evaluations = m.evaluations;
  k.rejected = m.steps_rejected;
  k.failures = m.failures;
  if (m.error_estimate >= 0.0) k.error_estimate = m.error_estimate;  // −1: none
  k.mode = m.mode;
  k.integrator = m.integrator;
  k.substeps = m.substeps;
  return k;
}

// The arm's channels of one run, event by event, into a Log.
class LogReading {
 public:
  LogReading(const std::vector<InstanceChannelNames>& ch, std::size_t arm, std::int64_t run_id)
      : ch_(ch), arm_(arm), run_id_(run_id) {}

  void Read(const LcmLogEvent& e) {
    ++log_.events;
    if (e.channel == ch_[arm_].state) {
      if (ReceiveInto(state_, e.data, e.size, Framing::kRecorded) == Drop::kNone && state_.run_id == run_id_) OnState();
    } else if (e.channel == ch_[arm_].setpoint) {
      if (ReceiveInto(setpoint_, e.data, e.size, Framing::kRecorded) == Drop::kNone) OnSetpoint();
    } else if (e.channel == ch_[arm_].reply) {
      if (ReceiveInto(reply_, e.data, e.size, Framing::kRecorded) == Drop::kNone && reply_.run_id == run_id_)
        log_.reply_utime[reply_.request_id] = reply_.utime;
    } else if (e.channel == ch_[arm_].telemetry) {
      if (ReceiveInto(telemetry_, e.data, e.size, Framing::kRecorded) == Drop::kNone && telemetry_.run_id == run_id_)
        OnTelemetry();
    }
  }
  Log Take() { return std::move(log_); }

 private:
  void OnState() { log_.states[state_.tick] = {state_.utime, View(state_.q), View(state_.qd), Bits(state_.q_des)}; }
  void OnSetpoint() {
    Setpoint sp(setpoint_.num_dofs);
    sp.q = View(setpoint_.q);
    sp.qd = View(setpoint_.qd);
    sp.qdd = View(setpoint_.qdd);
    log_.setpoints[Bits(setpoint_.q)].push_back(LoggedSetpoint{std::move(sp), setpoint_.utime, log_.setpoint_count++});
  }
  void OnTelemetry() {
    Tick k = TelemetryTick(telemetry_);
    if (base_us_ < 0) base_us_ = telemetry_.utime;
    k.clock = 1e-6 * static_cast<double>(telemetry_.utime - base_us_);
    if (!std::isfinite(k.eps) || !std::isfinite(k.energy)) ++log_.nonfinite;
    log_.ticks.push_back(std::move(k));
  }

  const std::vector<InstanceChannelNames>& ch_;
  std::size_t arm_;
  std::int64_t run_id_;
  Log log_;
  telemetry_t telemetry_;
  reply_t reply_;
  state_t state_;
  setpoint_t setpoint_;
  std::int64_t base_us_ = -1;  // the first telemetry's utime: the clock's zero
};

Log ReadLog(const fs::path& file, const std::vector<InstanceChannelNames>& ch, std::size_t arm, std::int64_t run_id) {
  LogReading reading(ch, arm, run_id);
  ForEachLogEvent(file, [&](const LcmLogEvent& e) { reading.Read(e); });
  return reading.Take();
}

struct LiveSegment {
  std::vector<Tick> ticks;  // after the drop, by tick (before Analyze's cut to whole periods)
  Figures figures;
  std::int64_t mismatched = 0;   // ticks in the window reporting another integrator or sub-step count
  std::int64_t not_running = 0;  // ticks in the window not in MODE_RUNNING
  bool reply_logged = false;
};

// Setting k's ticks: from its switch + drop to the next switch (or its hold's end).
std::vector<LiveSegment> SplitLog(const Log& log, const LiveRun& run, const std::vector<Setting>& settings,
                                  const Options& o) {
  std::vector<LiveSegment> segments;
  std::vector<std::int64_t> starts;
  for (const Switch& sw : run.switches) {
    const auto it = log.reply_utime.find(sw.request_id);
    starts.push_back(it != log.reply_utime.end() ? it->second : sw.reply ? sw.reply->utime : 0);
  }
  for (std::size_t k = 0; k < run.switches.size(); ++k) {
    LiveSegment seg;
    seg.reply_logged = log.reply_utime.contains(run.switches[k].request_id);
    const std::int64_t from = starts[k] + static_cast<std::int64_t>(o.drop * 1e6);
    const std::int64_t to = std::min(starts[k] + static_cast<std::int64_t>(o.seconds * 1e6),
                                     k + 1 < starts.size() ? starts[k + 1] : run.end_us);
    const IntegratorConfig& c = settings[k].config;
    std::vector<Tick> v;
    for (const Tick& t : log.ticks) {
      if (t.utime < from || t.utime >= to) continue;
      if (t.mode != state_t::MODE_RUNNING) ++seg.not_running;
      if (t.integrator != ToString(c.type) || t.substeps != std::max(1, c.substeps)) ++seg.mismatched;
      v.push_back(t);
    }
    std::sort(v.begin(), v.end(), [](const Tick& a, const Tick& b) { return a.tick < b.tick; });
    seg.figures = Analyze(v);
    seg.ticks = std::move(v);
    segments.push_back(std::move(seg));
  }
  return segments;
}

// ---- offline ---------------------------------------------------------------------------------------

// One tick as the daemon's: Step under `sp`, timed.
Tick StepTimed(Instance& inst, const Setpoint& sp, double period) {
  const auto start = Clock::now();
  inst.Step(period, sp);
  const auto end = Clock::now();
  Tick k;
  k.tick = inst.steps();
  k.t = inst.t();
  k.compute_us = std::chrono::duration<double, std::micro>(end - start).count();
  const EnergyBalance& balance = inst.energy_balance();
  k.eps = balance.residual();
  k.bound = balance.quadrature_bound();
  k.work = balance.work();
  k.energy = inst.KineticEnergy() + inst.PotentialEnergy();
  const IntegratorWork& w = inst.integrator().work();
  k.evaluations = w.evaluations;
  k.rejected = w.rejected;
  k.failures = w.failures;
  k.error_estimate = w.error_estimate;
  k.clock = k.t;
  k.integrator = std::string(ToString(inst.integrator().type()));
  k.substeps = inst.integrator().config().substeps;
  return k;
}

struct Replayed {
  Figures figures;
  double state_difference = kNaN;  // max over the window of |q − q_live|∞ and |qd − qd_live|∞, rad or rad/s
  std::int64_t setpoints_unmatched = 0;  // ticks whose q_des matched no logged setpoint (the previous one used)
  // The live input, over the window's ticks: the age of the setpoint in use
  // (the tick's utime − the setpoint's), µs; ticks that took the same setpoint
  // as the tick before; ticks whose setpoint came more than one after the
  // previous tick's (setpoints never used).
  Summary setpoint_age_us;
  std::int64_t setpoints_reused = 0, setpoints_skipped = 0;
  std::int64_t states_missing = 0;  // ticks without a logged state (the previous setpoint used)
};

// The replay's input, tick by tick: the setpoint the daemon used, and what
// the live input did (counted into the Replayed).
class ReplayInput {
 public:
  ReplayInput(const Log& log, Replayed& r) : log_(log), r_(r) {}

  // `sp` = the setpoint the tick of `state` used; unchanged when the state
  // was not logged (null) or its q_des matches no logged setpoint. A tick in
  // the window (`counted`) adds its setpoint's age, and whether it reused
  // the previous tick's or skipped some.
  void Next(const LoggedState* state, bool counted, Setpoint& sp) {
    const LoggedSetpoint* used = state ? LatestBefore(log_, *state) : nullptr;
    if (!state) {
      ++r_.states_missing;  // its setpoint unknown: the previous one again
    } else if (!used) {
      ++r_.setpoints_unmatched;
    } else {
      sp = used->setpoint;
      if (counted) {
        ages_.push_back(static_cast<double>(state->utime - used->utime));
        r_.setpoints_reused += previous_ >= 0 && used->index == previous_ ? 1 : 0;
        r_.setpoints_skipped += previous_ >= 0 && used->index > previous_ + 1 ? 1 : 0;
      }
    }
    previous_ = used ? used->index : -1;
  }
  std::vector<double> TakeAges() { return std::move(ages_); }

 private:
  const Log& log_;
  Replayed& r_;
  std::int64_t previous_ = -1;  // the previous tick's setpoint index
  std::vector<double> ages_;    // µs
};

// The arm offline: the live run's sequence, its replay, and the curve's points.
struct Offline {
  const InstanceConfig& config;
  double period;  // s
  const Options& o;
  std::unique_ptr<Trajectory> sine = ArmSine(config);

  std::int64_t Ticks(double seconds) const { return std::llround(seconds / period); }

  // `seconds` of ticks, those after the drop into `keep` (when given). Paced:
  // one tick per period on an absolute schedule, sleeping in between as the
  // daemon's tick thread does (caches and clock speed as the daemon finds them).
  void Run(Instance& inst, double seconds, std::vector<Tick>* keep, bool paced = false) const {
    Setpoint sp(inst.num_dofs());
    const std::int64_t n = Ticks(seconds), drop = Ticks(o.drop);
    const auto step = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period));
    auto next = Clock::now();
    for (std::int64_t k = 0; k < n; ++k) {
      sine->Sample(inst.t(), sp);
      Tick t = StepTimed(inst, sp, period);
      if (keep && k >= drop) keep->push_back(std::move(t));
      if (!paced) continue;
      next += step;
      std::this_thread::sleep_until(next);
    }
  }

  // (settings) => their figures on one instance switched through them in
  // turn after the settle, `seconds` each: the live run's sequence.
  std::vector<Figures> Sequence(const std::vector<Setting>& settings, double seconds, bool paced,
                                std::string& problem) const {
    Instance inst(config);
    Run(inst, o.settle, nullptr);
    std::vector<Figures> figures;
    for (const Setting& s : settings) {
      std::vector<Tick> v;
      if (const char* refused = inst.SetIntegrator(s.config)) problem += "offline " + s.label + ": " + refused + "; ";
      Run(inst, seconds, &v, paced);
      figures.push_back(Analyze(std::move(v)));
    }
    return figures;
  }

  // (setting, a live window) => the window again offline, from the logged
  // state two ticks before it, each tick under the setpoint the daemon used
  // (its q_des bits matched to the logged ARM_SETPOINT, which carries qd and
  // qdd); t and the sine's clock as live. The first tick warms up the
  // integrator (dopri5's step proposal starts over) and is not kept.
  Replayed Replay(const Setting& s, const Log& log, const std::vector<Tick>& live) const {
    Replayed r;
    if (live.empty()) return r;
    const auto start = log.states.find(live.front().tick - 2);
    if (start == log.states.end()) {
      r.states_missing = 1;
      return r;
    }
    Instance inst(config);
    inst.SetIntegrator(s.config);
    inst.SetMeasured(start->second.q, start->second.qd);
    Setpoint sp(inst.num_dofs());
    ReplayInput input(log, r);
    std::vector<Tick> v;
    auto next_live = live.begin();
    r.state_difference = 0.0;
    for (std::int64_t tick = live.front().tick - 1; tick <= live.back().tick; ++tick) {
      const auto state = log.states.find(tick);
      const LoggedState* logged = state == log.states.end() ? nullptr : &state->second;
      input.Next(logged, tick >= live.front().tick, sp);
      Tick k = StepTimed(inst, sp, period);
      if (logged) {
        r.state_difference = std::max({r.state_difference, (inst.q() - logged->q).lpNorm<Eigen::Infinity>(),
                                       (inst.qd() - logged->qd).lpNorm<Eigen::Infinity>()});
      }
      while (next_live != live.end() && next_live->tick < tick) ++next_live;
      if (next_live == live.end() || next_live->tick != tick) continue;
      k.tick = tick;
      k.t = next_live->t;
      k.clock = next_live->clock;
      v.push_back(std::move(k));
    }
    r.figures = Analyze(std::move(v));
    r.setpoint_age_us = Summarize(input.TakeAges());
    return r;
  }

  // (setting) => its figures from a new instance, settled under the scene's integrator.
  Figures Point(const Setting& s, std::string& problem) const {
    Instance inst(config);
    Run(inst, o.settle, nullptr);
    if (const char* refused = inst.SetIntegrator(s.config)) problem += "offline " + s.label + ": " + refused + "; ";
    std::vector<Tick> v;
    Run(inst, o.seconds, &v);
    return Analyze(std::move(v));
  }
};

// ---- output ----------------------------------------------------------------------------------------

constexpr const char* kFigureHeader =
    "ticks,ticks_missed,window_s,periods,compute_us_p50,compute_us_p99,compute_us_max,evaluations_per_tick,"
    "steps_rejected,failures,eps_growth_J_per_s,eps_growth_first_half_J_per_s,eps_growth_second_half_J_per_s,"
    "eps_change_rate_J_per_s,eps_swing_J,quadrature_bound_growth_J_per_s,roundoff_floor_J_per_s,"
    "error_estimate_max,clock_s,eps_start_J,eps_end_J";

void WriteSetting(std::ostream& csv, const Setting& s) {
  const bool dopri = s.config.type == IntegratorType::kDormandPrince;
  csv << '"' << s.label << "\"," << ToString(s.config.type) << ',' << s.config.substeps << ','
      << (dopri ? s.config.rtol : 0.0) << ',' << (dopri ? s.config.atol : 0.0) << ','
      << (dopri ? s.config.max_steps : 0) << ',';
}

void WriteFigures(std::ostream& csv, const Figures& f) {
  csv << f.ticks << ',' << f.missed << ',' << f.window_s << ',' << f.periods << ',' << f.compute.p50 << ','
      << f.compute.p99 << ',' << f.compute.max << ',' << f.evaluations << ',' << f.rejected << ',' << f.failures << ','
      << f.eps_growth << ',' << f.eps_growth_first << ',' << f.eps_growth_second << ',' << f.eps_change_rate << ','
      << f.eps_swing << ',' << f.bound_growth << ',' << f.floor << ',' << f.error_estimate_max << ',' << f.clock_s
      << ',' << f.eps_start << ',' << f.eps_end;
}

void PrintRow(const std::string& source, const Setting& s, const Figures& f) {
  std::ostringstream o;
  o.precision(3);
  o << "  " << source << "  " << s.label << ": compute p50 " << f.compute.p50 << " µs, p99 " << f.compute.p99 << " µs, "
    << f.evaluations << " evaluations/tick, ε growth " << f.eps_growth << " J/s (halves " << f.eps_growth_first << ", "
    << f.eps_growth_second << "), swing " << f.eps_swing << " J, " << f.ticks << " ticks over " << f.window_s
    << " s simulated, " << f.clock_s << " s on the sine's clock\n";
  std::cout << o.str();
}

// Everything the run measured, live and offline.
struct Results {
  LiveRun run;
  Log log;
  std::vector<LiveSegment> live;  // one per setting the daemon ran
  std::vector<Figures> same;      // offline, the live run's sequence
  std::vector<Figures> paced;     // the same, paced at the period
  std::vector<Replayed> replays;  // one per live segment
  std::vector<Figures> curve;     // one per CurveSettings()
  std::string offline_problem;
};

// live.csv: one row per setting the daemon ran.
void WriteLive(const Options& o, const std::vector<Setting>& settings, const Results& r) {
  std::ofstream csv(o.File("live.csv"));
  csv.precision(10);
  csv << "setting,integrator,substeps,rtol,atol,max_steps,reply_logged,ticks_mismatched,ticks_not_running,"
      << kFigureHeader << '\n';
  for (std::size_t k = 0; k < r.live.size(); ++k) {
    WriteSetting(csv, settings[k]);
    csv << (r.live[k].reply_logged ? 1 : 0) << ',' << r.live[k].mismatched << ',' << r.live[k].not_running << ',';
    WriteFigures(csv, r.live[k].figures);
    csv << '\n';
  }
}

// One row of live_offline.csv; the replay's columns empty for the other kinds.
void WriteOfflineRow(std::ostream& csv, const char* kind, const Setting& s, const Figures& f, const Replayed* r) {
  csv << kind << ',';
  WriteSetting(csv, s);
  WriteFigures(csv, f);
  if (!r) {
    csv << ",,,,,,,,\n";
    return;
  }
  csv << ',' << r->state_difference << ',' << r->setpoints_unmatched << ',' << r->states_missing << ','
      << r->setpoint_age_us.p50 << ',' << r->setpoint_age_us.p99 << ',' << r->setpoint_age_us.max << ','
      << r->setpoints_reused << ',' << r->setpoints_skipped << '\n';
}

// live_offline.csv: the settings offline, the same paced, the replays, then the curve.
void WriteOffline(const Options& o, const std::vector<Setting>& settings, const Results& r) {
  std::ofstream csv(o.File("live_offline.csv"));
  csv.precision(10);
  csv << "kind,setting,integrator,substeps,rtol,atol,max_steps," << kFigureHeader
      << ",state_difference_max,setpoints_unmatched,states_missing,setpoint_age_us_p50,setpoint_age_us_p99,"
         "setpoint_age_us_max,setpoints_reused,setpoints_skipped\n";
  for (std::size_t k = 0; k < r.same.size(); ++k) WriteOfflineRow(csv, "setting", settings[k], r.same[k], nullptr);
  for (std::size_t k = 0; k < r.paced.size(); ++k) WriteOfflineRow(csv, "paced", settings[k], r.paced[k], nullptr);
  for (std::size_t k = 0; k < r.replays.size(); ++k) {
    WriteOfflineRow(csv, "replay", settings[k], r.replays[k].figures, &r.replays[k]);
  }
  const std::vector<Setting> curve = CurveSettings();
  for (std::size_t k = 0; k < r.curve.size(); ++k) WriteOfflineRow(csv, "curve", curve[k], r.curve[k], nullptr);
}

// live_traces.csv: ε(t) of every window, live, offline and replayed.
void WriteTraces(const Options& o, const std::vector<Setting>& settings, const Results& r) {
  std::ofstream csv(o.File("live_traces.csv"));
  csv.precision(12);
  csv << "source,setting,t_s,eps_J\n";
  const auto write = [&](const char* source, const Setting& s, const Figures& f) {
    for (const auto& [t, eps] : f.trace) csv << source << ",\"" << s.label << "\"," << t << ',' << eps << '\n';
  };
  for (std::size_t k = 0; k < r.live.size(); ++k) write("live", settings[k], r.live[k].figures);
  for (std::size_t k = 0; k < r.same.size(); ++k) write("offline", settings[k], r.same[k]);
  for (std::size_t k = 0; k < r.replays.size(); ++k) write("replay", settings[k], r.replays[k].figures);
}

// live.json: the run's settings, exits and problems.
void WriteRunJson(const Options& o, const Scene& scene, std::size_t arm, const Results& r,
                  const std::vector<std::string>& problems) {
  const VectorXd& q0 = scene.instances[arm].q0;
  const json sine = {{"amplitude_rad", kAmplitude},
                     {"frequency_hz", kFrequency},
                     {"stream_hz", kStreamRate},
                     {"center_rad", std::vector<double>(q0.data(), q0.data() + q0.size())}};
  const json j = {{"url", Url(o.port)},
                  {"scene", kScene},
                  {"instance", kInstance},
                  {"period_s", scene.period},
                  {"seconds_per_setting", o.seconds},
                  {"settle_s", o.settle},
                  {"drop_s", o.drop},
                  {"quick", o.quick},
                  {"sine", sine},
                  {"dopri5_max_steps", kDopriMaxSteps},
                  {"run_id", r.run.run_id},
                  {"log_events", r.log.events},
                  {"telemetry_logged", r.log.ticks.size()},
                  {"daemon_exit", r.run.daemon_exit},
                  {"logger_exit", r.run.logger_exit},
                  {"cores", std::thread::hardware_concurrency()},
                  {"load_average_before", r.run.load_before},
                  {"load_average_after", r.run.load_after},
                  {"problems", problems}};
  std::ofstream(o.File("live.json")) << j.dump(2) << '\n';
}

// Every setting's figures on stdout.
void PrintRows(const std::vector<Setting>& settings, const Results& r) {
  std::cout << "live_bench (live: telemetry compute_us; offline: Instance::Step):\n";
  for (std::size_t k = 0; k < settings.size(); ++k) {
    if (k < r.live.size()) PrintRow("live   ", settings[k], r.live[k].figures);
    PrintRow("offline", settings[k], r.same[k]);
    PrintRow("paced  ", settings[k], r.paced[k]);
    if (k >= r.replays.size()) continue;
    const Replayed& rp = r.replays[k];
    PrintRow("replay ", settings[k], rp.figures);
    std::cout << "           replay: state difference " << rp.state_difference << ", setpoints unmatched "
              << rp.setpoints_unmatched << ", states missing " << rp.states_missing << "; setpoint age p50 "
              << rp.setpoint_age_us.p50 << " µs, p99 " << rp.setpoint_age_us.p99 << " µs, max "
              << rp.setpoint_age_us.max << " µs, reused " << rp.setpoints_reused << ", skipped " << rp.setpoints_skipped
              << '\n';
  }
}

// ---- the run ----------------------------------------------------------------------------------------

// The daemon switched through the settings, and its log split into the settings' windows.
void RunLivePart(const Options& o, const Scene& scene, std::size_t arm, const std::vector<Setting>& settings,
                 Results& r) {
  r.run = RunLive(o, scene, arm, settings);
  r.log = ReadLog(o.File("live.lcmlog"), SceneChannelNames(scene, ""), arm, r.run.run_id);
  r.live = SplitLog(r.log, r.run, settings, o);
  if (!o.keep_log) fs::remove(o.File("live.lcmlog"));
}

// The same settings offline, tight and paced, the curve, and the replay of every live window.
void RunOfflinePart(const Options& o, const Scene& scene, std::size_t arm, const std::vector<Setting>& settings,
                    Results& r) {
  std::cerr << "live_bench: offline, the same settings and the curve\n";
  const Offline offline{scene.instances[arm], scene.period, o};
  r.same = offline.Sequence(settings, o.seconds, false, r.offline_problem);
  std::cerr << "live_bench: offline paced at the scene's period, " << o.paced_seconds << " s a setting\n";
  r.paced = offline.Sequence(settings, o.paced_seconds, true, r.offline_problem);
  for (const Setting& s : CurveSettings()) r.curve.push_back(offline.Point(s, r.offline_problem));
  for (std::size_t k = 0; k < r.live.size(); ++k) {
    r.replays.push_back(offline.Replay(settings[k], r.log, r.live[k].ticks));
  }
}

// The self check: what makes the run's figures not what they say.
std::vector<std::string> Problems(const Options& o, const std::vector<Setting>& settings, const Results& r) {
  std::vector<std::string> problems;
  if (!r.run.problem.empty()) problems.push_back(r.run.problem);
  if (!r.offline_problem.empty()) problems.push_back(r.offline_problem);
  if (r.log.nonfinite > 0)
    problems.push_back(std::to_string(r.log.nonfinite) + " logged telemetry with a non-finite ε or energy");
  for (std::size_t k = 0; k < r.live.size(); ++k) {
    if (r.live[k].figures.ticks == 0) problems.push_back("no telemetry logged for " + settings[k].label);
    if (!r.live[k].figures.finite) problems.push_back("non-finite ε or energy under " + settings[k].label);
    if (r.live[k].mismatched > 0) {
      problems.push_back(std::to_string(r.live[k].mismatched) + " ticks under " + settings[k].label +
                         " reported another integrator or sub-step count");
    }
  }
  if (!o.offline_only && r.run.daemon_exit != "exit 0") problems.push_back("lagranged: " + r.run.daemon_exit);
  if (!o.offline_only && r.run.logger_exit != "exit 0") problems.push_back("lcm-logger: " + r.run.logger_exit);
  return problems;
}

// ---- main -------------------------------------------------------------------------------------------

void AddOptions(CLI::App& app, Options& o) {
  AddDaemonOptions(app, o, ConfigOption::kSceneFolder, "Where default.yaml is");
  auto* seconds = app.add_option("--seconds", o.seconds, "Seconds per setting")
                      ->check(CLI::Range(1.0, 3600.0))
                      ->capture_default_str();
  auto* settle = app.add_option("--settle", o.settle, "Seconds of the sine before the first switch")
                     ->check(CLI::Range(0.0, 600.0))
                     ->capture_default_str();
  app.add_option("--drop", o.drop, "Seconds left out after each switch")
      ->check(CLI::Range(0.0, 60.0))
      ->capture_default_str();
  auto* paced_seconds = app.add_option("--paced-seconds", o.paced_seconds,
                                       "Seconds per setting of the offline run paced at the period (compute only)")
                            ->check(CLI::Range(0.0, 3600.0))
                            ->capture_default_str();
  AddQuickFlag(app, o.quick, "5 s per setting (two sine periods kept), 1 s settle, 1 s paced (unless given)",
               [&o, seconds, settle, paced_seconds] {
                 QuickDefault(seconds, o.seconds, 5.0);
                 QuickDefault(settle, o.settle, 1.0);
                 QuickDefault(paced_seconds, o.paced_seconds, 1.0);
               });
  app.add_flag("--keep-log", o.keep_log, "Keep lcm-logger's live.lcmlog (removed once read otherwise)");
  app.add_flag("--offline-only", o.offline_only, "Skip the live run: the offline figures alone (no live.csv)");
}

// The scene and its arm's index; nullopt (and why, on stderr) when it does not load or has no arm.
std::optional<std::size_t> LoadArm(const Options& o, Scene& scene) {
  try {
    scene = LoadScene(o.Scene(kScene));
  } catch (const std::exception& e) {
    std::cerr << "live_bench: " << e.what() << "\n";
    return std::nullopt;
  }
  const auto found = std::find_if(scene.instances.begin(), scene.instances.end(),
                                  [](const InstanceConfig& c) { return c.name == kInstance; });
  if (found == scene.instances.end()) {
    std::cerr << "live_bench: " << kScene << " has no instance '" << kInstance << "'\n";
    return std::nullopt;
  }
  return static_cast<std::size_t>(found - scene.instances.begin());
}

int Main(int argc, char** argv) {
  Options o;
  CLI::App app{"live_bench: accuracy against cost, live in lagranged and offline, for every integrator setting"};
  AddOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  if (o.drop >= o.seconds) {
    std::cerr << "live_bench: --drop must be shorter than --seconds\n";
    return 2;
  }
  Scene scene;
  const std::optional<std::size_t> arm = LoadArm(o, scene);
  if (!arm) return 2;
  if (const int status = PrepareRun("live_bench", o, o.offline_only ? std::vector<int>{} : std::vector{o.port})) {
    return status;
  }
  const std::vector<Setting> settings = LiveSettings();
  std::cerr << "live_bench: lagranged on " << kScene << " (" << Url(o.port) << "), " << settings.size()
            << " settings of " << o.seconds << " s\n";
  Results r;
  if (!o.offline_only) RunLivePart(o, scene, *arm, settings, r);
  RunOfflinePart(o, scene, *arm, settings, r);
  const std::vector<std::string> problems = Problems(o, settings, r);
  if (!o.offline_only) WriteLive(o, settings, r);
  WriteOffline(o, settings, r);
  WriteTraces(o, settings, r);
  WriteRunJson(o, scene, *arm, r, problems);
  PrintRows(settings, r);
  for (const std::string& p : problems) std::cerr << "live_bench: " << p << "\n";
  return problems.empty() ? 0 : 1;
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
