// The loop (issue 6, item 5): the real lagranged on a scene (the default:
// config/default.yaml) at its period for a fixed time on a private LCM URL,
// with, at the same time,
//   - cyclictest (Debian rt-tests), the latency baseline: a 1 kHz
//     absolute-deadline clock_nanosleep loop doing no work, so its wake-up
//     latency is what the machine gives any sleeper under the same load. It
//     runs at the tick's policy (SCHED_OTHER here; SCHED_FIFO one priority
//     above the tick with --rt-priority, on the same CPU with --cpu), with
//     --default-system so that it does not lower the machine's wake-up
//     latency (/dev/cpu_dma_latency) for the daemon too. It also runs alone
//     for a while before the daemon starts, and once more alone with its
//     timer slack at 1 ns instead of Linux's default 50 µs for SCHED_OTHER
//     threads (SCHED_FIFO threads have none), to show what the slack
//     contributes;
//   - a setpoint prober: a new arm setpoint every 100 ms (+ up to 1 ms of
//     seeded jitter, so it does not lock to the tick's phase), timed from just
//     before lcm.publish to the first ARM_STATE whose q_des carries it;
//   - Debian's lcm-logger recording ARM_STATE, CARTPOLE_STATE and
//     LAGRANGE_STATUS: the states it logged against the ticks the daemon ran
//     (its final status) are the delivery figure.
// The daemon writes every tick's wake-up latency and compute time with
// --timing-csv (from a writer thread). Its CPU time comes from /proc over
// the steady window (from 2 s after its first state to 1 s before the end)
// and from wait4's rusage over the whole run.
//
// With --sigterm-runs N it then starts lagranged N times more, and sends each
// SIGTERM 0.3 s after its first state: the time to its exit (pidfd).
//
// Files in --out: loop_ticks.csv (the daemon's), cyclictest_<phase>.json
// (alone, alone-slack-1ns, concurrent), setpoint_latency.csv,
// loop_summary.csv, loop_threads.csv, loop_noise.csv, lagranged.log,
// sigterm.csv; with --tag T each name ends in _T (loop_ticks_T.csv, ...).
// The report script computes the percentiles.

#include <poll.h>
#include <signal.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <numbers>
#include <random>
#include <thread>

#include "bench/harness.hpp"
#include "bench/options.hpp"
#include "bench/proc_stats.hpp"
#include "protocol/bus.hpp"
#include "protocol/receive.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;

struct Options : DaemonOptions {
  Options() { port = 7901; }
  double duration = 60.0;  // s of daemon ticks
  double alone = 10.0;     // s of cyclictest alone before the daemon, twice (0: none)
  int rt_priority = 0;     // > 0: SCHED_FIFO for the daemon's tick, one more for cyclictest
  int cpu = -1;            // >= 0: the daemon's tick and cyclictest pinned to this CPU
  int sigterm_runs = 0;    // daemons started afterwards to time SIGTERM → exit
  std::string tag;         // appended to every file name

  // out/<stem>[_tag].<ext>
  fs::path Tagged(const std::string& stem, const std::string& ext = ".csv") const {
    return File(stem + (tag.empty() ? "" : "_" + tag) + ext);
  }
};

// The channels lcm-logger records.
const std::vector<std::string> kLoggedStates = {"ARM_STATE", "CARTPOLE_STATE"};
constexpr const char* kLoggedChannels = "ARM_STATE|CARTPOLE_STATE|LAGRANGE_STATUS";

// ---- cyclictest ---------------------------------------------------------------------

// Runs cyclictest for `seconds` (whole) in phase `phase` (file cyclictest_<phase>.json); returns its pid.
pid_t StartCyclictest(const Options& o, const std::string& phase, int seconds, bool beside_daemon,
                      unsigned long timer_slack_ns = 0) {
  const bool rt = beside_daemon && o.rt_priority > 0;
  return Spawn(CyclictestArgs(seconds, o.Tagged("cyclictest_" + phase, ".json"), rt ? o.rt_priority + 1 : 0,
                              beside_daemon ? o.cpu : -1, rt),
               o.Tagged("cyclictest_" + phase, ".log"), timer_slack_ns);
}

void RunCyclictestAlone(const Options& o, const std::string& phase, unsigned long timer_slack_ns = 0) {
  const int seconds = std::max(1, static_cast<int>(std::lround(o.alone)));
  const Exit e = WaitExit(StartCyclictest(o, phase, seconds, false, timer_slack_ns), seconds + 30.0);
  if (e.status != 0)
    std::cerr << "loop_bench: cyclictest (" << phase << ") ended with " << DescribeExit(e.status) << "\n";
}
// ---- the setpoint prober --------------------------------------------------------

// Sends arm setpoints on one LCM and matches them in ARM_STATE on another.
class SetpointProbe {
 public:
  SetpointProbe(const std::string& url) : in_(url), out_(url) {
    in_.subscribe("ARM_STATE", &SetpointProbe::OnState, this);
    in_.subscribe("LAGRANGE_STATUS", &SetpointProbe::OnStatus, this);
  }

  // Handles ARM_STATE until `stop`.
  void Receive(const std::atomic<bool>& stop) {
    while (!stop.load()) in_.handleTimeout(20);
  }
  // Publishes a setpoint every 100 ms (+ jitter) until `stop`.
  void Send(const std::atomic<bool>& stop);

  std::int64_t states() const { return states_.load(); }
  std::int64_t gaps() const { return gaps_; }
  std::int64_t run_id() const { return run_id_.load(); }
  // Ticks the daemon ran, from the latest status (its final one once it exited).
  std::int64_t ticks_run() const { return ticks_run_.load(); }
  // (sent, latency ns) of every setpoint; latency < 0: never seen in a state.
  std::vector<std::pair<std::int64_t, std::int64_t>> results() const;

 private:
  static double Value(std::int64_t k) { return std::numbers::pi / 4 + 1e-4 * static_cast<double>(k); }  // rad
  void OnState(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void OnStatus(const lcm::ReceiveBuffer* rbuf, const std::string& channel);

  lcm::LCM in_, out_;
  std::atomic<std::int64_t> states_{0}, run_id_{0}, ticks_run_{0};
  std::int64_t gaps_ = 0, last_tick_ = -1;
  mutable std::mutex mutex_;
  std::int64_t pending_ = -1;                 // the setpoint not yet seen in a state
  std::vector<std::int64_t> sent_, latency_;  // ns, per setpoint
};

void SetpointProbe::Send(const std::atomic<bool>& stop) {
  JitteredSchedule schedule(std::chrono::milliseconds(100));
  for (std::int64_t k = 0; !stop.load(); ++k) {
    schedule.SleepUntilNext();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      pending_ = k;
      sent_.push_back(MonotonicNs());
      latency_.push_back(-1);
    }
    const setpoint_t sp = SetpointMessage(WallMicros(), {Value(k), 0.0});
    out_.publish("ARM_SETPOINT", &sp);
  }
}

void SetpointProbe::OnState(const lcm::ReceiveBuffer* rbuf, const std::string&) {
  const std::int64_t now = MonotonicNs();
  state_t s;
  if (ReceiveInto(s, rbuf->data, rbuf->data_size) != Drop::kNone) return;
  states_.fetch_add(1);
  run_id_.store(s.run_id);
  if (last_tick_ >= 0 && s.tick != last_tick_ + 1) ++gaps_;
  last_tick_ = s.tick;
  std::lock_guard<std::mutex> lock(mutex_);
  if (pending_ >= 0 && !s.q_des.empty() && s.q_des[0] == Value(pending_)) {
    latency_[static_cast<std::size_t>(pending_)] = now - sent_[static_cast<std::size_t>(pending_)];
    pending_ = -1;
  }
}

void SetpointProbe::OnStatus(const lcm::ReceiveBuffer* rbuf, const std::string&) {
  status_t s;
  if (ReceiveInto(s, rbuf->data, rbuf->data_size) != Drop::kNone) return;
  ticks_run_.store(std::max(ticks_run_.load(), s.ticks));
}

std::vector<std::pair<std::int64_t, std::int64_t>> SetpointProbe::results() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::pair<std::int64_t, std::int64_t>> r;
  for (std::size_t k = 0; k < sent_.size(); ++k) r.emplace_back(sent_[k], latency_[k]);
  return r;
}

// ---- the run --------------------------------------------------------------------------

// CPU of the daemon, its threads and the machine at one moment.
struct Snapshot {
  double t = 0.0;  // s, steady clock
  double daemon = 0.0;
  std::map<pid_t, double> threads;
  MachineCpu machine;
};

Snapshot Take(pid_t pid) {
  return {std::chrono::duration<double>(Clock::now().time_since_epoch()).count(), ProcessCpuSeconds(pid),
          ThreadCpuSeconds(pid), ReadMachineCpu()};
}

struct Measured {
  Snapshot a, b;
  Exit exit, cyclictest, logger;
  bool logger_ready = false;
  std::map<std::string, std::vector<std::int64_t>> logged;  // channel => ticks lcm-logger recorded
  double wall = 0.0;                                        // s, spawn to exit
  std::string load_before, load_after;
  std::vector<std::pair<std::string, double>> top;
  std::map<pid_t, std::map<std::string, int>> thread_states;  // tid => (state => times seen)
  std::map<pid_t, std::string> thread_names;
};

void SampleThreadStates(pid_t pid, Measured& m) {
  for (const auto& [tid, cpu] : ThreadCpuSeconds(pid)) {
    ++m.thread_states[tid][ThreadState(pid, tid)];
    if (m.thread_names[tid].empty()) m.thread_names[tid] = ThreadName(pid, tid);
  }
}

// The system call a thread was seen blocked in most often ("running" if never blocked).
std::string UsualState(const Measured& m, pid_t tid) {
  const auto it = m.thread_states.find(tid);
  if (it == m.thread_states.end()) return "?";
  std::string best = "running";
  int most = 0;
  for (const auto& [state, times] : it->second) {
    if (state != "running" && times > most) {
      best = state;
      most = times;
    }
  }
  return best;
}

// Up to 20 s for the daemon's first state; false when it exits first.
bool AwaitFirstState(const SetpointProbe& probe, pid_t pid) {
  bool exited = false;
  const auto seen_or_exited = [&] {
    if (probe.states() > 0) return true;
    exited = waitpid(pid, nullptr, WNOHANG) != 0;
    return exited;
  };
  return Await(seen_or_exited, 20.0, std::chrono::milliseconds(5)) && !exited;
}

// From the daemon's first state to 1 s before its end: CPU snapshots, noise.
void Observe(const Options& o, pid_t pid, Measured& m) {
  const auto ready = Clock::now();
  ProcessCpuTracker tracker;
  std::this_thread::sleep_until(ready + std::chrono::seconds(2));
  m.a = Take(pid);
  const auto end = ready + std::chrono::duration<double>(o.duration - 1.0);
  while (Clock::now() + std::chrono::seconds(1) < end) {
    std::this_thread::sleep_for(std::chrono::seconds(1));
    tracker.Sample();
    SampleThreadStates(pid, m);
  }
  std::this_thread::sleep_until(end);
  m.b = Take(pid);
  tracker.Sample();
  m.top = tracker.Top(8);
}

// lagranged for --duration with its timing CSV, the real-time options given and its tick pinned to --cpu.
std::vector<std::string> LoopDaemonArgs(const Options& o, const std::string& url) {
  std::vector<std::string> argv = LagrangedArgs(o.lagranged, o.config, url, o.rt_priority);
  argv.insert(argv.end(), {"--duration", std::to_string(o.duration), "--timing-csv", o.Tagged("loop_ticks").string()});
  if (o.cpu >= 0) argv.insert(argv.end(), {"--cpu", std::to_string(o.cpu)});
  return argv;
}

// From the daemon's first state: cyclictest beside it and the prober sending until 1 s before its end,
// then the daemon's and cyclictest's exits; the daemon's wall time from `spawned`.
void MeasureRun(const Options& o, pid_t pid, Clock::time_point spawned, SetpointProbe& probe, Measured& m) {
  // cyclictest ends before the daemon does (whole seconds, -D).
  const pid_t cyclictest =
      StartCyclictest(o, "concurrent", std::max(1, static_cast<int>(std::floor(o.duration - 2.0))), true);
  std::atomic<bool> stop_send{false};
  std::thread send([&] { probe.Send(stop_send); });
  Observe(o, pid, m);
  stop_send = true;  // 1 s before the daemon's end: every setpoint sent can still show in a state
  send.join();
  m.exit = WaitExit(pid, 30.0);
  m.wall = std::chrono::duration<double>(Clock::now() - spawned).count();
  m.load_after = LoadAverage();
  m.cyclictest = WaitExit(cyclictest, 10.0);
}

int RunDaemon(const Options& o, const std::string& url, SetpointProbe& probe, Measured& m) {
  LcmLogger logger(url, kLoggedChannels, o.Tagged("loop_states", ".lcmlog"), o.Tagged("lcm_logger", ".log"));
  m.logger_ready = logger.AwaitReady();
  if (!m.logger_ready) std::cerr << "loop_bench: lcm-logger did not start; no delivery figure\n";
  const std::vector<std::string> argv = LoopDaemonArgs(o, url);
  m.load_before = LoadAverage();
  const auto spawned = Clock::now();
  const pid_t pid = Spawn(argv, o.Tagged("lagranged", ".log"));
  std::atomic<bool> stop{false};
  std::thread receive([&] { probe.Receive(stop); });
  if (!AwaitFirstState(probe, pid)) {
    stop = true;
    receive.join();
    std::cerr << "loop_bench: lagranged published no state (see " << o.Tagged("lagranged", ".log") << ")\n";
    WaitExit(pid, 1.0);
    return 1;
  }
  MeasureRun(o, pid, spawned, probe, m);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the final status reaches the logger and the probe
  stop = true;
  receive.join();
  m.logger = logger.Stop();
  m.logged = ReadStateTicks(o.Tagged("loop_states", ".lcmlog"), kLoggedStates, probe.run_id());
  fs::remove(o.Tagged("loop_states", ".lcmlog"));
  if (m.cyclictest.status != 0)
    std::cerr << "loop_bench: cyclictest ended with " << DescribeExit(m.cyclictest.status) << "\n";
  return m.exit.status == 0 ? 0 : 1;
}

// ---- SIGTERM to exit ----------------------------------------------------------------------

struct Shutdown {
  double exit_ms = -1.0;  // SIGTERM sent → the process gone (its pidfd readable); < 0: not measured
  int status = -1;
};

// Starts the daemon, waits for its first state and 0.3 s more, sends SIGTERM
// and times it until it has exited.
Shutdown TimeSigterm(const Options& o, const std::string& url, int run) {
  std::unique_ptr<Bus> bus = OpenBus(url);
  std::atomic<bool> seen{false};
  bus->Subscribe("ARM_STATE", [&](std::string_view, const std::uint8_t*, std::size_t) { seen = true; });
  const pid_t pid =
      Spawn(LagrangedArgs(o.lagranged, o.config, url), o.Tagged("lagranged_sigterm_" + std::to_string(run), ".log"));
  const auto deadline = Clock::now() + std::chrono::seconds(20);
  while (!seen && Clock::now() < deadline && waitpid(pid, nullptr, WNOHANG) == 0) bus->Handle(20);
  Shutdown s;
  if (!seen) {
    s.status = WaitExit(pid, 0.1).status;
    return s;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid, 0));
  const std::int64_t sent = MonotonicNs();
  kill(pid, SIGTERM);
  pollfd p{pidfd, POLLIN, 0};
  if (pidfd >= 0 && poll(&p, 1, 10'000) == 1) s.exit_ms = 1e-6 * static_cast<double>(MonotonicNs() - sent);
  if (pidfd >= 0) close(pidfd);
  s.status = WaitExit(pid, 1.0).status;
  return s;
}

// ---- output -----------------------------------------------------------------------------

void WriteSetpoints(const fs::path& path, const SetpointProbe& probe) {
  std::ofstream csv(path);
  csv << "k,sent_ns,latency_ns\n";
  std::int64_t k = 0;
  for (const auto& [sent, latency] : probe.results()) csv << k++ << ',' << sent << ',' << latency << '\n';
}

void WriteThreads(const fs::path& path, const Measured& m) {
  std::ofstream csv(path);
  csv << "thread,tid,name,usually_in,cpu_s,percent_of_one_core\n";
  const double window = m.b.t - m.a.t;
  int index = 0;
  for (const auto& [tid, after] : m.b.threads) {
    const auto it = m.a.threads.find(tid);
    const double used = after - (it == m.a.threads.end() ? 0.0 : it->second);
    const auto name = m.thread_names.find(tid);
    csv << index++ << ',' << tid << ",\"" << (name == m.thread_names.end() ? "" : name->second) << "\","
        << UsualState(m, tid) << ',' << used << ',' << 100.0 * used / window << '\n';
  }
}

void WriteNoise(const fs::path& path, const Measured& m) {
  std::ofstream csv(path);
  csv << "process,cpu_s,percent_of_one_core\n";
  const double window = m.b.t - m.a.t + 2.0;  // the tracker started at the first state
  for (const auto& [name, s] : m.top) csv << '"' << name << "\"," << s << ',' << 100.0 * s / window << '\n';
}

void WriteSummary(const fs::path& path, const Options& o, const Measured& m, const SetpointProbe& probe) {
  std::ofstream csv(path);
  csv.precision(10);
  const double window = m.b.t - m.a.t;
  const double machine = (m.b.machine.busy - m.a.machine.busy) / (m.b.machine.total - m.a.machine.total);
  csv << "key,value\n"
      << "duration_s," << o.duration << '\n'
      << "cores," << std::thread::hardware_concurrency() << '\n'
      << "window_s," << window << '\n'
      << "daemon_cpu_window_s," << m.b.daemon - m.a.daemon << '\n'
      << "daemon_cpu_window_percent," << 100.0 * (m.b.daemon - m.a.daemon) / window << '\n'
      << "daemon_cpu_total_s," << m.exit.cpu << '\n'
      << "daemon_wall_s," << m.wall << '\n'
      << "daemon_cpu_total_percent," << 100.0 * m.exit.cpu / m.wall << '\n'
      << "daemon_exit_status," << m.exit.status << '\n'
      << "machine_busy_percent_of_all_cores," << 100.0 * machine << '\n'
      << "load_average_before,\"" << m.load_before << "\"\n"
      << "load_average_after,\"" << m.load_after << "\"\n"
      << "arm_states_received," << probe.states() << '\n'
      << "arm_state_tick_gaps," << probe.gaps() << '\n'
      << "ticks_run," << probe.ticks_run() << '\n'
      << "logger_ready," << (m.logger_ready ? 1 : 0) << '\n'
      << "logger_exit,\"" << DescribeExit(m.logger.status) << "\"\n";
  for (const auto& [channel, ticks] : m.logged) {
    csv << "logger_states_" << channel << ',' << ticks.size() << '\n'
        << "logger_missing_" << channel << ',' << TicksMissing(ticks, 0, probe.ticks_run()) << '\n';
  }
  csv << "cyclictest_exit,\"" << DescribeExit(m.cyclictest.status) << "\"\n"
      << "alone_s," << o.alone << '\n'
      << "rt_priority," << o.rt_priority << '\n'
      << "cpu," << o.cpu << '\n';
}

// --sigterm-runs starts, each timed from SIGTERM to its exit, into sigterm.csv; false when one failed.
bool WriteSigterm(const Options& o, const std::string& url) {
  std::ofstream csv(o.Tagged("sigterm"));
  csv << "run,exit_ms,exit_status\n";
  bool clean = true;
  for (int run = 0; run < o.sigterm_runs; ++run) {
    const Shutdown s = TimeSigterm(o, url, run);
    csv << run << ',' << s.exit_ms << ',' << s.status << '\n';
    if (s.exit_ms < 0.0 || s.status != 0) clean = false;
    if (s.status == 0) fs::remove(o.Tagged("lagranged_sigterm_" + std::to_string(run), ".log"));
  }
  return clean;
}

void AddOptions(CLI::App& app, Options& o) {
  AddDaemonOptions(app, o, ConfigOption::kSceneFile, "Scene (default: the daemon's default scene)");
  app.add_option("--duration", o.duration, "Seconds of daemon ticks")
      ->check(CLI::Range(5.0, 3600.0))
      ->capture_default_str();
  app.add_option("--alone", o.alone,
                 "Seconds of cyclictest alone before the daemon, twice: default timer slack, then 1 ns (0: none)")
      ->capture_default_str();
  app.add_option("--rt-priority", o.rt_priority,
                 "SCHED_FIFO priority for the daemon's tick (with --mlockall); cyclictest gets one more")
      ->check(CLI::Range(1, 98));
  app.add_option("--cpu", o.cpu, "Pin the daemon's tick thread and cyclictest to this CPU")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--sigterm-runs", o.sigterm_runs, "Afterwards, time SIGTERM to exit over this many daemon starts")
      ->check(CLI::Range(0, 1000));
  app.add_option("--tag", o.tag, "Appended to every output file name");
}

int Main(int argc, char** argv) {
  Options o;
  CLI::App app{"loop_bench: lagranged on a scene beside cyclictest, with setpoint round trips and lcm-logger"};
  AddOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  if (const int status = PrepareRun("loop_bench", o, {o.port})) return status;
  const std::string url = Url(o.port);
  if (o.alone > 0.0) {
    RunCyclictestAlone(o, "alone");
    RunCyclictestAlone(o, "alone-slack-1ns", 1);
  }
  Measured m;
  SetpointProbe probe(url);
  int status = RunDaemon(o, url, probe, m);
  WriteSetpoints(o.Tagged("setpoint_latency"), probe);
  WriteThreads(o.Tagged("loop_threads"), m);
  WriteNoise(o.Tagged("loop_noise"), m);
  WriteSummary(o.Tagged("loop_summary"), o, m, probe);
  if (o.sigterm_runs > 0 && !WriteSigterm(o, url)) status = 1;
  return status;
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
