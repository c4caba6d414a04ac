// The two-process loop (external controller / external plant): what closing
// the control loop over LCM costs in latency, beside the single-process tick,
// in one run. On one private LCM URL (--port), one after another:
//   1. LCM round trip: this program pings a copy of itself (--echo, a second
//      process) through lagrange::Bus once per millisecond; the time from
//      Publish to the echo's arrival is the transport's round trip, the floor
//      of any two-process loop on this machine at this moment;
//   2. one process: lagranged on config/default.yaml (the arm under computed
//      torque in the tick itself, and the cart-pole) with --timing-csv. There
//      the torque applied in tick j is computed in tick j from state j − 1:
//      j − k = 1 for state k; that is the delay the two-process loop is
//      measured against;
//   3. two processes: lagranged #1 on config/arm_external_plant.yaml (the
//      simulated arm under an `external` controller: applies the latest
//      torque_t from ARM_TORQUE, publishes ARM_STATE every tick with tau = the
//      torque applied) and lagranged #2 on config/arm_external_controller.yaml with
//      --channel-prefix CTRL_ (computed torque on the measured ARM_STATE,
//      torque_t on ARM_TORQUE with state_tick = the state it used), both with
//      --timing-csv. This program timestamps every ARM_STATE and ARM_TORQUE it
//      receives with the wall clock (the clock of the messages' utime). For
//      each torque computed from state k:
//        - state → torque: its arrival − utime(state k), the time from plant
//          tick k's start to the torque being on the bus (and from the arrival
//          of state k here, the bus-observed figure);
//        - application: the first plant state j > k whose tau is bit-equal to
//          the torque's (both processes clamp to the same torque limits; the
//          plant adds nothing to an external torque): delay j − k ticks, and
//          utime(j) − utime(k); the loop adds j − k − 1 ticks to one process;
//        - never applied: superseded by a newer torque before a tick took it;
//        - daemon checks: a torque that arrived here well before a plant tick
//          that did not take it, a controller tick that used an older state
//          than the newest one here (kReceiveGuardUs).
//      #2 runs in --segments segments, each a new process: two free-running
//      1 kHz loops keep the phase between their ticks for as long as they
//      run, and that phase decides whether a torque makes the plant's next
//      tick, so one long run would measure one phase. Each segment ends with
//      SIGKILL to #2: the time until the plant's state shows MODE_HOLD is the
//      kill-to-hold figure (torque_timeout in the scene).
// Every daemon runs SCHED_OTHER unless --rt-priority P: then all with
// --mlockall --rt-priority P, and this program's receiving threads and the
// echo at a daemon's receive priority, so that they see what the daemons see.
//
// Files in --out: external.json (every figure, computed here; bench/report.py
// formats it), external_rtt.csv, external_torques.csv (one row per torque in
// a window), external_single_ticks.csv, external_plant_ticks.csv and
// external_controller_ticks_<segment>.csv (the daemons' --timing-csv), and
// the daemons' logs.

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/torque_t.hpp>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "bench/harness.hpp"
#include "bench/options.hpp"
#include "bench/stats.hpp"
#include "daemon/realtime.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "protocol/observer.hpp"
#include "protocol/receive.hpp"
#include "sim/scene.hpp"
#include "sim/scene_channels.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kSingleScene = "default.yaml";
constexpr const char* kPlantScene = "arm_external_plant.yaml";  // lagranged #1: the plant
constexpr const char* kControllerScene = "arm_external_controller.yaml";  // lagranged #2: the controller
constexpr const char* kControllerPrefix = "CTRL_";                   // #2's own channels
constexpr const char* kPingChannel = "LAGRANGE_BENCH_PING";
constexpr const char* kPongChannel = "LAGRANGE_BENCH_PONG";
constexpr int kApplyMargin = 20;  // ticks a window's last torques get to be applied before the window closes
// A message seen here this long before a daemon's tick began is one that tick
// should have taken: time for the daemon's receive thread to wake, decode and
// post it to the tick's mailbox.
constexpr std::int64_t kReceiveGuardUs = 100;

// config: the folder of the three scenes.
struct Options : DaemonOptions {
  Options() {
    config = SourceConfigDir();
    port = 7750;
  }
  double duration = 12.0;  // s: the one-process run, and the two-process loop over all segments
  int segments = 8;        // controller processes, one after another; each ends with SIGKILL
  int round_trips = 2000;
  double settle = 0.3;  // s after a controller's first torque is applied before its window opens
  // > 0: every daemon with --mlockall --rt-priority P (tick P, publish P − 1, receive P − 2); this
  // program's receiving threads and the echo at SCHED_FIFO P − 2, as a daemon's receive thread.
  int rt_priority = 0;

  int receive_priority() const { return PrioritiesBelow(rt_priority).receive; }
  bool quick = false;
  bool echo = false;  // internal: be the echo of the round-trip measurement
};

// ---- figures ---------------------------------------------------------------------------

json ToJson(const Summary& s) { return {{"n", s.n}, {"p50", s.p50}, {"p99", s.p99}, {"max", s.max}}; }

std::string Describe(const Summary& s, const char* unit) {
  std::ostringstream o;
  o.precision(4);
  o << "p50 " << s.p50 << ", p99 " << s.p99 << ", max " << s.max << ' ' << unit << " (n = " << s.n << ')';
  return o.str();
}

// A daemon's --timing-csv: "tick,utime_us,wake_latency_ns,compute_ns,overruns".
struct TickTiming {
  std::vector<double> compute_us, wake_us;
  std::int64_t overruns = 0;  // the last row's total, summed over files
};

// Adds one file's rows; a daemon killed with SIGKILL leaves a cut last line
// (no newline), which is skipped.
void ReadTiming(const fs::path& path, TickTiming& t) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  std::int64_t overruns = 0;
  while (std::getline(in, line) && !in.eof()) {
    std::int64_t v[5];
    std::istringstream row(line);
    char comma = 0;
    row >> v[0] >> comma >> v[1] >> comma >> v[2] >> comma >> v[3] >> comma >> v[4];
    if (!row || !row.eof()) continue;
    t.wake_us.push_back(1e-3 * static_cast<double>(v[2]));
    t.compute_us.push_back(1e-3 * static_cast<double>(v[3]));
    overruns = v[4];
  }
  t.overruns += overruns;
}

json ToJson(const TickTiming& t) {
  return {{"ticks", t.compute_us.size()},
          {"overruns", t.overruns},
          {"compute_us", ToJson(Summarize(t.compute_us))},
          {"wake_us", ToJson(Summarize(t.wake_us))}};
}

// ---- 1. LCM round trip ---------------------------------------------------------------------

// --echo: sends every ping back as a pong until an empty ping or 30 s without one.
int RunEcho(const std::string& url, int priority) {
  for (const std::string& problem : SetThisThreadPriority(priority))
    std::cerr << "external_bench --echo: " << problem << "\n";
  std::unique_ptr<Bus> bus = OpenBus(url);
  bool stop = false;
  bus->Subscribe(kPingChannel, [&](std::string_view, const std::uint8_t* data, std::size_t size) {
    if (size == 0) {
      stop = true;
      return;
    }
    bus->Publish(kPongChannel, data, size);
  });
  auto last = Clock::now();
  while (!stop && Clock::now() - last < std::chrono::seconds(30)) {
    if (bus->Handle(100) > 0) last = Clock::now();
  }
  return 0;
}

struct RoundTrips {
  std::vector<double> us;  // one per ping answered
  int lost = 0;            // pings without a pong within 100 ms
  std::string echo_exit;
};

// Pings the echo on `bus` and times each pong.
class Pinger {
 public:
  explicit Pinger(Bus& bus) : bus_(bus) {
    bus_.Subscribe(kPongChannel, [this](std::string_view, const std::uint8_t* data, std::size_t size) {
      std::int64_t k = -1;
      if (size == sizeof k) std::memcpy(&k, data, sizeof k);
      if (k == expected_) arrived_ns_ = MonotonicNs();
    });
  }
  // Ping `k`, waiting up to `timeout_ms` for its pong: the round trip, µs; -1 when none came.
  double Ping(std::int64_t k, int timeout_ms) {
    expected_ = k;
    arrived_ns_ = -1;
    const std::int64_t sent = MonotonicNs();
    bus_.Publish(kPingChannel, &k, sizeof k);
    const std::int64_t deadline = sent + std::int64_t{timeout_ms} * 1'000'000;
    while (arrived_ns_ < 0 && MonotonicNs() < deadline) {
      bus_.Handle(static_cast<int>(std::max<std::int64_t>(1, (deadline - MonotonicNs()) / 1'000'000)));
    }
    return arrived_ns_ < 0 ? -1.0 : 1e-3 * static_cast<double>(arrived_ns_ - sent);
  }

 private:
  Bus& bus_;
  std::int64_t expected_ = -1, arrived_ns_ = -1;
};

// Starts the echo and pings it once per millisecond (absolute schedule),
// each awaited before the next, at the receive priority.
RoundTrips PingEcho(const Options& o, const std::string& url) {
  for (const std::string& problem : SetThisThreadPriority(o.receive_priority())) {
    std::cerr << "external_bench: " << problem << "\n";
  }
  RoundTrips r;
  std::unique_ptr<Bus> bus = OpenBus(url);
  Pinger pinger(*bus);
  std::vector<std::string> argv = {fs::read_symlink("/proc/self/exe").string(), "--echo", "--port",
                                   std::to_string(o.port)};
  if (o.rt_priority > 0) argv.insert(argv.end(), {"--rt-priority", std::to_string(o.rt_priority)});
  const pid_t echo = Spawn(argv, o.File("external_echo.log"));
  // One pong back (the echo has subscribed) before timing; at most 5 s. Warm-up pings count down from -1.
  bool echoing = false;
  for (std::int64_t k = -1; k >= -250 && !echoing; --k) echoing = pinger.Ping(k, 20) >= 0;
  auto next = Clock::now();
  for (std::int64_t i = 0; i < o.round_trips; ++i) {
    next += std::chrono::milliseconds(1);
    std::this_thread::sleep_until(next);
    const double us = pinger.Ping(i, 100);
    if (us < 0) {
      ++r.lost;
    } else {
      r.us.push_back(us);
    }
    if (Clock::now() > next) next = Clock::now();  // a late pong: keep the spacing, do not burst
  }
  const char none = 0;
  bus->Publish(kPingChannel, &none, 0);  // an empty ping ends the echo
  r.echo_exit = DescribeExit(WaitExit(echo, 2.0).status);
  return r;
}

// PingEcho on a thread of its own, so that its priority ends with it.
RoundTrips MeasureRoundTrips(const Options& o, const std::string& url) {
  RoundTrips r;
  std::thread([&] { r = PingEcho(o, url); }).join();
  return r;
}

// ---- 2. one process ------------------------------------------------------------------------------

struct SingleRun {
  TickTiming timing;
  std::string exit;
};

std::vector<std::string> DaemonArgs(const Options& o, const std::string& url, const char* scene) {
  return LagrangedArgs(o.lagranged, o.Scene(scene), url, o.rt_priority);
}

SingleRun RunSingleProcess(const Options& o, const std::string& url) {
  const fs::path csv = o.File("external_single_ticks.csv");
  std::vector<std::string> argv = DaemonArgs(o, url, kSingleScene);
  argv.insert(argv.end(), {"--duration", std::to_string(o.duration), "--timing-csv", csv.string()});
  const pid_t pid = Spawn(argv, o.File("lagranged_external_single.log"));
  SingleRun r;
  r.exit = DescribeExit(WaitExit(pid, o.duration + 30.0).status);
  ReadTiming(csv, r.timing);
  return r;
}

// ---- 3. two processes: what the bus carries -----------------------------------------------------

struct StateSeen {
  std::int64_t tick = 0, utime = 0, arrival = 0;  // arrival: this program's wall clock, µs
  std::int8_t mode = 0;
  std::vector<double> tau;
};

struct TorqueSeen {
  std::int64_t run_id = 0, sequence = 0, state_tick = -1, utime = 0, arrival = 0;
  std::vector<double> tau;
};

struct Channels {
  std::string plant;  // the plant's instance
  std::string state, torque;
  std::string plant_prefix, controller_prefix;  // the daemons' channel prefixes
};

// Receives the plant's states and both statuses (a BusObserver per daemon,
// their hooks doing the per-message work) and the controller's torques,
// timestamping each message as its handler runs (once the typed receive
// decoded it).
class Observer {
 public:
  Observer(const std::string& url, const Channels& ch)
      : bus_(OpenBus(WithReceiveBuffer(url))),
        plant_(*bus_, ch.plant_prefix, ObserverLimits{.instances = 1, .discover = false, .telemetry = false},
               BusObserver::Hooks{.on_state = [this](const std::string&, const state_t& s) { OnState(s); },
                                  .on_status = [this](const status_t& s) { OnStatus(s, true); }}),
        controller_(*bus_, ch.controller_prefix, ObserverLimits{.instances = 0, .discover = false},
                    BusObserver::Hooks{.on_status = [this](const status_t& s) { OnStatus(s, false); }}) {
    plant_.Follow(ch.plant);
    SubscribeMessages<torque_t>(*bus_, ch.torque, [this](torque_t&& t) { OnTorque(t); });
  }

  // Receives until `stop`, at SCHED_FIFO `priority` (0: as it is).
  void Run(const std::atomic<bool>& stop, int priority) {
    for (const std::string& problem : SetThisThreadPriority(priority))
      std::cerr << "external_bench: " << problem << "\n";
    while (!stop.load()) bus_->Handle(20);
  }

  std::int64_t plant_run_id() const { return plant_run_id_.load(); }
  std::int8_t plant_mode() const { return plant_mode_.load(); }
  std::int64_t last_torque_run_id() const { return last_torque_run_id_.load(); }
  std::int64_t last_torque_arrival() const { return last_torque_arrival_.load(); }
  std::int64_t kernel_drops() const { return bus_->stats().kernel_drops; }

  // From now on, remember the first plant state in MODE_HOLD whose tick began after `after_us`.
  void WatchHold(std::int64_t after_us) {
    std::lock_guard<std::mutex> lock(mutex_);
    hold_after_ = after_us;
    hold_ = std::nullopt;
  }
  std::optional<StateSeen> hold() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return hold_;
  }

  // The last statuses of the plant and of a controller run.
  std::optional<status_t> plant_status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return plant_status_;
  }
  std::optional<status_t> controller_status(std::int64_t run_id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = controller_status_.find(run_id);
    return it == controller_status_.end() ? std::nullopt : std::optional<status_t>(it->second);
  }

  // After Run has returned.
  const std::vector<StateSeen>& states() const { return states_; }
  const std::vector<TorqueSeen>& torques() const { return torques_; }

 private:
  void OnState(const state_t& state) {
    const std::int64_t arrival = WallMicros();
    std::lock_guard<std::mutex> lock(mutex_);
    if (plant_run_id_.load() == 0) plant_run_id_.store(state.run_id);
    if (state.run_id != plant_run_id_.load()) return;  // not this run's plant
    states_.push_back({state.tick, state.utime, arrival, state.mode, state.tau});
    plant_mode_.store(state.mode);
    if (state.mode == state_t::MODE_HOLD && !hold_ && hold_after_ > 0 && state.utime > hold_after_) {
      hold_ = states_.back();
    }
  }

  void OnTorque(const torque_t& torque) {
    const std::int64_t arrival = WallMicros();
    std::lock_guard<std::mutex> lock(mutex_);
    torques_.push_back({torque.run_id, torque.sequence, torque.state_tick, torque.utime, arrival, torque.tau});
    last_torque_run_id_.store(torque.run_id);
    last_torque_arrival_.store(arrival);
  }

  void OnStatus(const status_t& s, bool plant) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (plant) {
      if (s.run_id == plant_run_id_.load()) plant_status_ = s;
    } else {
      controller_status_[s.run_id] = s;
    }
  }

  std::unique_ptr<Bus> bus_;
  BusObserver plant_, controller_;  // read on the receive thread only (their hooks)
  mutable std::mutex mutex_;
  std::vector<StateSeen> states_;
  std::vector<TorqueSeen> torques_;
  std::atomic<std::int64_t> plant_run_id_{0}, last_torque_run_id_{0}, last_torque_arrival_{-1};
  std::atomic<std::int8_t> plant_mode_{-1};
  std::int64_t hold_after_ = 0;
  std::optional<StateSeen> hold_;
  std::optional<status_t> plant_status_;
  std::map<std::int64_t, status_t> controller_status_;
};

// ---- 3. two processes: the run ---------------------------------------------------------------------

// One controller process.
struct Segment {
  std::int64_t run_id = 0;
  std::int64_t start_us = 0, end_us = 0;  // its measurement window, wall clock
  std::int64_t kill_us = -1;              // SIGKILL sent
  std::int64_t last_torque_arrival = -1;  // its last torque seen here before the kill
  std::optional<StateSeen> hold;          // the plant's first state in hold after the kill
  std::string exit;
  std::optional<status_t> status;  // its last status
};

struct TwoProcessRun {
  std::vector<Segment> segments;
  std::string plant_exit, problem;
  std::optional<status_t> plant_status;
  std::int64_t kernel_drops = 0;  // at this program's receive socket
};

// Starts controller `index`, waits until the plant applies its torques, lets
// the loop run its share of --duration, then SIGKILLs it and times the plant's hold.
std::optional<std::string> RunSegment(const Options& o, const std::string& url, Observer& observer, int index,
                                      std::int64_t previous_run_id, Segment& s) {
  std::vector<std::string> argv = DaemonArgs(o, url, kControllerScene);
  const std::string tag = std::to_string(index);
  argv.insert(argv.end(), {"--channel-prefix", kControllerPrefix, "--timing-csv",
                           o.File("external_controller_ticks_" + tag + ".csv").string()});
  const pid_t pid = Spawn(argv, o.File("lagranged_external_controller_" + tag + ".log"));
  const bool running = Await(
      [&] {
        const std::int64_t id = observer.last_torque_run_id();
        return id != 0 && id != previous_run_id && observer.plant_mode() == state_t::MODE_RUNNING;
      },
      20.0);
  if (!running) {
    s.exit = DescribeExit(WaitExit(pid, 0.1).status);
    return "controller " + tag + ": the plant never ran on its torques (see lagranged_external_controller_" + tag +
           ".log)";
  }
  s.run_id = observer.last_torque_run_id();
  std::this_thread::sleep_for(std::chrono::duration<double>(o.settle));
  s.start_us = WallMicros();
  std::this_thread::sleep_for(std::chrono::duration<double>(o.duration / o.segments));
  s.end_us = WallMicros();
  s.status = observer.controller_status(s.run_id);
  observer.WatchHold(s.end_us);
  s.kill_us = WallMicros();
  kill(pid, SIGKILL);
  s.exit = DescribeExit(WaitExit(pid, 2.0).status);
  Await([&] { return observer.hold().has_value(); }, 2.0);  // torque_timeout is 50 ms
  s.hold = observer.hold();
  s.last_torque_arrival = observer.last_torque_arrival();
  return std::nullopt;
}

TwoProcessRun RunTwoProcess(const Options& o, const std::string& url, const Channels& ch, Observer& observer) {
  TwoProcessRun r;
  std::vector<std::string> argv = DaemonArgs(o, url, kPlantScene);
  argv.insert(argv.end(), {"--timing-csv", o.File("external_plant_ticks.csv").string()});
  const pid_t plant = Spawn(argv, o.File("lagranged_external_plant.log"));
  if (!Await([&] { return observer.plant_run_id() != 0; }, 20.0)) {
    r.problem = "the plant published no state on " + ch.state + " (see lagranged_external_plant.log)";
  }
  std::int64_t previous = 0;
  for (int k = 0; k < o.segments && r.problem.empty(); ++k) {
    Segment s;
    if (auto problem = RunSegment(o, url, observer, k, previous, s)) r.problem = *problem;
    previous = s.run_id;
    r.segments.push_back(std::move(s));
  }
  r.plant_status = observer.plant_status();
  r.plant_exit = DescribeExit(Terminate(plant, 10.0).status);
  r.kernel_drops = observer.kernel_drops();
  return r;
}

// ---- 3. two processes: the analysis ---------------------------------------------------------------

// One torque computed from a state in a window. k: that state's tick; j: the plant tick that applied it.
struct TorqueResult {
  int segment = 0;
  const TorqueSeen* torque = nullptr;
  double state_to_torque_us = std::numeric_limits<double>::quiet_NaN();          // arrival − utime(k)
  double state_arrival_to_torque_us = std::numeric_limits<double>::quiet_NaN();  // arrival − arrival(k)
  double controller_tick_after_us = std::numeric_limits<double>::quiet_NaN();    // its utime − utime(k)
  bool older_state = false;        // the controller's tick began kReceiveGuardUs after a newer state arrived here
  std::int64_t applied_tick = -1;  // j; -1: never applied
  double delay_us = std::numeric_limits<double>::quiet_NaN();                   // utime(j) − utime(k)
  double added_us = std::numeric_limits<double>::quiet_NaN();                   // utime(j) − utime(k + 1)
  double arrival_to_application_us = std::numeric_limits<double>::quiet_NaN();  // utime(j) − arrival
  bool waited_a_tick = false;  // plant tick j − 1 began kReceiveGuardUs after it arrived here and did not take it
};

struct Analysis {
  std::vector<TorqueResult> torques;
  std::int64_t window_ticks = 0;              // plant states in the windows
  std::int64_t hold_ticks = 0;                // ... in MODE_HOLD
  std::int64_t other_mode_ticks = 0;          // ... neither running nor hold
  std::int64_t reused_ticks = 0;              // ... applying the same torque as the tick before (no new one in time)
  std::int64_t unmatched_ticks = 0;           // ... running on a torque this program never received
  std::int64_t at_limit_ticks = 0;            // ... with a joint's torque at its limit
  std::int64_t state_gaps = 0;                // plant ticks missing here, in the windows
  std::int64_t torque_gaps = 0;               // controller sequence numbers missing here
  std::int64_t waited_a_tick = 0;             // torques a plant tick should have taken and did not (see TorqueResult)
  std::int64_t older_state = 0;               // torques from an older state than the controller had (see TorqueResult)
  std::vector<double> tau_abs_max;            // N·m or N, per joint, applied in the windows
  std::vector<double> state_publication_us;   // arrival here − utime, the windows' plant states
  std::vector<double> torque_publication_us;  // arrival here − utime (the controller's tick), the windows' torques
  std::vector<json> segments;
};

// The plant's states as received: by tick, and in arrival order.
class PlantStates {
 public:
  explicit PlantStates(const std::vector<StateSeen>& arrived) : arrived_(arrived), newest_(arrived.size()) {
    for (std::size_t k = 0; k < arrived.size(); ++k) {
      by_tick_.emplace(arrived[k].tick, &arrived[k]);
      newest_[k] = std::max(arrived[k].tick, k > 0 ? newest_[k - 1] : std::int64_t{-1});
    }
  }
  const std::map<std::int64_t, const StateSeen*>& by_tick() const { return by_tick_; }
  const StateSeen* at(std::int64_t tick) const {
    const auto it = by_tick_.find(tick);
    return it == by_tick_.end() ? nullptr : it->second;
  }
  // The newest tick that had arrived here by `us` (wall clock); -1: none.
  std::int64_t NewestBy(std::int64_t us) const {
    const auto it = std::upper_bound(arrived_.begin(), arrived_.end(), us,
                                     [](std::int64_t t, const StateSeen& s) { return t < s.arrival; });
    return it == arrived_.begin() ? -1 : newest_[static_cast<std::size_t>(it - arrived_.begin()) - 1];
  }
  // The first and last tick that began in [start_us, end_us); (-1, -1) when none.
  std::pair<std::int64_t, std::int64_t> Window(std::int64_t start_us, std::int64_t end_us) const {
    std::int64_t first = -1, last = -1;
    for (const auto& [tick, s] : by_tick_) {
      if (s->utime < start_us || s->utime >= end_us) continue;
      if (first < 0) first = tick;
      last = tick;
    }
    return {first, last};
  }

 private:
  const std::vector<StateSeen>& arrived_;
  std::vector<std::int64_t> newest_;  // the newest tick among arrived_[0..k]
  std::map<std::int64_t, const StateSeen*> by_tick_;
};

// One segment: the plant ticks [first, last] of its window, and `end`, the
// tick up to which its torques may still be applied (the hold after the kill).
struct Window {
  std::int64_t first = -1, last = -1, end = -1;
  std::int64_t ticks = 0, hold = 0, reused = 0;
};

// (plant states, one controller's torques) => the tick that first applied
// each torque: the newest of that controller's torques with the state's bits
// computed from an earlier state. Counts the window's ticks by what they applied.
std::map<const TorqueSeen*, std::int64_t> MatchApplications(const PlantStates& plant,
                                                            const std::vector<const TorqueSeen*>& torques,
                                                            const InstanceConfig& config, Window& w, Analysis& a) {
  std::unordered_map<std::string, std::vector<const TorqueSeen*>> by_tau;
  for (const TorqueSeen* t : torques) by_tau[Bits(t->tau)].push_back(t);
  std::map<const TorqueSeen*, std::int64_t> applied;
  const TorqueSeen* previous = nullptr;
  const auto& by_tick = plant.by_tick();
  for (auto it = by_tick.lower_bound(w.first); it != by_tick.end() && it->first < w.end; ++it) {
    const StateSeen& s = *it->second;
    const TorqueSeen* match = nullptr;
    if (const auto c = by_tau.find(Bits(s.tau)); c != by_tau.end()) {
      for (const TorqueSeen* t : c->second) {
        if (t->state_tick < s.tick && (!match || t->sequence > match->sequence)) match = t;
      }
    }
    if (match && !applied.contains(match)) applied[match] = s.tick;
    if (s.tick <= w.last) {
      ++w.ticks;
      a.state_publication_us.push_back(static_cast<double>(s.arrival - s.utime));
      if (s.mode == state_t::MODE_HOLD) ++w.hold;
      if (s.mode != state_t::MODE_HOLD && s.mode != state_t::MODE_RUNNING) ++a.other_mode_ticks;
      if (s.mode == state_t::MODE_RUNNING && !match) ++a.unmatched_ticks;
      if (match && match == previous) ++w.reused;
      bool at_limit = false;
      for (std::size_t i = 0; i < a.tau_abs_max.size() && i < s.tau.size(); ++i) {
        a.tau_abs_max[i] = std::max(a.tau_abs_max[i], std::abs(s.tau[i]));
        const auto joint = static_cast<Eigen::Index>(i);
        at_limit =
            at_limit || (joint < config.torque_limits.size() && std::abs(s.tau[i]) >= config.torque_limits[joint]);
      }
      a.at_limit_ticks += at_limit ? 1 : 0;
    }
    previous = match;
  }
  return applied;
}

// (torque, the states it was computed from and applied at) => its latencies.
TorqueResult Measure(const PlantStates& plant, const TorqueSeen& t, std::optional<std::int64_t> applied_tick) {
  TorqueResult r;
  r.torque = &t;
  const StateSeen* k = plant.at(t.state_tick);
  if (k) {
    r.state_to_torque_us = static_cast<double>(t.arrival - k->utime);
    r.state_arrival_to_torque_us = static_cast<double>(t.arrival - k->arrival);
    r.controller_tick_after_us = static_cast<double>(t.utime - k->utime);
  }
  r.older_state = plant.NewestBy(t.utime - kReceiveGuardUs) > t.state_tick;
  if (!applied_tick) return r;
  r.applied_tick = *applied_tick;
  const StateSeen* j = plant.at(r.applied_tick);
  const StateSeen* k1 = plant.at(t.state_tick + 1);
  const StateSeen* before = plant.at(r.applied_tick - 1);
  if (k && j) r.delay_us = static_cast<double>(j->utime - k->utime);
  if (k1 && j) r.added_us = static_cast<double>(j->utime - k1->utime);
  if (j) r.arrival_to_application_us = static_cast<double>(j->utime - t.arrival);
  r.waited_a_tick = before && before->utime >= t.arrival + kReceiveGuardUs;
  return r;
}

json SegmentJson(const Segment& seg, std::size_t index, const Window& w, const std::vector<TorqueResult>& results) {
  std::vector<double> recv, phase, delay;
  std::size_t applied = 0;
  for (const TorqueResult& r : results) {
    if (std::isfinite(r.state_to_torque_us)) recv.push_back(r.state_to_torque_us);
    if (std::isfinite(r.controller_tick_after_us)) phase.push_back(r.controller_tick_after_us);
    if (r.applied_tick < 0) continue;
    delay.push_back(static_cast<double>(r.applied_tick - r.torque->state_tick));
    ++applied;
  }
  const Summary rs = Summarize(recv), ps = Summarize(phase), ds = Summarize(delay);
  const auto ms = [](std::int64_t us) { return 1e-3 * static_cast<double>(us); };
  json j = {{"segment", index},
            {"controller_run_id", seg.run_id},
            {"window_s", 1e-6 * static_cast<double>(seg.end_us - seg.start_us)},
            {"plant_ticks", w.ticks},
            {"plant_ticks_in_hold", w.hold},
            {"plant_ticks_reusing_torque", w.reused},
            {"torques", results.size()},
            {"applied", applied},
            {"controller_tick_after_state_us_p50", ps.p50},
            {"state_to_torque_us_p50", rs.p50},
            {"state_to_torque_us_p99", rs.p99},
            {"delay_ticks_p50", ds.p50},
            {"delay_ticks_p99", ds.p99},
            {"delay_ticks_max", ds.max},
            {"controller_exit", seg.exit}};
  if (seg.hold) {
    j["kill_to_hold_ms"] = ms(seg.hold->utime - seg.kill_us);
    j["kill_to_hold_seen_ms"] = ms(seg.hold->arrival - seg.kill_us);
    j["last_torque_to_hold_ms"] = ms(seg.hold->utime - seg.last_torque_arrival);
  }
  if (seg.status) {
    j["controller_measured_accepted"] = seg.status->measured_accepted;
    j["controller_measured_rejected"] = seg.status->measured_rejected;
    j["controller_overruns"] = seg.status->overruns;
  }
  return j;
}

// One segment's window: its plant ticks counted, each of its controller's
// torques measured (those from the window's states), into `a`.
void AnalyzeSegment(const PlantStates& plant, const Observer& observer, const InstanceConfig& config,
                    const Segment& seg, std::size_t index, Analysis& a) {
  Window w;
  std::tie(w.first, w.last) = plant.Window(seg.start_us, seg.end_us);
  if (w.first < 0) return;
  w.end = seg.hold ? seg.hold->tick : w.last + kApplyMargin;
  std::vector<const TorqueSeen*> mine;
  for (const TorqueSeen& t : observer.torques()) {
    if (t.run_id == seg.run_id) mine.push_back(&t);
  }
  const auto applied = MatchApplications(plant, mine, config, w, a);
  a.window_ticks += w.ticks;
  a.hold_ticks += w.hold;
  a.reused_ticks += w.reused;
  const auto& by_tick = plant.by_tick();
  a.state_gaps += (w.last - w.first + 1) -
                  static_cast<std::int64_t>(std::distance(by_tick.lower_bound(w.first), by_tick.upper_bound(w.last)));
  std::vector<TorqueResult> results;
  std::int64_t last_sequence = -1;
  for (const TorqueSeen* t : mine) {
    if (last_sequence >= 0 && t->sequence > last_sequence + 1) a.torque_gaps += t->sequence - last_sequence - 1;
    last_sequence = std::max(last_sequence, t->sequence);
    if (t->state_tick < w.first || t->state_tick > w.last - kApplyMargin) continue;
    const auto it = applied.find(t);
    TorqueResult r = Measure(plant, *t, it == applied.end() ? std::nullopt : std::optional(it->second));
    r.segment = static_cast<int>(index);
    a.torque_publication_us.push_back(static_cast<double>(t->arrival - t->utime));
    a.older_state += r.older_state ? 1 : 0;
    a.waited_a_tick += r.waited_a_tick ? 1 : 0;
    results.push_back(r);
  }
  a.segments.push_back(SegmentJson(seg, index, w, results));
  a.torques.insert(a.torques.end(), results.begin(), results.end());
}

Analysis Analyze(const TwoProcessRun& run, const Observer& observer, const InstanceConfig& config) {
  Analysis a;
  a.tau_abs_max.assign(static_cast<std::size_t>(config.plant.num_dofs()), 0.0);
  const PlantStates plant(observer.states());
  for (std::size_t si = 0; si < run.segments.size(); ++si) {
    if (run.segments[si].start_us != 0) AnalyzeSegment(plant, observer, config, run.segments[si], si, a);
  }
  return a;
}

// ---- output --------------------------------------------------------------------------------------

void WriteTorques(const fs::path& path, const Analysis& a) {
  std::ofstream csv(path);
  csv << "segment,sequence,state_tick,state_to_torque_us,state_arrival_to_torque_us,controller_tick_after_state_us,"
         "older_state,applied_tick,delay_ticks,delay_us,added_us,arrival_to_application_us,waited_a_tick\n";
  for (const TorqueResult& r : a.torques) {
    csv << r.segment << ',' << r.torque->sequence << ',' << r.torque->state_tick << ',' << r.state_to_torque_us << ','
        << r.state_arrival_to_torque_us << ',' << r.controller_tick_after_us << ',' << (r.older_state ? 1 : 0) << ','
        << r.applied_tick << ',' << (r.applied_tick >= 0 ? r.applied_tick - r.torque->state_tick : -1) << ','
        << r.delay_us << ',' << r.added_us << ',' << r.arrival_to_application_us << ',' << (r.waited_a_tick ? 1 : 0)
        << '\n';
  }
}

// The latencies of the torques of every window, sample by sample.
struct TorqueSamples {
  std::vector<double> recv, recv_bus, phase, delay_ticks, added_ticks, delay_us, added_us, application;
  std::map<std::int64_t, std::int64_t> histogram;  // delay j − k => torques
  std::int64_t never = 0;                          // never applied
};

TorqueSamples CollectTorques(const std::vector<TorqueResult>& torques) {
  TorqueSamples t;
  for (const TorqueResult& r : torques) {
    if (std::isfinite(r.state_to_torque_us)) t.recv.push_back(r.state_to_torque_us);
    if (std::isfinite(r.state_arrival_to_torque_us)) t.recv_bus.push_back(r.state_arrival_to_torque_us);
    if (std::isfinite(r.controller_tick_after_us)) t.phase.push_back(r.controller_tick_after_us);
    if (r.applied_tick < 0) {
      ++t.never;
      continue;
    }
    const std::int64_t d = r.applied_tick - r.torque->state_tick;
    ++t.histogram[d];
    t.delay_ticks.push_back(static_cast<double>(d));
    t.added_ticks.push_back(static_cast<double>(d - 1));
    if (std::isfinite(r.delay_us)) t.delay_us.push_back(r.delay_us);
    if (std::isfinite(r.added_us)) t.added_us.push_back(r.added_us);
    if (std::isfinite(r.arrival_to_application_us)) t.application.push_back(r.arrival_to_application_us);
  }
  return t;
}

// The torques' figures in external.json's two_process.
json TorqueJson(const Analysis& a) {
  const TorqueSamples t = CollectTorques(a.torques);
  json histogram = json::object();
  for (const auto& [d, count] : t.histogram) histogram[std::to_string(d)] = count;
  const std::size_t n = a.torques.size();
  return {{"torques", n},
          {"applied", n - static_cast<std::size_t>(t.never)},
          {"never_applied", t.never},
          {"never_applied_fraction", n == 0 ? 0.0 : static_cast<double>(t.never) / static_cast<double>(n)},
          {"state_to_torque_us", ToJson(Summarize(t.recv))},
          {"state_arrival_to_torque_us", ToJson(Summarize(t.recv_bus))},
          {"controller_tick_after_state_us", ToJson(Summarize(t.phase))},
          {"state_publication_us", ToJson(Summarize(a.state_publication_us))},
          {"torque_publication_us", ToJson(Summarize(a.torque_publication_us))},
          {"delay_ticks", ToJson(Summarize(t.delay_ticks))},
          {"delay_ticks_histogram", histogram},
          {"added_ticks", ToJson(Summarize(t.added_ticks))},
          {"delay_us", ToJson(Summarize(t.delay_us))},
          {"added_us", ToJson(Summarize(t.added_us))},
          {"added_ticks_mean", Mean(t.added_ticks)},
          {"arrival_to_application_us", ToJson(Summarize(t.application))},
          {"receive_guard_us", kReceiveGuardUs},
          {"torques_waited_a_tick", a.waited_a_tick},
          {"torques_from_older_state", a.older_state}};
}

// The plant's ticks in the windows and what this program missed, in external.json's two_process.
json TickJson(const TwoProcessRun& run, const Analysis& a) {
  return {{"plant_ticks_in_windows", a.window_ticks},
          {"plant_ticks_in_hold", a.hold_ticks},
          {"plant_ticks_other_mode", a.other_mode_ticks},
          {"plant_ticks_reusing_torque", a.reused_ticks},
          {"plant_ticks_unmatched", a.unmatched_ticks},
          {"plant_ticks_at_torque_limit", a.at_limit_ticks},
          {"tau_abs_max", a.tau_abs_max},
          {"states_missed_here", a.state_gaps},
          {"torques_missed_here", a.torque_gaps},
          {"kernel_drops_here", run.kernel_drops}};
}

// Each kill's time to the plant's hold: by the plant's tick (`seen`: false) or by its arrival here, ms.
Summary KillToHold(const TwoProcessRun& run, bool seen) {
  std::vector<double> ms;
  for (const Segment& s : run.segments) {
    if (s.hold) ms.push_back(1e-3 * static_cast<double>((seen ? s.hold->arrival : s.hold->utime) - s.kill_us));
  }
  return Summarize(std::move(ms));
}

json TwoProcessJson(const Options& o, const TwoProcessRun& run, const Analysis& a) {
  json j = {{"segments_run", run.segments.size()}, {"plant_exit", run.plant_exit}, {"problem", run.problem}};
  j.update(TorqueJson(a));
  j.update(TickJson(run, a));
  j["kill_to_hold_ms"] = ToJson(KillToHold(run, false));
  j["kill_to_hold_seen_ms"] = ToJson(KillToHold(run, true));
  j["segments"] = a.segments;
  if (run.plant_status) {
    j["plant_torques_accepted"] = run.plant_status->torques_accepted;
    j["plant_torques_rejected"] = run.plant_status->torques_rejected;
    j["plant_last_rejection"] = run.plant_status->last_rejection;
  }
  TickTiming plant, controller;
  ReadTiming(o.File("external_plant_ticks.csv"), plant);
  for (std::size_t k = 0; k < run.segments.size(); ++k) {
    ReadTiming(o.File("external_controller_ticks_" + std::to_string(k) + ".csv"), controller);
  }
  j["plant_timing"] = ToJson(plant);
  j["controller_timing"] = ToJson(controller);
  return j;
}

void PrintSummary(const json& j) {
  const json& rtt = j["round_trip_us"];
  const json& single = j["single_process"]["timing"];
  const json& two = j["two_process"];
  const auto line = [](const char* what, const json& s, const char* unit) {
    Summary x;
    x.n = s["n"].get<std::size_t>();
    x.p50 = s["p50"].is_number() ? s["p50"].get<double>() : std::nan("");
    x.p99 = s["p99"].is_number() ? s["p99"].get<double>() : std::nan("");
    x.max = s["max"].is_number() ? s["max"].get<double>() : std::nan("");
    std::cout << "  " << what << ": " << Describe(x, unit) << '\n';
  };
  std::cout << "external_bench:\n";
  line("LCM round trip", rtt, "µs");
  line("one process, tick compute", single["compute_us"], "µs");
  line("one process, wake-up latency", single["wake_us"], "µs");
  line("two processes, plant tick compute", two["plant_timing"]["compute_us"], "µs");
  line("two processes, controller tick compute", two["controller_timing"]["compute_us"], "µs");
  line("state → torque (utime(k) → arrival)", two["state_to_torque_us"], "µs");
  line("state → torque (arrival of k → arrival)", two["state_arrival_to_torque_us"], "µs");
  line("controller tick after plant tick k", two["controller_tick_after_state_us"], "µs");
  line("plant tick → its state here", two["state_publication_us"], "µs");
  line("controller tick → its torque here", two["torque_publication_us"], "µs");
  line("delay j − k", two["delay_ticks"], "ticks");
  line("added j − k − 1", two["added_ticks"], "ticks");
  line("added utime(j) − utime(k + 1)", two["added_us"], "µs");
  line("torque arrival → plant tick j", two["arrival_to_application_us"], "µs");
  line("kill → hold (plant tick)", two["kill_to_hold_ms"], "ms");
  std::cout << "  delay histogram " << two["delay_ticks_histogram"].dump() << "; never applied " << two["never_applied"]
            << " of " << two["torques"] << "; plant ticks in hold " << two["plant_ticks_in_hold"] << " of "
            << two["plant_ticks_in_windows"] << ", reusing the previous torque " << two["plant_ticks_reusing_torque"]
            << ", unmatched " << two["plant_ticks_unmatched"] << "; torques that waited a plant tick "
            << two["torques_waited_a_tick"] << ", from an older state " << two["torques_from_older_state"] << '\n';
}

// ---- main -----------------------------------------------------------------------------------------

// The two scenes of the loop and their channels.
struct LoopScenes {
  Scene plant, controller;
  Channels channels;
};

// The two scenes' channels, as lagranged derives them, and whether they meet.
std::optional<Channels> LoopChannels(const Scene& plant, const Scene& controller, std::string& problem) {
  if (plant.instances.size() != 1 || controller.instances.size() != 1) {
    problem = "the scenes do not close a loop: expected one instance each";
    return std::nullopt;
  }
  const InstanceChannelNames p = SceneChannelNames(plant.instances[0], "");
  const InstanceChannelNames c = SceneChannelNames(controller.instances[0], kControllerPrefix);
  if (p.torque_in.empty() || c.measured_in != p.state || c.torque_out != p.torque_in) {
    problem =
        "the scenes do not close a loop: the plant must publish what the controller reads, and read what it "
        "writes (one instance each)";
    return std::nullopt;
  }
  return Channels{plant.instances[0].name, p.state, p.torque_in, "", kControllerPrefix};
}

// The plant's and the controller's scenes from --config-dir; nullopt (and why, on stderr) when they do not load
// or do not close a loop.
std::optional<LoopScenes> LoadLoopScenes(const Options& o) {
  LoopScenes s;
  std::string problem;
  try {
    s.plant = LoadScene(o.Scene(kPlantScene));
    s.controller = LoadScene(o.Scene(kControllerScene));
  } catch (const std::exception& e) {
    problem = e.what();
  }
  if (problem.empty()) {
    if (std::optional<Channels> channels = LoopChannels(s.plant, s.controller, problem)) s.channels = *channels;
  }
  if (problem.empty()) return s;
  std::cerr << "external_bench: " << problem << "\n";
  return std::nullopt;
}

void AddOptions(CLI::App& app, Options& o) {
  AddDaemonOptions(app, o, ConfigOption::kSceneFolder, "Where default.yaml and the two external scenes are");
  auto* duration = app.add_option("--duration", o.duration, "Seconds of one process, and of the two-process loop")
                       ->check(CLI::Range(1.0, 3600.0))
                       ->capture_default_str();
  auto* segments = app.add_option("--segments", o.segments, "Controller processes, each ending with SIGKILL")
                       ->check(CLI::Range(1, 100))
                       ->capture_default_str();
  auto* round_trips = app.add_option("--round-trips", o.round_trips, "LCM pings, one per ms")
                          ->check(CLI::Range(10, 1000000))
                          ->capture_default_str();
  app.add_option("--rt-priority", o.rt_priority,
                 "Run every daemon with --mlockall --rt-priority P (SCHED_FIFO tick, publish and receive threads)")
      ->check(CLI::Range(1, 97));
  AddQuickFlag(app, o.quick, "2 s, 2 segments, 500 round trips (unless given)", [&o, duration, segments, round_trips] {
    QuickDefault(duration, o.duration, 2.0);
    QuickDefault(segments, o.segments, 2);
    QuickDefault(round_trips, o.round_trips, 500);
  });
  app.add_flag("--echo", o.echo, "Internal: answer the round-trip pings on --port")->group("");
}

// 1: the LCM round trip, into external_rtt.csv.
RoundTrips RunRoundTrips(const Options& o, const std::string& url) {
  std::cerr << "external_bench: LCM round trip (" << o.round_trips << " pings)\n";
  RoundTrips rtt = MeasureRoundTrips(o, url);
  std::ofstream csv(o.File("external_rtt.csv"));
  csv << "k,round_trip_us\n";
  for (std::size_t k = 0; k < rtt.us.size(); ++k) csv << k << ',' << rtt.us[k] << '\n';
  return rtt;
}

// 3: the two-process loop, its torques into external_torques.csv; external.json's two_process.
json RunLoop(const Options& o, const std::string& url, const LoopScenes& scenes, TwoProcessRun& two) {
  std::cerr << "external_bench: two processes, " << kPlantScene << " and " << kControllerScene << ", " << o.segments
            << " controller segment(s)\n";
  Observer observer(url, scenes.channels);
  std::atomic<bool> stop{false};
  std::thread receive([&] { observer.Run(stop, o.receive_priority()); });
  two = RunTwoProcess(o, url, scenes.channels, observer);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  stop = true;
  receive.join();
  const Analysis analysis = Analyze(two, observer, scenes.plant.instances[0]);
  WriteTorques(o.File("external_torques.csv"), analysis);
  return TwoProcessJson(o, two, analysis);
}

json SettingsJson(const Options& o, const std::string& url, const LoopScenes& scenes) {
  const InstanceConfig& plant = scenes.plant.instances[0];
  return {{"url", url},
          {"duration_s", o.duration},
          {"segments", o.segments},
          {"settle_s", o.settle},
          {"rt_priority", o.rt_priority},
          {"quick", o.quick},
          {"period_s", scenes.plant.period},
          {"torque_timeout_s", plant.controller.external.torque_timeout},
          {"torque_limits",
           std::vector<double>(plant.torque_limits.data(), plant.torque_limits.data() + plant.torque_limits.size())},
          {"scenes", {{"single", kSingleScene}, {"plant", kPlantScene}, {"controller", kControllerScene}}},
          {"channels", {{"state", scenes.channels.state}, {"torque", scenes.channels.torque}}},
          {"cores", std::thread::hardware_concurrency()}};
}

// 1, 2 and 3 one after another, into external.json; the exit status.
int Run(const Options& o, const std::string& url, const LoopScenes& scenes) {
  json settings = SettingsJson(o, url, scenes);
  settings["load_average_before"] = LoadAverage();
  const RoundTrips rtt = RunRoundTrips(o, url);
  std::cerr << "external_bench: one process, " << kSingleScene << ", " << o.duration << " s\n";
  const SingleRun single = RunSingleProcess(o, url);
  TwoProcessRun two;
  json loop = RunLoop(o, url, scenes, two);
  settings["load_average_after"] = LoadAverage();
  const json j = {{"settings", settings},
                  {"round_trip_us", ToJson(Summarize(rtt.us))},
                  {"round_trips_lost", rtt.lost},
                  {"echo_exit", rtt.echo_exit},
                  {"single_process", {{"timing", ToJson(single.timing)}, {"exit", single.exit}}},
                  {"two_process", std::move(loop)}};
  std::ofstream(o.File("external.json")) << j.dump(2) << '\n';
  PrintSummary(j);
  if (!two.problem.empty()) {
    std::cerr << "external_bench: " << two.problem << "\n";
    return 1;
  }
  const bool clean = single.exit == "exit 0" && two.plant_exit == "exit 0" && !rtt.us.empty();
  if (!clean) {
    std::cerr << "external_bench: one process " << single.exit << ", plant " << two.plant_exit << ", " << rtt.us.size()
              << " round trips\n";
  }
  return clean ? 0 : 1;
}

int Main(int argc, char** argv) {
  Options o;
  CLI::App app{"external_bench: the two-process loop (external controller / external plant) beside one process"};
  AddOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  const std::string url = Url(o.port);
  if (o.echo) return RunEcho(url, o.receive_priority());
  const std::optional<LoopScenes> scenes = LoadLoopScenes(o);
  if (!scenes) return 2;
  if (const int status = PrepareRun("external_bench", o, {o.port})) return status;
  return Run(o, url, *scenes);
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
