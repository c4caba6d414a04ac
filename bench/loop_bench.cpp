// The loop (issue 6, item 5): the real lagranged on a scene (the default:
// config/default.yaml) at its period for a fixed time on a private LCM URL,
// with, in this process and at the same time,
//   - a bare absolute-deadline timer loop: the daemon's own LoopTimer and
//     MonotonicClock at 1 kHz doing no work, so its wake-up latency is what
//     the machine gives any sleeper under the same load; it also runs alone
//     for a while before the daemon starts, and once more alone with the
//     thread's timer slack at 1 ns instead of Linux's default 50 µs for
//     SCHED_OTHER threads (SCHED_FIFO threads have none), to show what the
//     slack contributes;
//   - a setpoint prober: a new arm setpoint every 100 ms (+ up to 1 ms of
//     seeded jitter, so it does not lock to the tick's phase), timed from just
//     before lcm.publish to the first ARM_STATE whose q_des carries it.
// The daemon writes every tick's wake-up latency and compute time with
// --timing-csv (from its publish thread). Its CPU time comes from /proc over
// the steady window (from 2 s after its first state to 1 s before the end)
// and from wait4's rusage over the whole run.
//
// With --rt-priority N the daemon runs with the service's real-time options
// (--mlockall --rt-priority N: SCHED_FIFO tick thread) and the bare loop
// thread runs SCHED_FIFO at N + 1: on a shared CPU (--cpu) two 1 kHz loops of
// equal priority would queue behind each other whenever their deadlines came
// close, so the bare loop, whose own work is a clock read, goes first.
//
// Files in --out: loop_ticks.csv (the daemon's), bare_loop.csv,
// setpoint_latency.csv, loop_summary.csv, loop_threads.csv, loop_noise.csv,
// lagranged.log; with --tag T each name ends in _T (loop_ticks_T.csv, ...).
// The report script computes the percentiles.

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

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

#include "bench/proc_stats.hpp"
#include "daemon/clock.hpp"
#include "daemon/loop_timer.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string lagranged;
  std::string config;
  std::string out = "bench/results";
  int port = 7901;
  double duration = 60.0;    // s of daemon ticks
  double bare_alone = 10.0;  // s of the bare loop before the daemon starts (0: none)
  int rt_priority = 0;       // > 0: SCHED_FIFO for the daemon's tick and the bare loop
  int cpu = -1;              // >= 0: the daemon's tick and the bare loop pinned to this CPU
  std::string tag;           // appended to every file name

  // out/<stem>[_tag].<ext>
  fs::path File(const std::string& stem, const std::string& ext = ".csv") const {
    return fs::path(out) / (stem + (tag.empty() ? "" : "_" + tag) + ext);
  }
};

std::string Url(int port) { return "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0"; }

std::int64_t MonotonicNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

std::int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// "" when a message published on `url` comes back to this process.
std::string CheckLoopback(const std::string& url) {
  lcm::LCM lcm(url);
  if (!lcm.good()) return "cannot open LCM at " + url;
  int received = 0;
  struct Counter {
    int* n;
    void On(const lcm::ReceiveBuffer*, const std::string&) { ++*n; }
  } counter{&received};
  lcm.subscribe("LAGRANGE_BENCH_LOOPBACK", &Counter::On, &counter);
  for (int i = 0; i < 20 && received == 0; ++i) {
    const char byte = 1;
    lcm.publish("LAGRANGE_BENCH_LOOPBACK", &byte, 1);
    lcm.handleTimeout(50);
  }
  if (received > 0) return "";
  return "LCM multicast does not loop back; as root: ip link set lo multicast on; ip route add 239.255.0.0/16 dev lo";
}

// ---- the bare timer loop ------------------------------------------------------

struct BareWake {
  std::int64_t wall_us;  // wall clock at the wake, µs since the Unix epoch
  Nanoseconds latency;
};

// How a bare loop's thread is set up.
struct ThreadSetup {
  unsigned long timer_slack_ns = 0;  // > 0: PR_SET_TIMERSLACK
  int fifo_priority = 0;             // > 0: SCHED_FIFO at this priority
  int cpu = -1;                      // >= 0: pinned to this CPU
};

void ApplyToThisThread(const ThreadSetup& setup) {
  if (setup.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(setup.cpu, &set);
    if (pthread_setaffinity_np(pthread_self(), sizeof set, &set) != 0) std::cerr << "loop_bench: cannot pin\n";
  }
  if (setup.timer_slack_ns > 0) prctl(PR_SET_TIMERSLACK, setup.timer_slack_ns, 0, 0, 0);
  if (setup.fifo_priority > 0) {
    sched_param param{};
    param.sched_priority = setup.fifo_priority;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) != 0) {
      std::cerr << "loop_bench: SCHED_FIFO not permitted for the bare loop\n";
    }
  }
}

// Wake-ups of a 1 kHz absolute-deadline loop doing nothing, on this thread set
// up by `setup`, until `ticks` wakes or `stop`.
std::vector<BareWake> BareLoop(std::int64_t ticks, const std::atomic<bool>& stop, const ThreadSetup& setup = {}) {
  ApplyToThisThread(setup);
  MonotonicClock clock;
  LoopTimer timer(clock, LoopTimerOptions{});
  std::vector<BareWake> wakes;
  wakes.reserve(static_cast<std::size_t>(ticks));
  timer.Start();
  while (static_cast<std::int64_t>(wakes.size()) < ticks && !stop.load(std::memory_order_relaxed)) {
    const Nanoseconds latency = timer.WaitForNextTick().latency;
    wakes.push_back({clock.WallMicros(), latency});
  }
  return wakes;
}

// ---- the setpoint prober --------------------------------------------------------

// Sends arm setpoints on one LCM and matches them in ARM_STATE on another.
class SetpointProbe {
 public:
  SetpointProbe(const std::string& url) : in_(url), out_(url) {
    in_.subscribe("ARM_STATE", &SetpointProbe::OnState, this);
  }

  // Handles ARM_STATE until `stop`.
  void Receive(const std::atomic<bool>& stop) {
    while (!stop.load()) in_.handleTimeout(20);
  }
  // Publishes a setpoint every 100 ms (+ jitter) until `stop`.
  void Send(const std::atomic<bool>& stop);

  std::int64_t states() const { return states_.load(); }
  std::int64_t gaps() const { return gaps_; }
  // (sent, latency ns) of every setpoint; latency < 0: never seen in a state.
  std::vector<std::pair<std::int64_t, std::int64_t>> results() const;

 private:
  static double Value(std::int64_t k) { return std::numbers::pi / 4 + 1e-4 * static_cast<double>(k); }  // rad
  void OnState(const lcm::ReceiveBuffer* rbuf, const std::string& channel);

  lcm::LCM in_, out_;
  std::atomic<std::int64_t> states_{0};
  std::int64_t gaps_ = 0, last_tick_ = -1;
  mutable std::mutex mutex_;
  std::int64_t pending_ = -1;                  // the setpoint not yet seen in a state
  std::vector<std::int64_t> sent_, latency_;   // ns, per setpoint
};

void SetpointProbe::Send(const std::atomic<bool>& stop) {
  std::mt19937 rng{42};
  std::uniform_int_distribution<int> jitter_us(0, 999);
  auto next = Clock::now();
  for (std::int64_t k = 0; !stop.load(); ++k) {
    next += std::chrono::milliseconds(100) + std::chrono::microseconds(jitter_us(rng));
    std::this_thread::sleep_until(next);
    setpoint_t sp;
    sp.num_dofs = 2;
    sp.q = {Value(k), 0.0};
    sp.qd = {0.0, 0.0};
    sp.qdd = {0.0, 0.0};
    {
      std::lock_guard<std::mutex> lock(mutex_);
      pending_ = k;
      sent_.push_back(MonotonicNs());
      latency_.push_back(-1);
    }
    sp.utime = WallMicros();
    out_.publish("ARM_SETPOINT", &sp);
  }
}

void SetpointProbe::OnState(const lcm::ReceiveBuffer* rbuf, const std::string&) {
  const std::int64_t now = MonotonicNs();
  state_t s;
  if (s.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
  states_.fetch_add(1);
  if (last_tick_ >= 0 && s.tick != last_tick_ + 1) ++gaps_;
  last_tick_ = s.tick;
  std::lock_guard<std::mutex> lock(mutex_);
  if (pending_ >= 0 && !s.q_des.empty() && s.q_des[0] == Value(pending_)) {
    latency_[static_cast<std::size_t>(pending_)] = now - sent_[static_cast<std::size_t>(pending_)];
    pending_ = -1;
  }
}

std::vector<std::pair<std::int64_t, std::int64_t>> SetpointProbe::results() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::pair<std::int64_t, std::int64_t>> r;
  for (std::size_t k = 0; k < sent_.size(); ++k) r.emplace_back(sent_[k], latency_[k]);
  return r;
}

// ---- the daemon process ---------------------------------------------------------

// Starts argv[0] with its output in `log`; returns its pid.
pid_t Spawn(const std::vector<std::string>& argv, const fs::path& log) {
  const pid_t pid = fork();
  if (pid != 0) return pid;
  const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  dup2(fd, STDOUT_FILENO);
  dup2(fd, STDERR_FILENO);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  execv(args[0], args.data());
  _exit(127);
}

struct Exit {
  int status = -1;   // exit code, 128 + signal, or -1 if it had to be killed
  double cpu = 0.0;  // s, user + system over the whole run
};

// Waits up to `timeout_s` for `pid`, then kills it.
Exit WaitExit(pid_t pid, double timeout_s) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  rusage usage{};
  pid_t done = 0;
  while ((done = wait4(pid, &status, WNOHANG, &usage)) == 0 && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  Exit e;
  if (done == 0) {
    kill(pid, SIGKILL);
    wait4(pid, &status, 0, &usage);
  } else {
    e.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  e.cpu = seconds(usage.ru_utime) + seconds(usage.ru_stime);
  return e;
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

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

struct Measured {
  std::vector<BareWake> bare_alone, bare_slack, bare_concurrent;
  Snapshot a, b;
  Exit exit;
  double wall = 0.0;  // s, spawn to exit
  std::string load_before, load_after;
  std::vector<std::pair<std::string, double>> top;
  std::map<pid_t, std::map<std::string, int>> thread_states;  // tid => (state => times seen)
};

void SampleThreadStates(pid_t pid, Measured& m) {
  for (const auto& [tid, cpu] : ThreadCpuSeconds(pid)) ++m.thread_states[tid][ThreadState(pid, tid)];
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

bool AwaitFirstState(const SetpointProbe& probe, pid_t pid) {
  const auto deadline = Clock::now() + std::chrono::seconds(20);
  while (probe.states() == 0 && Clock::now() < deadline) {
    if (waitpid(pid, nullptr, WNOHANG) != 0) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return probe.states() > 0;
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

int RunDaemon(const Options& o, const std::string& url, SetpointProbe& probe, Measured& m) {
  std::vector<std::string> argv = {o.lagranged, "--lcm-url", url, "--duration", std::to_string(o.duration),
                                   "--timing-csv", o.File("loop_ticks").string(), "--log-level", "warn"};
  if (!o.config.empty()) argv.insert(argv.end(), {"--config", o.config});
  if (o.rt_priority > 0) argv.insert(argv.end(), {"--mlockall", "--rt-priority", std::to_string(o.rt_priority)});
  if (o.cpu >= 0) argv.insert(argv.end(), {"--cpu", std::to_string(o.cpu)});
  m.load_before = LoadAverage();
  const auto spawned = Clock::now();
  const pid_t pid = Spawn(argv, o.File("lagranged", ".log"));
  std::atomic<bool> stop{false};
  std::thread receive([&] { probe.Receive(stop); });
  if (!AwaitFirstState(probe, pid)) {
    stop = true;
    receive.join();
    std::cerr << "loop_bench: lagranged published no state (see " << o.File("lagranged", ".log") << ")\n";
    WaitExit(pid, 1.0);
    return 1;
  }
  std::atomic<bool> stop_bare{false}, stop_send{false};
  const ThreadSetup bare_setup{.fifo_priority = o.rt_priority > 0 ? o.rt_priority + 1 : 0, .cpu = o.cpu};
  const std::int64_t bare_ticks = std::llround((o.duration - 1.5) * 1000.0);
  std::thread bare([&] { m.bare_concurrent = BareLoop(bare_ticks, stop_bare, bare_setup); });
  std::thread send([&] { probe.Send(stop_send); });
  Observe(o, pid, m);
  stop_send = true;  // 1 s before the daemon's end: every setpoint sent can still show in a state
  send.join();
  m.exit = WaitExit(pid, 30.0);
  m.wall = std::chrono::duration<double>(Clock::now() - spawned).count();
  m.load_after = LoadAverage();
  stop = true;
  stop_bare = true;
  bare.join();
  receive.join();
  return m.exit.status == 0 ? 0 : 1;
}

// ---- output -----------------------------------------------------------------------------

void WriteBare(const fs::path& path, const Measured& m) {
  std::ofstream csv(path);
  csv << "phase,wall_us,latency_ns\n";
  for (const auto& [phase, wakes] : {std::pair{"alone", &m.bare_alone}, std::pair{"concurrent", &m.bare_concurrent},
                                     std::pair{"alone-slack-1ns", &m.bare_slack}}) {
    for (const BareWake& w : *wakes) csv << phase << ',' << w.wall_us << ',' << w.latency << '\n';
  }
}

void WriteSetpoints(const fs::path& path, const SetpointProbe& probe) {
  std::ofstream csv(path);
  csv << "k,sent_ns,latency_ns\n";
  std::int64_t k = 0;
  for (const auto& [sent, latency] : probe.results()) csv << k++ << ',' << sent << ',' << latency << '\n';
}

void WriteThreads(const fs::path& path, const Measured& m) {
  std::ofstream csv(path);
  csv << "thread,tid,usually_in,cpu_s,percent_of_one_core\n";
  const double window = m.b.t - m.a.t;
  int index = 0;
  for (const auto& [tid, after] : m.b.threads) {
    const auto it = m.a.threads.find(tid);
    const double used = after - (it == m.a.threads.end() ? 0.0 : it->second);
    csv << index++ << ',' << tid << ',' << UsualState(m, tid) << ',' << used << ',' << 100.0 * used / window << '\n';
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
      << "bare_alone_s," << o.bare_alone << '\n'
      << "rt_priority," << o.rt_priority << '\n'
      << "cpu," << o.cpu << '\n';
}

int Main(int argc, char** argv) {
  Options o;
  CLI::App app{"loop_bench: lagranged on a scene beside a bare timer loop, with setpoint round trips"};
  app.add_option("--lagranged", o.lagranged, "The daemon to run")->required()->check(CLI::ExistingFile);
  app.add_option("--config", o.config, "Scene (default: the daemon's default scene)");
  app.add_option("--out", o.out, "Folder for the results")->capture_default_str();
  app.add_option("--port", o.port, "Private LCM port on udpm://239.255.76.67")->capture_default_str();
  app.add_option("--duration", o.duration, "Seconds of daemon ticks")->check(CLI::Range(5.0, 3600.0))->capture_default_str();
  app.add_option("--bare-alone", o.bare_alone, "Seconds of the bare loop alone, before the daemon")->capture_default_str();
  app.add_option("--rt-priority", o.rt_priority,
                 "SCHED_FIFO priority for the daemon's tick (with --mlockall); the bare loop gets one more")
      ->check(CLI::Range(1, 98));
  app.add_option("--cpu", o.cpu, "Pin the daemon's tick thread and the bare loop to this CPU")->check(CLI::NonNegativeNumber);
  app.add_option("--tag", o.tag, "Appended to every output file name");
  CLI11_PARSE(app, argc, argv);
  fs::create_directories(o.out);
  const std::string url = Url(o.port);
  if (const std::string problem = CheckLoopback(url); !problem.empty()) {
    std::cerr << "loop_bench: " << problem << "\n";
    return 1;
  }
  Measured m;
  const std::atomic<bool> never{false};
  if (o.bare_alone > 0.0) {
    m.bare_alone = BareLoop(std::llround(o.bare_alone * 1000.0), never);
    std::thread slack([&] { m.bare_slack = BareLoop(std::llround(o.bare_alone * 1000.0), never, {.timer_slack_ns = 1}); });
    slack.join();
  }
  SetpointProbe probe(url);
  const int status = RunDaemon(o, url, probe, m);
  WriteBare(o.File("bare_loop"), m);
  WriteSetpoints(o.File("setpoint_latency"), probe);
  WriteThreads(o.File("loop_threads"), m);
  WriteNoise(o.File("loop_noise"), m);
  WriteSummary(o.File("loop_summary"), o, m, probe);
  return status;
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
