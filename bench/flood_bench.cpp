// The two-process loop under a flood (issue 21, "a flood of refused or
// garbage packets must not starve the real inputs"): lagranged #1 on
// config/arm_external_plant.yaml (the simulated arm, torques from ARM_TORQUE)
// and lagranged #2 on config/arm_external_controller.yaml with --channel-prefix
// CTRL_ (computed torque on the measured ARM_STATE, torques to ARM_TORQUE), on
// one private bus, while --senders threads of this program flood that bus for
// --seconds-per-case at --rate datagrams/s in all (default 140 000, the flood
// the issue measured; 0: as fast as they can) with, one case after another:
//   quiet      no flood: the baseline, measured in the same run
//   refused    state_t on ARM_STATE that the controller must refuse without
//              tripping: the plant's own run id copied off the bus, a tick that
//              does not grow (tick 1), a fresh utime. With a key each also
//              carries a trailer with a fresh stamp and a wrong tag, so every
//              one costs the receiver a MAC (the dearest refusal)
//   garbage    200-byte datagrams that are not LCM
// every case with a fresh pair of daemons, once on an unsigned bus and once
// with a key (--bus-key on both daemons and on this program's observer), and
// each twice: with lagranged's own receive buffer (2 MiB; --recv-buf-size to
// ask another) and, the baseline in the same run, with the daemons' URL
// asking --baseline-buffer (212 992 bytes: Debian's net.core.rmem_default,
// what lagranged had before; 0 skips it).
// The flood goes to the group and port both daemons listen on: the
// controller reads ARM_STATE there, the plant watches its own output channels.
//
// --cpu-hogs N adds CPU contention to every window: N processes of this
// program that only spin, at nice 0, beside the daemons and the flood (a
// build on the same machine); each case then reports the 1-minute load
// average at its window's end. --bench-nice N runs the flooding and
// observing threads at nice N: below 0 (privileged) the hogs slow the flood
// less (an attacker with CPU to spare) and what the observer counts is the
// daemons' doing, not its own starvation. (Not SCHED_FIFO: a flood thread
// that cannot keep its rate never sleeps, and real-time throttling,
// sched_rt_runtime_us, would then stall every real-time thread for 50 ms a
// second, the daemons' included.) --bus and --cases pick a part of the matrix.
//
// Per case: the flood's rate; the controller's status at both ends of the
// window (measured states accepted and refused, kernel drops at its socket,
// datagrams refused for their signature) and every status in between (how
// many showed the controller's instance not running); the plant's status
// (torques accepted, kernel drops) and its states in the window (how many
// showed the arm not running). The loop kept running when neither left
// running. Files in --out: flood_cases.csv and the daemons' logs.

#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <CLI/CLI.hpp>
#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include "bench/harness.hpp"
#include "bench/options.hpp"
#include "protocol/big_endian.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "protocol/observer.hpp"
#include "protocol/signing.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;

constexpr const char* kPlantScene = "arm_external_plant.yaml";
constexpr const char* kControllerScene = "arm_external_controller.yaml";
constexpr const char* kControllerPrefix = "CTRL_";
constexpr const char* kFloodMark = "flood";  // state_t.controller of the flood's states

enum class Case { kQuiet, kRefused, kGarbage };
const char* Name(Case c) {
  switch (c) {
    case Case::kQuiet: return "quiet";
    case Case::kRefused: return "refused";
    case Case::kGarbage: return "garbage";
  }
  return "?";
}

struct Options : DaemonOptions {
  Options() {
    config = SourceConfigDir();
    port = 7760;
  }
  double seconds = 8.0;  // per case
  bool quick = false;
  int rt_priority = 0;
  int senders = 1;          // flooding threads
  double rate = 140000.0;   // datagrams/s over all senders; 0: as fast as they can
  int recv_buf_size = 0;    // > 0: the daemons' URL asks for this SO_RCVBUF (bytes)
  // > 0: every case again with the daemons' URL asking this buffer (the
  // baseline in the same run: Debian's net.core.rmem_default, what lagranged
  // had before it asked 2 MiB)
  int baseline_buffer = 212992;
  int cpu_hogs = 0;              // spinning processes beside the daemons during each window
  int bench_nice = 0;            // the flooding and observing threads' nice value (< 0: privileged)
  std::string bus = "both";      // unsigned | signed | both
  std::vector<std::string> cases = {"quiet", "refused", "garbage"};
};

// ---- CPU contention ---------------------------------------------------------------------------

// `n` child processes that spin at nice 0 until destroyed (SIGKILL, by pid); each also dies with this program.
class CpuHogs {
 public:
  explicit CpuHogs(int n) {
    for (int k = 0; k < n; ++k) {
      const pid_t pid = fork();
      if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        volatile std::uint64_t spins = 0;
        for (;;) spins = spins + 1;
      }
      if (pid > 0) pids_.push_back(pid);
    }
  }
  ~CpuHogs() {
    for (const pid_t pid : pids_) kill(pid, SIGKILL);
    for (const pid_t pid : pids_) waitpid(pid, nullptr, 0);
  }
  CpuHogs(const CpuHogs&) = delete;
  CpuHogs& operator=(const CpuHogs&) = delete;

 private:
  std::vector<pid_t> pids_;
};

// Sets the calling thread's nice value (Linux: per thread); false when not permitted.
bool ReniceThisThread(int nice) {
  return setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), nice) == 0;
}

// The 1-minute load average (/proc/loadavg), or -1.
double LoadAverage() {
  std::ifstream in("/proc/loadavg");
  double one = -1.0;
  in >> one;
  return one;
}

// ---- the flood --------------------------------------------------------------------------------

// A refused measured state: the plant's run id, tick 1 (never grows), stamped now.
Bytes RefusedState(std::int64_t plant_run_id, bool signed_bus, std::uint64_t sender) {
  state_t s;
  s.utime = WallMicros();
  s.run_id = plant_run_id;
  s.tick = 1;
  s.num_dofs = 2;
  for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(2, 0.0);
  s.controller = kFloodMark;
  Bytes payload(static_cast<std::size_t>(s.getEncodedSize()));
  s.encode(payload.data(), 0, static_cast<int>(payload.size()));
  Bytes b = Lc02(1, "ARM_STATE", payload);
  if (signed_bus) {  // sender id, stamp (patched per datagram), a tag that will not verify, the mark
    const std::size_t at = b.size();
    b.resize(at + kSignatureTrailerBytes, 0xa5);
    WriteBigEndian64(sender, b.data() + at);
    std::memcpy(b.data() + at + 32, "LGS2", 4);
  }
  return b;
}

Bytes Garbage(std::mt19937& rng) {
  Bytes b(200);
  for (auto& x : b) x = static_cast<std::uint8_t>(rng());
  b[0] = 'X';  // never an LCM magic
  return b;
}

struct FloodResult {
  std::int64_t sent = 0;
  double seconds = 0.0;
  bool reniced = false;  // the thread took --bench-nice
};

// Sends `c`'s datagrams to the group on `port` as fast as one thread can until `stop`.
// `rate` > 0: at most that many datagrams/s, in bursts of 64 on an absolute schedule.
FloodResult Flood(Case c, int port, bool signed_bus, std::int64_t plant_run_id, int index, double rate, int nice,
                  const std::atomic<bool>& stop) {
  FloodResult r;
  if (c == Case::kQuiet) return r;
  r.reniced = nice == 0 || ReniceThisThread(nice);
  RawSender out(port);
  if (!out.ok()) return r;
  std::mt19937 rng(static_cast<std::uint32_t>(42 + index));
  const std::uint64_t sender = 0xf100d000ULL + static_cast<std::uint64_t>(index);
  Bytes datagram;
  const auto start = Clock::now();
  for (std::uint64_t k = 0; !stop.load(std::memory_order_relaxed); ++k) {
    if (k % 512 == 0) datagram = c == Case::kRefused ? RefusedState(plant_run_id, signed_bus, sender) : Garbage(rng);
    if (c == Case::kRefused && signed_bus) {  // a stamp in the window: the receiver must compute the tag
      WriteBigEndian64(static_cast<std::uint64_t>(WallMicros()),
                       datagram.data() + datagram.size() - kSignatureTrailerBytes + 8);
    }
    if (out.Send(datagram)) ++r.sent;
    if (rate > 0 && k % 64 == 63) {
      std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(static_cast<double>(k + 1) / rate)));
    }
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

// ---- what the daemons publish -------------------------------------------------------------------

// The plant's states and status and the controller's status (a BusObserver
// per daemon, their hooks doing the per-message work); the window counts.
class Observer {
 public:
  Observer(const std::string& url, const BusKey* key)
      : bus_(OpenBus(WithReceiveBuffer(url), key)),
        plant_(*bus_, "", ObserverLimits{.instances = 1, .discover = false, .telemetry = false},
               BusObserver::Hooks{.on_state = [this](const std::string&, const state_t& s) { OnState(s); },
                                  .on_status = [this](const status_t& s) { OnStatus(s, false); }}),
        controller_(*bus_, kControllerPrefix, ObserverLimits{.instances = 0, .discover = false},
                    BusObserver::Hooks{.on_status = [this](const status_t& s) { OnStatus(s, true); }}) {
    plant_.Follow("arm");
  }
  void Run(const std::atomic<bool>& stop) {
    while (!stop.load()) bus_->Handle(20);
  }
  void Reset() {
    std::lock_guard<std::mutex> lock(mutex_);
    plant_run_id_ = 0;
    plant_mode_ = -1;
    plant_status_.reset();
    controller_status_.reset();
  }
  void OpenWindow() {
    std::lock_guard<std::mutex> lock(mutex_);
    window_ = true;
    states_ = states_not_running_ = statuses_ = statuses_not_running_ = 0;
  }
  void CloseWindow() {
    std::lock_guard<std::mutex> lock(mutex_);
    window_ = false;
  }
  std::int64_t plant_run_id() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return plant_run_id_;
  }
  int plant_mode() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return plant_mode_;
  }
  std::optional<status_t> plant_status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return plant_status_;
  }
  std::optional<status_t> controller_status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return controller_status_;
  }
  // In the last window: plant states, those not running; controller statuses, those not running.
  std::array<std::int64_t, 4> window_counts() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return {states_, states_not_running_, statuses_, statuses_not_running_};
  }
  std::int64_t kernel_drops() const { return bus_->stats().kernel_drops; }

 private:
  void OnState(const state_t& state) {
    if (state.controller == kFloodMark) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (plant_run_id_ == 0) plant_run_id_ = state.run_id;
    if (state.run_id != plant_run_id_) return;
    plant_mode_ = state.mode;
    if (!window_) return;
    ++states_;
    if (state.mode != state_t::MODE_RUNNING) ++states_not_running_;
  }
  void OnStatus(const status_t& status, bool controller) {
    std::lock_guard<std::mutex> lock(mutex_);
    (controller ? controller_status_ : plant_status_) = status;
    if (!controller || !window_) return;
    ++statuses_;
    if (status.num_instances < 1 || status.instance_modes[0] != state_t::MODE_RUNNING) ++statuses_not_running_;
  }

  std::unique_ptr<Bus> bus_;
  BusObserver plant_, controller_;  // read on the receive thread only (their hooks)
  mutable std::mutex mutex_;
  std::int64_t plant_run_id_ = 0;
  int plant_mode_ = -1;
  std::optional<status_t> plant_status_, controller_status_;
  bool window_ = false;
  std::int64_t states_ = 0, states_not_running_ = 0, statuses_ = 0, statuses_not_running_ = 0;
};

// ---- one case ------------------------------------------------------------------------------------

struct CaseResult {
  std::string bus;
  Case c = Case::kQuiet;
  int recv_buf_size = 0;  // asked in the daemons' URL; 0: lagranged's default
  std::string problem;  // the loop never started
  FloodResult flood;
  std::optional<status_t> plant_a, plant_b, ctrl_a, ctrl_b;
  std::array<std::int64_t, 4> counts{};
  std::string controller_reason;
  std::int64_t observer_drops = 0;
  int cpu_hogs = 0;
  double load_average = -1.0;  // 1 min, at the window's end
};

std::vector<std::string> DaemonArgs(const Options& o, const std::string& url, const char* scene,
                                    const std::string& key_file) {
  std::vector<std::string> argv = LagrangedArgs(o.lagranged, o.Scene(scene), url, o.rt_priority);
  if (!key_file.empty()) argv.insert(argv.end(), {"--bus-key", key_file});
  return argv;
}

CaseResult RunCase(const Options& o, const std::string& bus_name, const std::string& key_file, Case c,
                   int recv_buf_size, Observer& observer) {
  CaseResult r;
  r.bus = bus_name;
  r.c = c;
  r.recv_buf_size = recv_buf_size;
  const std::string url = Url(o.port) + (recv_buf_size > 0 ? "&recv_buf_size=" + std::to_string(recv_buf_size) : "");
  const std::string stem = bus_name + "_" + Name(c) + (recv_buf_size > 0 ? "_" + std::to_string(recv_buf_size) : "");
  observer.Reset();
  const pid_t plant = Spawn(DaemonArgs(o, url, kPlantScene, key_file), o.File("lagranged_flood_plant_" + stem + ".log"));
  std::vector<std::string> argv = DaemonArgs(o, url, kControllerScene, key_file);
  argv.insert(argv.end(), {"--channel-prefix", kControllerPrefix});
  const pid_t controller = Spawn(argv, o.File("lagranged_flood_controller_" + stem + ".log"));
  const bool running = Await(
      [&] {
        const auto s = observer.controller_status();
        return observer.plant_mode() == state_t::MODE_RUNNING && s && s->num_instances == 1 &&
               s->instance_modes[0] == state_t::MODE_RUNNING;
      },
      20.0);
  if (!running) {
    r.problem = "the loop did not start (see lagranged_flood_*_" + stem + ".log)";
  } else {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    r.plant_a = observer.plant_status();
    r.ctrl_a = observer.controller_status();
    const std::int64_t drops_before = observer.kernel_drops();
    std::optional<CpuHogs> hogs;
    if (o.cpu_hogs > 0) hogs.emplace(o.cpu_hogs);
    r.cpu_hogs = o.cpu_hogs;
    observer.OpenWindow();
    std::atomic<bool> stop{false};
    std::vector<FloodResult> floods(static_cast<std::size_t>(o.senders));
    std::vector<std::thread> senders;
    for (int k = 0; k < o.senders; ++k) {
      senders.emplace_back([&, k] {
        floods[static_cast<std::size_t>(k)] =
            Flood(c, o.port, !key_file.empty(), observer.plant_run_id(), k, o.rate / o.senders, o.bench_nice, stop);
      });
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
    stop = true;
    for (auto& t : senders) t.join();
    for (const FloodResult& f : floods) {
      r.flood.reniced = f.reniced;
      r.flood.sent += f.sent;
      r.flood.seconds = std::max(r.flood.seconds, f.seconds);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a status from after the flood
    observer.CloseWindow();
    r.load_average = LoadAverage();
    hogs.reset();
    r.counts = observer.window_counts();
    r.plant_b = observer.plant_status();
    r.ctrl_b = observer.controller_status();
    r.observer_drops = observer.kernel_drops() - drops_before;
    if (r.ctrl_b && r.ctrl_b->num_instances == 1) r.controller_reason = r.ctrl_b->instance_reasons[0];
  }
  Terminate(controller, 5.0);
  Terminate(plant, 5.0);
  return r;
}

// ---- output ---------------------------------------------------------------------------------------

void Write(const fs::path& path, const std::vector<CaseResult>& results) {
  std::ofstream csv(path);
  csv.precision(8);
  csv << "bus,case,daemon_recv_buf_size,problem,flood_datagrams,flood_rate_per_s,loop_kept_running,controller_statuses,"
         "controller_statuses_not_running,controller_reason,controller_ticks,measured_accepted,measured_rejected,"
         "controller_kernel_drops,controller_unauthenticated,plant_states_seen,plant_states_not_running,plant_ticks,"
         "torques_accepted,plant_kernel_drops,observer_kernel_drops,cpu_hogs,load_average,bench_nice_taken\n";
  std::cout << "bus        case     buffer   flood/s   loop  ctrl: not-running  accepted/ticks  kernel drops | plant: "
               "not-running  torques/ticks  kernel drops | hogs  load\n";
  for (const CaseResult& r : results) {
    const bool have = r.plant_a && r.plant_b && r.ctrl_a && r.ctrl_b;
    const auto d = [&](const std::optional<status_t>& a, const std::optional<status_t>& b,
                       std::int64_t status_t::*field) { return have ? (*b).*field - (*a).*field : -1; };
    const double rate = r.flood.seconds > 0 ? static_cast<double>(r.flood.sent) / r.flood.seconds : 0.0;
    const bool kept = have && r.counts[1] == 0 && r.counts[3] == 0 && r.counts[0] > 0 && r.counts[2] > 0;
    const std::int64_t ctrl_ticks = d(r.ctrl_a, r.ctrl_b, &status_t::ticks);
    const std::int64_t accepted = d(r.ctrl_a, r.ctrl_b, &status_t::measured_accepted);
    const std::int64_t plant_ticks = d(r.plant_a, r.plant_b, &status_t::ticks);
    const std::int64_t torques = d(r.plant_a, r.plant_b, &status_t::torques_accepted);
    csv << r.bus << ',' << Name(r.c) << ',' << r.recv_buf_size << ",\"" << r.problem << "\"," << r.flood.sent << ',' << rate << ','
        << (kept ? 1 : 0) << ',' << r.counts[2] << ',' << r.counts[3] << ",\"" << r.controller_reason << "\","
        << ctrl_ticks << ',' << accepted << ',' << d(r.ctrl_a, r.ctrl_b, &status_t::measured_rejected) << ','
        << d(r.ctrl_a, r.ctrl_b, &status_t::datagrams_dropped_kernel) << ','
        << d(r.ctrl_a, r.ctrl_b, &status_t::datagrams_unauthenticated) << ',' << r.counts[0] << ',' << r.counts[1]
        << ',' << plant_ticks << ',' << torques << ',' << d(r.plant_a, r.plant_b, &status_t::datagrams_dropped_kernel)
        << ',' << r.observer_drops << ',' << r.cpu_hogs << ',' << r.load_average << ',' << (r.flood.reniced ? 1 : 0)
        << '\n';
    char line[256];
    const std::string buffer = r.recv_buf_size > 0 ? std::to_string(r.recv_buf_size) : "default";
    std::snprintf(line, sizeof line,
                  "%-10s %-8s %-8s %8.0f  %-4s  %6lld/%-6lld  %13.3f  %12lld | %6lld/%-6lld  %13.3f  %12lld | %4d  %4.1f\n",
                  r.bus.c_str(), Name(r.c), buffer.c_str(), rate, kept ? "yes" : "NO", static_cast<long long>(r.counts[3]),
                  static_cast<long long>(r.counts[2]),
                  ctrl_ticks > 0 ? static_cast<double>(accepted) / static_cast<double>(ctrl_ticks) : 0.0,
                  static_cast<long long>(d(r.ctrl_a, r.ctrl_b, &status_t::datagrams_dropped_kernel)),
                  static_cast<long long>(r.counts[1]), static_cast<long long>(r.counts[0]),
                  plant_ticks > 0 ? static_cast<double>(torques) / static_cast<double>(plant_ticks) : 0.0,
                  static_cast<long long>(d(r.plant_a, r.plant_b, &status_t::datagrams_dropped_kernel)), r.cpu_hogs,
                  r.load_average);
    std::cout << line;
    if (!r.problem.empty()) std::cout << "  " << r.problem << '\n';
  }
}

// 32 random bytes, owner-only, in `dir`.
std::string WriteKey(const fs::path& dir) {
  const fs::path path = dir / "bus.key";
  std::random_device random;
  std::ofstream out(path, std::ios::binary);
  for (int k = 0; k < 32; ++k) out.put(static_cast<char>(random() & 0xff));
  out.close();
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  return path.string();
}

int Main(int argc, char** argv) {
  Options o;
  CLI::App app{"flood_bench: the two-process loop (external plant / external controller) under floods"};
  AddDaemonOptions(app, o, ConfigOption::kSceneFolder,
                   std::string("Folder of ") + kPlantScene + " and " + kControllerScene);
  auto* seconds = app.add_option("--seconds-per-case", o.seconds, "Seconds of each flood")
                      ->check(CLI::Range(1.0, 600.0))
                      ->capture_default_str();
  app.add_option("--senders", o.senders, "Flooding threads")->check(CLI::Range(1, 8))->capture_default_str();
  app.add_option("--rate", o.rate, "Flood datagrams per second, all senders together (0: as fast as they can)")
      ->check(CLI::Range(0.0, 1e7))
      ->capture_default_str();
  app.add_option("--recv-buf-size", o.recv_buf_size, "The daemons' SO_RCVBUF request, bytes (default: theirs)")
      ->check(CLI::Range(1, 1 << 30));
  app.add_option("--baseline-buffer", o.baseline_buffer,
                 "Every case again with the daemons asking this receive buffer, bytes (0: not)")
      ->check(CLI::Range(0, 1 << 30))
      ->capture_default_str();
  AddQuickFlag(app, o.quick, "2 s per case (unless --seconds-per-case)",
               [&o, seconds] { QuickDefault(seconds, o.seconds, 2.0); });
  app.add_option("--rt-priority", o.rt_priority, "Run the daemons with --mlockall --rt-priority N")
      ->check(CLI::Range(1, 99));
  app.add_option("--bench-nice", o.bench_nice,
                 "Nice value of the flooding and observing threads (negative: privileged; the hogs then slow them less)")
      ->check(CLI::Range(-20, 19))
      ->capture_default_str();
  app.add_option("--cpu-hogs", o.cpu_hogs, "Processes spinning at nice 0 beside the daemons in every window")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  app.add_option("--bus", o.bus, "Which buses: unsigned, signed or both")
      ->check(CLI::IsMember({"unsigned", "signed", "both"}))
      ->capture_default_str();
  app.add_option("--cases", o.cases, "Which cases, in order (quiet, refused, garbage)")
      ->delimiter(',')
      ->check(CLI::IsMember({"quiet", "refused", "garbage"}));
  CLI11_PARSE(app, argc, argv);
  if (const int status = PrepareRun("flood_bench", o, {o.port})) return status;
  char scratch_template[] = "/tmp/flood_bench.XXXXXX";
  const fs::path scratch = mkdtemp(scratch_template);
  const std::string key_file = WriteKey(scratch);
  const BusKey key = BusKey::FromFile(key_file);
  std::vector<CaseResult> results;
  for (const bool signed_bus : {false, true}) {
    if (o.bus != "both" && o.bus != (signed_bus ? "signed" : "unsigned")) continue;
    Observer observer(Url(o.port), signed_bus ? &key : nullptr);
    std::atomic<bool> stop{false};
    std::thread observe([&] {
      if (o.bench_nice != 0) ReniceThisThread(o.bench_nice);  // the measuring instrument, as the flood
      observer.Run(stop);
    });
    for (const std::string& name : o.cases) {
      const Case c = name == "quiet" ? Case::kQuiet : name == "refused" ? Case::kRefused : Case::kGarbage;
      std::vector<int> buffers = {o.recv_buf_size};
      if (o.baseline_buffer > 0 && o.baseline_buffer != o.recv_buf_size) buffers.push_back(o.baseline_buffer);
      for (const int buffer : buffers) {
        std::cerr << "flood_bench: " << (signed_bus ? "signed" : "unsigned") << " bus, " << Name(c) << ", buffer "
                  << (buffer > 0 ? std::to_string(buffer) : "default") << "\n";
        results.push_back(RunCase(o, signed_bus ? "signed" : "unsigned", signed_bus ? key_file : "", c, buffer, observer));
      }
    }
    stop = true;
    observe.join();
  }
  fs::remove_all(scratch);
  Write(o.File("flood_cases.csv"), results);
  for (const CaseResult& r : results)
    if (!r.problem.empty()) return 1;
  return 0;
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
