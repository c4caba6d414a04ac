// The hostile bus (security issue, "measured in a benchmark, not a test"):
// the real lagranged on the default scene (instances arm and cartpole) under
// floods of traffic, one case after another, each for --seconds-per-case:
//   quiet       no flood: the baseline, measured in the same run
//   setpoints   valid ARM_SETPOINT messages
//   malformed   ARM_SETPOINT messages the daemon must refuse (truncated, wrong
//               type, wrong size, NaN, out of limits, stale, num_dofs 2^31−1,
//               empty) and datagrams that are not LCM (bad magic, channel not
//               terminated, over the size bound, 3 bytes)
//   commands    valid ARM_COMMAND messages: switch controller, pause, resume
//   fragments   LC03 fragments on ARM_STATE: a first fragment, one whose
//               offset wraps 32 bits, one shorter than its header, one that
//               declares a 256 MiB message and fragments into it
//               (docs/lcm-fragment-bug.md)
//   foreign     LC02 messages on 15 channels the daemon does not use, and one
//               in 16 a spoofed ARM_STATE from another run id
// Each flood is one thread sending prepared datagrams on a raw UDP socket as
// fast as it can (its rate is reported). During every case, the quiet one too:
//   - Debian's lcm-logger records the output channels (a new log per case);
//     its states of this run, per instance, are counted against the ticks the
//     daemon ran in the window (from its status_t.ticks just after the window
//     opened to just after it closed): ticks lost at an external logger;
//   - an estop every 1 s to the arm (a request_id each, resent every 20 ms
//     until seen, as lagrangectl does), then clear_estop
//     once the arm is seen in MODE_ESTOP (resent every 50 ms until it leaves
//     it, which it does once the scene's estop_dwell, 0.5 s, is over): an
//     estop counts as applied when a state shows the arm in MODE_ESTOP or
//     its reply_t says accepted;
//   - a setpoint prober: a new cartpole setpoint every 20 ms (+ up to 1 ms of
//     seeded jitter), timed from just before its publication to the first
//     CARTPOLE_STATE whose q_des carries it;
//   - the daemon's VmRSS (/proc) at the start, every 0.1 s and at the end,
//     and its status_t counters at both ends of the window.
// The harness receives through lagrange::Bus (never lcm::LCM, whose
// fragment reassembly the fragment flood crashes) with a 4 MiB receive
// buffer.
//
// All of it twice: "shared", the daemon, the floods and the logger on one bus
// (--port); "separate", the daemon with --lcm-url on --port (outputs, where
// the logger listens) and --input-lcm-url on --port + 1 (setpoints and
// commands, where the floods, the estops and the prober send).
//
// Files in --out: hostile_cases.csv (a row per bus and case),
// hostile_estops.csv, hostile_probe.csv, hostile_summary.csv,
// lagranged_hostile_<bus>.log. The report script computes the percentiles.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <mutex>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <thread>

#include "bench/harness.hpp"
#include "bench/options.hpp"
#include "bench/proc_stats.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "protocol/observer.hpp"
#include "protocol/receive.hpp"

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;


enum class Case { kQuiet, kSetpoints, kMalformed, kCommands, kFragments, kForeign };
constexpr std::array kCases = {Case::kQuiet,    Case::kSetpoints, Case::kMalformed,
                               Case::kCommands, Case::kFragments, Case::kForeign};

const char* Name(Case c) {
  switch (c) {
    case Case::kQuiet: return "quiet";
    case Case::kSetpoints: return "setpoints";
    case Case::kMalformed: return "malformed";
    case Case::kCommands: return "commands";
    case Case::kFragments: return "fragments";
    case Case::kForeign: return "foreign";
  }
  return "?";
}

// port: outputs (and inputs on the shared bus); inputs on port + 1 when separate.
struct Options : DaemonOptions {
  Options() { port = 7990; }
  double seconds = 10.0;  // per case
  bool quick = false;     // 2 s per case
  int rt_priority = 0;    // > 0: the daemon with --mlockall --rt-priority
};

// The default scene's channels: instance 0 is the arm, 1 the cart-pole.
const std::vector<InstanceChannelNames> kChannels = {DerivedChannelNames("", "arm"),
                                                     DerivedChannelNames("", "cartpole")};
const std::string kStatus = StatusChannel("");
constexpr std::size_t kArm = 0, kCartpole = 1;
constexpr const char* kLoggedChannels = "ARM_STATE|CARTPOLE_STATE|LAGRANGE_STATUS|ARM_REPLY|CARTPOLE_REPLY";
// Request ids of the estops and clears carry this tag in their top 16 bits.
constexpr std::int64_t kEstopTag = std::int64_t{0x4553} << 48;
constexpr std::int64_t kSpoofRunId = 0x5ee5;

// ---- datagrams ------------------------------------------------------------------------

void PutU32(Bytes& b, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) b.push_back(static_cast<std::uint8_t>(v >> shift));
}
void PutU16(Bytes& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v >> 8));
  b.push_back(static_cast<std::uint8_t>(v));
}

// An LC03 fragment; fragment 0 carries the channel.
Bytes Lc03(std::uint32_t seqno, std::uint32_t msg_size, std::uint32_t offset, std::uint16_t fragment,
           std::uint16_t fragments, std::string_view channel, std::size_t data_size, std::uint8_t fill) {
  Bytes b;
  PutU32(b, 0x4c433033);
  PutU32(b, seqno);
  PutU32(b, msg_size);
  PutU32(b, offset);
  PutU16(b, fragment);
  PutU16(b, fragments);
  if (fragment == 0) {
    b.insert(b.end(), channel.begin(), channel.end());
    b.push_back(0);
  }
  b.insert(b.end(), data_size, fill);
  return b;
}

template <class Message>
Bytes Encode(const Message& m) {
  Bytes b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

Bytes SetpointBytes(std::int64_t utime, std::vector<double> q) { return Encode(SetpointMessage(utime, std::move(q))); }

Bytes CommandBytes(std::int8_t kind, std::int64_t request_id, const std::string& controller = "") {
  command_t c = CommandMessage(kind, request_id);
  c.controller = controller;
  return Encode(c);
}

// The datagrams of one flood, sent in turn. Made again (new timestamps and
// request ids) every kRemakeEvery datagrams when `remake`.
struct Traffic {
  std::vector<Bytes> datagrams;
  bool remake = false;
};
constexpr std::uint64_t kRemakeEvery = 512;

constexpr double kHold = std::numbers::pi / 4;  // rad, the arm's first joint

// Valid arm setpoints.
Traffic SetpointFlood(std::int64_t now) {
  return {{Lc02(1, kChannels[kArm].setpoint, SetpointBytes(now, {kHold, 0.0}))}, true};
}

// Arm setpoints the daemon must refuse, and datagrams that are not LCM.
Traffic MalformedFlood(std::int64_t now) {
  const std::string& setpoint = kChannels[kArm].setpoint;
  const Bytes valid = SetpointBytes(now, {kHold, 0.0});
  Bytes huge_n = valid;
  const std::uint8_t n_max[4] = {0x7f, 0xff, 0xff, 0xff};
  std::memcpy(huge_n.data() + 16, n_max, 4);  // after the fingerprint and utime
  state_t wrong_type;
  wrong_type.num_dofs = 0;
  Bytes unterminated = Lc02(10, "", {});
  unterminated.pop_back();
  unterminated.insert(unterminated.end(), 80, 'A');  // no NUL
  return {{
              Lc02(1, setpoint, Bytes(valid.begin(), valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2))),
              Lc02(2, setpoint, Encode(wrong_type)),
              Lc02(3, setpoint, SetpointBytes(now, {kHold, 0.0, 0.0})),
              Lc02(4, setpoint, SetpointBytes(now, {std::numeric_limits<double>::quiet_NaN(), 0.0})),
              Lc02(5, setpoint, SetpointBytes(now, {10.0, 0.0})),
              Lc02(6, setpoint, SetpointBytes(now - 3'600'000'000, {kHold, 0.0})),
              Lc02(7, setpoint, huge_n),
              Lc02(8, setpoint, {}),
              Bytes{'L', 'C', '9', '9', 0, 0, 0, 9, 'A', 0, 1, 2, 3},
              unterminated,
              Lc02(11, setpoint, Bytes(20'000, 0x55)),
              Bytes{'L', 'C', '0'},
          },
          true};
}

// Valid arm commands; request ids new in every generation.
Traffic CommandFlood(std::uint64_t generation) {
  const std::int64_t id = static_cast<std::int64_t>(generation) * 8 + 1;
  const std::string& command = kChannels[kArm].command;
  return {{
              Lc02(1, command, CommandBytes(command_t::SWITCH_CONTROLLER, id, "pd")),
              Lc02(2, command, CommandBytes(command_t::PAUSE, id + 1)),
              Lc02(3, command, CommandBytes(command_t::SWITCH_CONTROLLER, id + 2, "gravity-compensation")),
              Lc02(4, command, CommandBytes(command_t::RESUME, id + 3)),
              Lc02(5, command, CommandBytes(command_t::SWITCH_CONTROLLER, id + 4, "computed-torque")),
          },
          true};
}

// LC03 fragments on the arm's state channel (docs/lcm-fragment-bug.md).
Traffic FragmentFlood() {
  const std::string& channel = kChannels[kArm].state;
  const Bytes first = Lc03(7, 4096, 0, 0, 2, channel, 16, 0x11);
  Bytes shorter = Lc03(7, 4096, 2, 1, 2, "", 0, 0);  // 20 bytes of header ...
  shorter.resize(18);                                // ... cut to 18
  Traffic t;
  t.datagrams = {first, Lc03(7, 4096, 0xfffffff0u, 1, 2, "", 64, 0xab), first, shorter,
                 Lc03(8, 1u << 28, 0, 0, 0x1001, channel, 16, 0x22)};
  for (std::uint16_t k = 1; k <= 4; ++k) t.datagrams.push_back(Lc03(8, 1u << 28, k * 1400u, k, 0x1001, "", 1400, 0x33));
  return t;
}

// Seeded random payloads on 15 channels the daemon does not use, and an arm state from another run.
Traffic ForeignFlood(std::int64_t now) {
  Traffic t;
  std::mt19937 rng{42};
  std::uniform_int_distribution<int> byte(0, 255);
  for (int k = 0; k < 15; ++k) {
    Bytes payload(200);
    for (auto& b : payload) b = static_cast<std::uint8_t>(byte(rng));
    char name[32];
    std::snprintf(name, sizeof name, "FOREIGN_ROBOT_%02d_STATE", k);
    t.datagrams.push_back(Lc02(static_cast<std::uint32_t>(k), name, payload));
  }
  state_t spoof;
  spoof.utime = now;
  spoof.run_id = kSpoofRunId;
  spoof.num_dofs = 2;
  for (auto* v : {&spoof.q, &spoof.qd, &spoof.qdd, &spoof.tau, &spoof.q_des, &spoof.qd_des}) v->assign(2, 0.0);
  spoof.controller = "spoof";
  t.datagrams.push_back(Lc02(15, kChannels[kArm].state, Encode(spoof)));
  return t;
}

Traffic MakeTraffic(Case c, std::uint64_t generation) {
  const std::int64_t now = WallMicros();
  switch (c) {
    case Case::kQuiet: return {};
    case Case::kSetpoints: return SetpointFlood(now);
    case Case::kMalformed: return MalformedFlood(now);
    case Case::kCommands: return CommandFlood(generation);
    case Case::kFragments: return FragmentFlood();
    case Case::kForeign: return ForeignFlood(now);
  }
  return {};
}

struct FloodResult {
  std::int64_t sent = 0, failed = 0;
  double seconds = 0.0;
};

FloodResult Flood(Case c, int port, const std::atomic<bool>& stop) {
  FloodResult r;
  Traffic t = MakeTraffic(c, 0);
  if (t.datagrams.empty()) return r;
  RawSender sender(port);
  const auto start = Clock::now();
  for (std::uint64_t k = 0; !stop.load(std::memory_order_relaxed); ++k) {
    if (t.remake && k % kRemakeEvery == 0 && k > 0) t = MakeTraffic(c, k / kRemakeEvery);
    (sender.Send(t.datagrams[k % t.datagrams.size()]) ? r.sent : r.failed)++;
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

// ---- what the daemon publishes ------------------------------------------------------------

// Receives the daemon's outputs: statuses, the arm's mode and the
// cart-pole's q_des for the prober (a BusObserver following both, its hooks
// doing the per-message work), and replies to the estops. Learns the run id
// from the first status.
class Observer {
 public:
  explicit Observer(const std::string& url)
      : bus_(OpenBus(WithReceiveBuffer(url))),
        daemon_(*bus_, "", ObserverLimits{.instances = 2, .discover = false, .telemetry = false},
                BusObserver::Hooks{.on_state = [this](const std::string& name, const state_t& s) { OnState(name, s); },
                                   .on_status = [this](const status_t& s) { OnStatus(s); }}) {
    daemon_.Follow(kChannels[kArm].instance);
    daemon_.Follow(kChannels[kCartpole].instance);
    SubscribeMessages<reply_t>(*bus_, kChannels[kArm].reply, [this](reply_t&& r) { OnReply(r); });
  }

  void Run(const std::atomic<bool>& stop) {
    while (!stop.load()) bus_->Handle(20);
  }

  // A new daemon: forget the run id.
  void Reset() {
    std::lock_guard<std::mutex> lock(mutex_);
    run_id_ = 0;
    statuses_.clear();
  }
  std::int64_t run_id() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return run_id_;
  }
  // The first status received after `after_ns`, waiting up to `timeout_s`.
  std::optional<status_t> StatusAfter(std::int64_t after_ns, double timeout_s) {
    std::unique_lock<std::mutex> lock(mutex_);
    std::optional<status_t> found;
    changed_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
      for (const auto& [t, s] : statuses_) {
        if (t > after_ns) {
          found = s;
          return true;
        }
      }
      return false;
    });
    return found;
  }
  // When the arm was first seen in MODE_ESTOP since it was last seen in another mode; -1: not in it.
  std::int64_t estop_since() const { return estop_since_.load(); }
  // 1 accepted, 0 refused, -1 no reply (yet).
  int Reply(std::int64_t request_id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = replies_.find(request_id);
    return it == replies_.end() ? -1 : it->second ? 1 : 0;
  }

  // The prober: setpoint `value` published at `sent_ns`.
  void ProbeSent(double value, std::int64_t sent_ns) {
    std::lock_guard<std::mutex> lock(mutex_);
    probe_value_ = value;
    probe_sent_ = sent_ns;
    probe_pending_ = true;
    probe_latency_.push_back(-1);
  }
  // The latency of every setpoint probed since the last call (ns; -1: never seen), and forgets them.
  std::vector<std::int64_t> TakeProbes() {
    std::lock_guard<std::mutex> lock(mutex_);
    probe_pending_ = false;
    return std::exchange(probe_latency_, {});
  }

 private:
  bool Ours(std::int64_t run_id) const { return run_id_ != 0 && run_id == run_id_; }

  void OnStatus(const status_t& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (run_id_ == 0 && status.run_id != kSpoofRunId) run_id_ = status.run_id;
    if (!Ours(status.run_id)) return;
    statuses_.emplace_back(MonotonicNs(), status);
    if (statuses_.size() > 4096) statuses_.erase(statuses_.begin(), statuses_.begin() + 2048);
    changed_.notify_all();
  }
  void OnState(const std::string& name, const state_t& s) {
    if (name == kChannels[kArm].instance) OnArm(s);
    if (name == kChannels[kCartpole].instance) OnCartpole(s);
  }
  void OnArm(const state_t& arm) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!Ours(arm.run_id)) return;
    }
    if (arm.mode != state_t::MODE_ESTOP) {
      estop_since_ = -1;
    } else if (estop_since_.load() < 0) {
      estop_since_ = MonotonicNs();
    }
  }
  void OnCartpole(const state_t& cartpole) {
    const std::int64_t now = MonotonicNs();
    std::lock_guard<std::mutex> lock(mutex_);
    if (!Ours(cartpole.run_id) || !probe_pending_ || cartpole.q_des.empty()) return;
    if (cartpole.q_des[0] == probe_value_) {
      probe_latency_.back() = now - probe_sent_;
      probe_pending_ = false;
    }
  }
  void OnReply(const reply_t& reply) {
    if ((reply.request_id & ~((std::int64_t{1} << 48) - 1)) != kEstopTag) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (Ours(reply.run_id)) replies_[reply.request_id] = reply.accepted;
  }

  std::unique_ptr<Bus> bus_;
  BusObserver daemon_;  // read on the receive thread only (its hooks)
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::int64_t run_id_ = 0;
  std::vector<std::pair<std::int64_t, status_t>> statuses_;  // (received, status)
  std::atomic<std::int64_t> estop_since_{-1};
  std::map<std::int64_t, bool> replies_;
  double probe_value_ = 0.0;
  std::int64_t probe_sent_ = 0;
  bool probe_pending_ = false;
  std::vector<std::int64_t> probe_latency_;
};

// ---- estops and the prober ------------------------------------------------------------------

struct Estop {
  std::int64_t sent_ns = 0;
  std::int64_t request_id = 0;
  std::int64_t state_latency_ns = -1;  // publication → the arm first seen in MODE_ESTOP; -1: not seen
  int reply = -1;                      // 1 accepted, 0 refused, -1 none
  int clears = 0;                      // clear_estop sent until the arm left MODE_ESTOP
  int sends = 0;                       // times the estop was sent (every 20 ms until seen, as lagrangectl does)
};

constexpr auto kEstopPoll = std::chrono::microseconds(200);

// An estop every 1 s (the first after 0.25 s) until `stop`; after each, clear_estop until the arm leaves it
// (refused until the estop has lasted the scene's estop_dwell, 0.5 s).
std::vector<Estop> SendEstops(const std::string& input_url, Observer& observer, std::int64_t& next_id,
                              const std::atomic<bool>& stop) {
  std::unique_ptr<Bus> bus = OpenBus(input_url);
  const std::string& channel = kChannels[kArm].command;
  std::vector<Estop> estops;
  auto next = Clock::now() + std::chrono::milliseconds(250);
  while (!stop.load()) {
    std::this_thread::sleep_until(next);
    if (stop.load()) break;
    next += std::chrono::milliseconds(1000);
    Estop e;
    e.request_id = kEstopTag | next_id++;
    e.sent_ns = MonotonicNs();
    // Sent as `lagrangectl command estop` sends it: again every 20 ms (same
    // request id) until it shows, since under a flood the kernel may drop a
    // datagram before lagranged reads it; a repeated estop applies once.
    for (int elapsed = 0; elapsed < 250; elapsed += 20) {
      ++e.sends;
      bus->PublishMessage(channel, CommandMessage(command_t::ESTOP, e.request_id));
      if (Await([&] { return observer.estop_since() >= e.sent_ns; }, 0.020, kEstopPoll)) {
        e.state_latency_ns = observer.estop_since() - e.sent_ns;
        break;
      }
    }
    do {
      ++e.clears;
      bus->PublishMessage(channel, CommandMessage(command_t::CLEAR_ESTOP, kEstopTag | next_id++));
    } while (!Await([&] { return observer.estop_since() < 0; }, 0.050, kEstopPoll) && e.clears < 15);
    estops.push_back(e);
  }
  return estops;
}

// A cart-pole setpoint every 20 ms (+ jitter) until `stop`: x changes every time, θ upright.
void Probe(const std::string& input_url, Observer& observer, const std::atomic<bool>& stop) {
  std::unique_ptr<Bus> bus = OpenBus(input_url);
  JitteredSchedule schedule(std::chrono::milliseconds(20));
  for (std::int64_t k = 0; !stop.load(); ++k) {
    schedule.SleepUntilNext();
    const double x = 1e-4 * static_cast<double>(k % 500 + 1);  // m
    observer.ProbeSent(x, MonotonicNs());
    bus->PublishMessage(kChannels[kCartpole].setpoint, SetpointMessage(WallMicros(), {x, std::numbers::pi}));
  }
}

// ---- one case ------------------------------------------------------------------------------

// One bus set-up: the daemon's outputs on `url`, its inputs (the floods, the
// estops, the prober) on `input_url`, the same URL when shared.
struct BusSetup {
  std::string name;  // "shared" or "separate"
  std::string url, input_url;
  int input_port = 0;
  fs::path scratch;  // the cases' LCM logs, removed once read
};

struct Daemon {
  pid_t pid = -1;
  int starts = 0;
  long rss_first_kib = -1, rss_last_kib = -1;
};

struct CaseResult {
  std::string bus;
  Case c = Case::kQuiet;
  double seconds = 0.0;
  FloodResult flood;
  bool have_status = false;
  status_t a, b;                             // the statuses at the window's ends
  std::map<std::string, std::int64_t> lost;  // state channel => ticks not logged
  std::string logger_exit;
  bool daemon_alive = false;
  long rss_start = -1, rss_end = -1, rss_peak = -1;  // KiB
  std::vector<Estop> estops;
  std::vector<std::int64_t> probes;
};

// Starts the daemon (its output in `log`, or `log`.restartN) and waits for its first status.
bool StartDaemon(const Options& o, const BusSetup& bus, const fs::path& log, Observer& observer, Daemon& d) {
  observer.Reset();
  std::vector<std::string> argv = LagrangedArgs(o.lagranged, o.config, bus.url, o.rt_priority);
  if (bus.input_url != bus.url) argv.insert(argv.end(), {"--input-lcm-url", bus.input_url});
  d.pid = Spawn(argv, d.starts == 0 ? log : fs::path(log.string() + ".restart" + std::to_string(d.starts)));
  ++d.starts;
  if (!observer.StatusAfter(0, 20.0)) return false;
  if (d.rss_first_kib < 0) d.rss_first_kib = VmRssKiB(d.pid);
  return true;
}

// The case's window: its flood, the estops and the prober for --seconds-per-case, the daemon's VmRSS every 0.1 s.
void RunWindow(const Options& o, const BusSetup& bus, Case c, Observer& observer, const Daemon& d,
               std::int64_t& next_id, CaseResult& r) {
  std::atomic<bool> stop_flood{false}, stop{false};
  std::thread flood([&] { r.flood = Flood(c, bus.input_port, stop_flood); });
  std::thread estops([&] { r.estops = SendEstops(bus.input_url, observer, next_id, stop); });
  std::thread probe([&] { Probe(bus.input_url, observer, stop); });
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration<double>(o.seconds);
  while (Clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    r.rss_peak = std::max(r.rss_peak, VmRssKiB(d.pid));
  }
  stop_flood = true;
  flood.join();
  stop = true;
  estops.join();
  probe.join();
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
}

// The states of this run that `log` lacks, per instance, of the ticks between the statuses `a` and `b`.
void CountLost(const fs::path& log, const std::optional<status_t>& a, const std::optional<status_t>& b,
               std::int64_t run_id, CaseResult& r) {
  r.have_status = a && b;
  if (!r.have_status) return;
  r.a = *a;
  r.b = *b;
  const auto ticks = ReadStateTicks(log, {kChannels[kArm].state, kChannels[kCartpole].state}, run_id);
  for (const auto& [channel, t] : ticks) r.lost[channel] = TicksMissing(t, a->ticks, b->ticks);
}

CaseResult RunCase(const Options& o, const BusSetup& bus, Case c, Observer& observer, const Daemon& d,
                   std::int64_t& next_id) {
  CaseResult r;
  r.bus = bus.name;
  r.c = c;
  const std::string stem = bus.name + "_" + Name(c);
  const fs::path log = bus.scratch / (stem + ".lcmlog");
  LcmLogger logger(bus.url, kLoggedChannels, log, bus.scratch / (stem + ".logger.txt"));
  if (!logger.AwaitReady())
    std::cerr << "hostile_bench: lcm-logger did not start (" << bus.name << ", " << Name(c) << ")\n";
  r.rss_start = r.rss_peak = VmRssKiB(d.pid);
  const std::optional<status_t> a = observer.StatusAfter(MonotonicNs(), 2.0);
  RunWindow(o, bus, c, observer, d, next_id, r);
  const std::optional<status_t> b = observer.StatusAfter(MonotonicNs(), 2.0);
  r.rss_end = VmRssKiB(d.pid);
  r.rss_peak = std::max(r.rss_peak, r.rss_end);
  r.probes = observer.TakeProbes();
  for (Estop& e : r.estops) e.reply = observer.Reply(e.request_id);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last states reach the logger
  r.logger_exit = DescribeExit(logger.Stop().status);
  r.daemon_alive = waitpid(d.pid, nullptr, WNOHANG) == 0;
  CountLost(log, a, b, observer.run_id(), r);
  fs::remove(log);
  return r;
}

// ---- output ---------------------------------------------------------------------------------

void WriteCases(const fs::path& path, const std::vector<CaseResult>& results) {
  std::ofstream csv(path);
  csv.precision(10);
  csv << "bus,case,seconds,flood_datagrams,flood_failed,flood_rate_per_s,have_status,ticks,lost_arm,lost_cartpole,"
         "logger_exit,daemon_alive,overruns,state_messages_dropped,rss_start_kib,rss_end_kib,rss_peak_kib,estops,"
         "estops_seen_in_state,estop_replies_accepted,estops_applied,probe_sent,probe_seen,setpoints_accepted,"
         "setpoints_rejected,commands_accepted,commands_rejected,decode_errors,datagrams_dropped_kernel,"
         "datagrams_malformed,fragments_dropped,foreign_messages,replies_suppressed\n";
  for (const CaseResult& r : results) {
    const auto lost = [&](std::size_t i) {
      const auto it = r.lost.find(kChannels[i].state);
      return it == r.lost.end() ? std::int64_t{-1} : it->second;
    };
    const auto count = [&](auto pred) { return std::count_if(r.estops.begin(), r.estops.end(), pred); };
    const auto delta = [&](std::int64_t status_t::*field) { return r.have_status ? r.b.*field - r.a.*field : -1; };
    csv << r.bus << ',' << Name(r.c) << ',' << r.seconds << ',' << r.flood.sent << ',' << r.flood.failed << ','
        << (r.flood.seconds > 0 ? static_cast<double>(r.flood.sent) / r.flood.seconds : 0.0) << ','
        << (r.have_status ? 1 : 0) << ',' << delta(&status_t::ticks) << ',' << lost(kArm) << ',' << lost(kCartpole)
        << ",\"" << r.logger_exit << "\"," << (r.daemon_alive ? 1 : 0) << ',' << delta(&status_t::overruns) << ','
        << (r.have_status ? r.b.state_messages_dropped : -1) << ',' << r.rss_start << ',' << r.rss_end << ','
        << r.rss_peak << ',' << r.estops.size() << ',' << count([](const Estop& e) { return e.state_latency_ns >= 0; })
        << ',' << count([](const Estop& e) { return e.reply == 1; }) << ','
        << count([](const Estop& e) { return e.state_latency_ns >= 0 || e.reply == 1; }) << ',' << r.probes.size()
        << ',' << std::count_if(r.probes.begin(), r.probes.end(), [](std::int64_t l) { return l >= 0; }) << ','
        << delta(&status_t::setpoints_accepted) << ',' << delta(&status_t::setpoints_rejected) << ','
        << delta(&status_t::commands_accepted) << ',' << delta(&status_t::commands_rejected) << ','
        << delta(&status_t::decode_errors) << ',' << delta(&status_t::datagrams_dropped_kernel) << ','
        << delta(&status_t::datagrams_malformed) << ',' << delta(&status_t::fragments_dropped) << ','
        << delta(&status_t::foreign_messages) << ',' << delta(&status_t::replies_suppressed) << '\n';
  }
}

void WriteEstops(const fs::path& path, const std::vector<CaseResult>& results) {
  std::ofstream csv(path);
  csv << "bus,case,k,sent_ns,state_latency_ns,reply,clears_sent,estop_sends\n";
  for (const CaseResult& r : results) {
    int k = 0;
    for (const Estop& e : r.estops) {
      csv << r.bus << ',' << Name(r.c) << ',' << k++ << ',' << e.sent_ns << ',' << e.state_latency_ns << ','
          << (e.reply == 1   ? "accepted"
              : e.reply == 0 ? "refused"
                             : "none")
          << ',' << e.clears << ',' << e.sends << '\n';
    }
  }
}

void WriteProbes(const fs::path& path, const std::vector<CaseResult>& results) {
  std::ofstream csv(path);
  csv << "bus,case,k,latency_ns\n";
  for (const CaseResult& r : results) {
    int k = 0;
    for (std::int64_t l : r.probes) csv << r.bus << ',' << Name(r.c) << ',' << k++ << ',' << l << '\n';
  }
}

// ---- the run ----------------------------------------------------------------------------------

struct BusRun {
  std::string bus;
  int starts = 0;
  std::string exit;
  long rss_first_kib = -1, rss_last_kib = -1;
};

// Every case on one bus set-up, with one daemon (started again if a case killed it).
BusRun RunBus(const Options& o, const BusSetup& bus, std::vector<CaseResult>& results) {
  const fs::path log = o.File("lagranged_hostile_" + bus.name + ".log");
  Observer observer(bus.url);
  std::atomic<bool> stop{false};
  std::thread observe([&] { observer.Run(stop); });
  Daemon d;
  std::int64_t next_id = 1;
  bool up = StartDaemon(o, bus, log, observer, d);
  for (Case c : kCases) {
    if (!up) {
      std::cerr << "hostile_bench: lagranged (" << bus.name << ") is not running; starting it again\n";
      WaitExit(d.pid, 0.5);
      up = StartDaemon(o, bus, log, observer, d);
      if (!up) break;
    }
    std::cerr << "hostile_bench: " << bus.name << " bus, " << Name(c) << "\n";
    results.push_back(RunCase(o, bus, c, observer, d, next_id));
    d.rss_last_kib = results.back().rss_end;
    up = results.back().daemon_alive;
  }
  BusRun run{bus.name, d.starts, DescribeExit(Terminate(d.pid, 10.0).status), d.rss_first_kib, d.rss_last_kib};
  stop = true;
  observe.join();
  return run;
}

BusSetup MakeBusSetup(const Options& o, const std::string& name, bool separate, const fs::path& scratch) {
  const int input_port = separate ? o.port + 1 : o.port;
  return {name, Url(o.port), Url(input_port), input_port, scratch};
}

// hostile_summary.csv; the exit status: 1 when a daemon had to be started again or did not exit cleanly.
int WriteSummary(const Options& o, const std::vector<BusRun>& runs) {
  std::ofstream summary(o.File("hostile_summary.csv"));
  summary << "key,value\nseconds_per_case," << o.seconds << "\nport," << o.port << "\ninput_port_separate,"
          << o.port + 1 << "\nrt_priority," << o.rt_priority << "\ncores," << std::thread::hardware_concurrency()
          << '\n';
  int status = 0;
  for (const BusRun& r : runs) {
    summary << r.bus << "_daemon_starts," << r.starts << '\n'
            << r.bus << "_daemon_exit,\"" << r.exit << "\"\n"
            << r.bus << "_rss_first_kib," << r.rss_first_kib << '\n'
            << r.bus << "_rss_last_kib," << r.rss_last_kib << '\n';
    if (r.starts != 1 || r.exit != "exit 0") status = 1;
  }
  return status;
}

int Main(int argc, char** argv) {
  Options o;
  CLI::App app{"hostile_bench: lagranged under floods of hostile traffic, on one bus and on two"};
  AddDaemonOptions(app, o, ConfigOption::kSceneFile,
                   "Scene with instances arm (2-DOF) and cartpole (default: the daemon's default)");
  app.get_option("--port")
      ->description("LCM port on udpm://239.255.76.67 (outputs); inputs on PORT + 1 when separate")
      ->check(CLI::Range(1, 65534));
  auto* seconds = app.add_option("--seconds-per-case", o.seconds, "Seconds of each case")
                      ->check(CLI::Range(1.0, 600.0))
                      ->capture_default_str();
  AddQuickFlag(app, o.quick, "2 s per case (unless --seconds-per-case)",
               [&o, seconds] { QuickDefault(seconds, o.seconds, 2.0); });
  app.add_option("--rt-priority", o.rt_priority, "Run the daemon with --mlockall --rt-priority N")
      ->check(CLI::Range(1, 99));
  CLI11_PARSE(app, argc, argv);
  if (const int status = PrepareRun("hostile_bench", o, {o.port, o.port + 1})) return status;
  char scratch_template[] = "/tmp/hostile_bench.XXXXXX";
  const fs::path scratch = mkdtemp(scratch_template);
  std::vector<CaseResult> results;
  const std::vector<BusRun> runs = {RunBus(o, MakeBusSetup(o, "shared", false, scratch), results),
                                    RunBus(o, MakeBusSetup(o, "separate", true, scratch), results)};
  fs::remove_all(scratch);
  WriteCases(o.File("hostile_cases.csv"), results);
  WriteEstops(o.File("hostile_estops.csv"), results);
  WriteProbes(o.File("hostile_probe.csv"), results);
  return WriteSummary(o, runs);
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
