// Attacks on a live lagranged, each test named after what it proves: what a
// careless or malicious sender on the bus can send (fragments that crash
// LCM 1.3.1's reassembly, a fragment declaring 256 MiB, floods, forged log
// lines, terminal escapes, a spoofed state stream) leaves the daemon running,
// obeying, its memory flat and its log truthful. Raw datagrams go out through
// tests/support/raw_udp.hpp; this process itself listens through lagrange's
// own bus (protocol/bus.hpp), never lcm::LCM, which the fragments would crash.
// UDP may lose datagrams under a flood: every wait here resends or polls
// with a bound, and nothing counts messages or measures time.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>
#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "protocol/bus.hpp"
#include "tests/support/lcm_messages.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"
#include "tests/support/raw_udp.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;
using testing::BackgroundProcess;
using testing::WallMicros;

constexpr double kWait = 30.0;           // s: bound on waiting for an effect; a pass takes far less
constexpr long kMemoryGrowthKiB = 1024;  // "pins no memory": at most 1 MiB

// lagranged's output channels for the default scene.
const std::vector<std::string> kOutputChannels = {"ARM_STATE",      "CARTPOLE_STATE",  "ARM_REPLY",
                                                  "CARTPOLE_REPLY", "ARM_TELEMETRY",   "CARTPOLE_TELEMETRY",
                                                  "ARM_FORCES",     "CARTPOLE_FORCES", "LAGRANGE_STATUS"};

// Records the messages of some channels of one bus, on its own thread.
class BusCollector {
 public:
  BusCollector(const std::string& url, const std::vector<std::string>& channels) : bus_(OpenBus(url)) {
    for (const std::string& channel : channels) {
      bus_->Subscribe(channel, [this](std::string_view name, const std::uint8_t* data, std::size_t size) {
        std::lock_guard<std::mutex> lock(mutex_);
        messages_[std::string(name)].emplace_back(data, data + size);
      });
    }
    thread_ = std::thread([this] {
      while (!stop_) bus_->Handle(20);
    });
  }
  ~BusCollector() {
    stop_ = true;
    thread_.join();
  }

  template <class T>
  std::vector<T> Decoded(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<T> out;
    for (const Bytes& m : messages_[channel]) {
      T msg;
      if (msg.decode(m.data(), 0, static_cast<int>(m.size())) >= 0) out.push_back(msg);
    }
    return out;
  }
  template <class T>
  std::optional<T> Latest(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto& v = messages_[channel];
    T msg;
    if (v.empty() || msg.decode(v.back().data(), 0, static_cast<int>(v.back().size())) < 0) return std::nullopt;
    return msg;
  }
  std::size_t Count(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_[channel].size();
  }
  // Waits until the latest message of `channel`, as T, satisfies `predicate`.
  template <class T>
  bool WaitForLatest(const std::string& channel, const std::function<bool(const T&)>& predicate,
                     double timeout_s = kWait) {
    return testing::WaitUntil(
        [&] {
          const std::optional<T> m = Latest<T>(channel);
          return m && predicate(*m);
        },
        timeout_s);
  }
  BusStats stats() const { return bus_->stats(); }

 private:
  std::unique_ptr<Bus> bus_;
  std::mutex mutex_;
  std::map<std::string, std::vector<Bytes>> messages_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// ---------------------------------------------------------------- LC03 fragments

// LC03 datagrams (tests/support/raw_udp.hpp lays them out).
Bytes Fragment(std::uint32_t seqno, std::uint32_t msg_size, std::uint32_t offset, std::uint16_t fragment_no,
               std::uint16_t fragments, const std::string& channel, std::size_t data_size) {
  return testing::LcmFragment(seqno, msg_size, offset, fragment_no, fragments, channel, data_size);
}

// ---------------------------------------------------------------- the daemon

class Attack : public ::testing::Test {
 protected:
  // lagranged on `port` (outputs and inputs), this test listening to its outputs.
  void Start(int port, std::vector<std::string> extra = {}) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    url_ = testing::TestLcmUrl(port);
    outputs_ = std::make_unique<BusCollector>(url_, kOutputChannels);
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_};
    argv.insert(argv.end(), extra.begin(), extra.end());
    started_ = std::chrono::steady_clock::now();
    daemon_ = std::make_unique<BackgroundProcess>(argv);
    sender_ = OpenBus(url_);
    raw_ = std::make_unique<testing::RawUdpSender>(testing::kTestLcmGroup, port);
    ASSERT_TRUE(testing::WaitUntil([&] { return outputs_->Count("LAGRANGE_STATUS") >= 2; }, kWait))
        << "lagranged did not start: " << daemon_->Stderr();
  }
  // SIGTERM; it must exit 0. Returns the seconds it ran.
  double Stop() {
    daemon_->Signal(SIGTERM);
    EXPECT_EQ(daemon_->Wait(kWait), 0) << daemon_->Stderr();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  }
  status_t LastStatus() { return outputs_->Latest<status_t>("LAGRANGE_STATUS").value_or(status_t{}); }
  bool AwaitStatus(const std::function<bool(const status_t&)>& predicate) {
    return outputs_->WaitForLatest<status_t>("LAGRANGE_STATUS", predicate);
  }

  static command_t Command(int8_t kind, const std::string& controller = "") {
    command_t c{};
    c.utime = WallMicros();
    c.request_id = 0;
    c.command = kind;
    c.controller = controller;
    c.num_gains = 0;
    return c;
  }
  std::optional<reply_t> FindReply(std::int64_t request_id) {
    for (const reply_t& r : outputs_->Decoded<reply_t>("ARM_REPLY")) {
      if (r.request_id == request_id) return r;
    }
    return std::nullopt;
  }
  // Sends `c` to the arm under a new request id (again, while no reply came); the first reply.
  reply_t Request(command_t c, double every_s = 0.25) {
    c.request_id = ++next_request_id_;
    EXPECT_TRUE(testing::SendUntil([&] { sender_->PublishMessage("ARM_COMMAND", c); },
                                   [&] { return FindReply(c.request_id).has_value(); }, kWait, every_s))
        << "no reply to command " << static_cast<int>(c.command);
    return FindReply(c.request_id).value_or(reply_t{});
  }
  std::string LogText(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  std::string url_;
  std::unique_ptr<BusCollector> outputs_;
  std::unique_ptr<BackgroundProcess> daemon_;
  std::unique_ptr<Bus> sender_;
  std::unique_ptr<testing::RawUdpSender> raw_;
  std::chrono::steady_clock::time_point started_;
  std::int64_t next_request_id_ = 0x5a5a0000;
};
using AttackFlood = Attack;  // the floods: LABELS long, RUN_SERIAL (tests/daemon/CMakeLists.txt)

TEST_F(Attack, OneFragmentDatagramCannotKillTheDaemon) {
  Start(7940);
  std::mt19937 rng{42};
  std::uniform_int_distribution<std::uint32_t> word;
  std::uniform_int_distribution<int> length(0, 1400);
  for (const std::string channel : {"ARM_SETPOINT", "ARM_COMMAND", "NOT_A_LAGRANGE_CHANNEL"}) {
    for (std::uint32_t seqno = 1; seqno <= 3; ++seqno) {
      // A first fragment opens a reassembly on the channel; the next one's offset wraps LCM 1.3.1's bounds check.
      EXPECT_TRUE(raw_->Send(Fragment(seqno, 4096, 0, 0, 2, channel, 100)));
      EXPECT_TRUE(raw_->Send(Fragment(seqno, 4096, 0xFFFFFFF0u, 1, 2, "", 64)));
    }
    // Shorter than the 20-byte fragment header.
    const Bytes whole = Fragment(9, 4096, 0, 0, 2, channel, 0);
    for (std::size_t len = 4; len < 20; ++len) raw_->Send(Bytes(whole.begin(), whole.begin() + static_cast<long>(len)));
    // Random fragments: every header field random, a first fragment now and then.
    for (int k = 0; k < 500; ++k) {
      const auto fragment_no = static_cast<std::uint16_t>(k % 4 == 0 ? 0 : word(rng));
      Bytes f = Fragment(word(rng), word(rng), word(rng), fragment_no, static_cast<std::uint16_t>(word(rng)), channel,
                         static_cast<std::size_t>(length(rng)));
      for (std::size_t i = 20; i < f.size(); ++i) f[i] = static_cast<std::uint8_t>(word(rng));
      raw_->Send(f);
    }
  }
  EXPECT_TRUE(AwaitStatus([](const status_t& s) { return s.fragments_dropped > 0; }))
      << "fragments_dropped " << LastStatus().fragments_dropped;
  EXPECT_TRUE(daemon_->Running()) << daemon_->Stderr();
  const reply_t reply = Request(Command(command_t::SWITCH_CONTROLLER, "pd"));
  EXPECT_TRUE(reply.accepted) << reply.reason;
  EXPECT_TRUE(outputs_->WaitForLatest<state_t>("ARM_STATE", [](const state_t& s) { return s.controller == "pd"; }));
  Stop();
}

TEST_F(Attack, A256MiBFragmentPinsNoMemory) {
  Start(7941);
  // After start-up has settled: the record ring (1024 ticks) has gone round twice.
  ASSERT_TRUE(AwaitStatus([](const status_t& s) { return s.ticks > 2048; }));
  const long rss_before = daemon_->ResidentKiB();
  constexpr std::size_t kData = 1400;
  raw_->Send(Fragment(77, 256u << 20, 0, 0, 0xFFFF, "ARM_SETPOINT", kData));
  for (std::uint16_t k = 1; k <= 1000; ++k) {
    raw_->Send(Fragment(77, 256u << 20, static_cast<std::uint32_t>(k * kData), k, 0xFFFF, "", kData));
    if (k % 50 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // pace: let them arrive
  }
  // A reply to a command sent after them: the daemon has read every fragment that arrived.
  EXPECT_TRUE(Request(Command(command_t::SWITCH_CONTROLLER, "pd")).accepted);
  EXPECT_TRUE(AwaitStatus([](const status_t& s) { return s.fragments_dropped > 0; }));
  const long rss_after = daemon_->ResidentKiB();
  EXPECT_TRUE(daemon_->Running());
  if (testing::kResidentSizeMeaningful) {
    EXPECT_LT(rss_after - rss_before, kMemoryGrowthKiB)
        << "KiB resident before " << rss_before << ", after " << rss_after;
  }
  Stop();
}

TEST_F(AttackFlood, EstopLandsUnderCommandFlood) {
  Start(7942);
  std::atomic<bool> flooding{true};
  std::atomic<std::int64_t> flood_sent{0};
  std::thread flood([&] {
    std::unique_ptr<Bus> bus = OpenBus(url_);
    const std::vector<command_t> kinds = {Command(command_t::PAUSE), Command(command_t::RESUME),
                                          Command(command_t::SWITCH_CONTROLLER, "pd"),
                                          Command(command_t::SWITCH_CONTROLLER, "computed-torque")};
    std::int64_t id = 1'000'000'000;
    auto next = std::chrono::steady_clock::now();
    while (flooding) {
      for (int k = 0; k < 64; ++k) {  // 64 a millisecond: twice what the tick's queue takes
        command_t c = kinds[static_cast<std::size_t>(id % 4)];
        c.request_id = ++id;
        bus->PublishMessage("ARM_COMMAND", c);
      }
      flood_sent += 64;
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
    }
  });
  struct StopFlood {  // also when an assertion below returns early
    std::atomic<bool>& flooding;
    std::thread& thread;
    ~StopFlood() {
      flooding = false;
      if (thread.joinable()) thread.join();
    }
  } stop_flood{flooding, flood};
  // Estops while the flood runs (~2 s): each one lands (the arm's state shows it), whatever is queued.
  std::vector<std::int64_t> estops;
  const auto flood_start = std::chrono::steady_clock::now();
  for (int round = 0; round < 5 || std::chrono::steady_clock::now() - flood_start < std::chrono::seconds(2); ++round) {
    command_t clear = Command(command_t::CLEAR_ESTOP);
    clear.request_id = ++next_request_id_;
    ASSERT_TRUE(testing::SendUntil([&] { sender_->PublishMessage("ARM_COMMAND", clear); },
                                   [&] {
                                     const auto s = outputs_->Latest<state_t>("ARM_STATE");
                                     return s && s->mode != state_t::MODE_ESTOP;
                                   },
                                   kWait))
        << "round " << round;
    command_t estop = Command(command_t::ESTOP);
    estop.request_id = ++next_request_id_;
    estops.push_back(estop.request_id);
    ASSERT_TRUE(testing::SendUntil([&] { sender_->PublishMessage("ARM_COMMAND", estop); },
                                   [&] {
                                     const auto s = outputs_->Latest<state_t>("ARM_STATE");
                                     return s && s->mode == state_t::MODE_ESTOP;
                                   },
                                   kWait))
        << "estop " << round << " did not land";
  }
  flooding = false;
  flood.join();
  EXPECT_GT(flood_sent.load(), 0);
  // No estop was refused for lack of room (urgent commands never queue behind the flood).
  std::int64_t estop_replies = 0;
  for (const reply_t& r : outputs_->Decoded<reply_t>("ARM_REPLY")) {
    if (std::find(estops.begin(), estops.end(), r.request_id) == estops.end()) continue;
    ++estop_replies;
    EXPECT_EQ(r.reason.find("queue is full"), std::string::npos) << r.request_id << ": " << r.reason;
  }
  std::int64_t queue_full = 0;
  for (const reply_t& r : outputs_->Decoded<reply_t>("ARM_REPLY"))
    queue_full += r.reason == "the command queue is full";
  RecordProperty("queue_full_replies", static_cast<int>(queue_full));
  RecordProperty("estops", static_cast<int>(estops.size()));
  RecordProperty("estop_replies_received", static_cast<int>(estop_replies));
  RecordProperty("flood_commands_sent", static_cast<int>(flood_sent.load()));
  Stop();
}

TEST_F(Attack, ForeignPublisherIsCounted) {
  Start(7943);
  constexpr std::int64_t kForeignRunId = 0x0badc0de0badc0de;
  state_t spoof;
  spoof.utime = WallMicros();
  spoof.run_id = kForeignRunId;
  spoof.num_dofs = 0;
  spoof.controller = "pd";
  ASSERT_TRUE(testing::SendUntil([&] { sender_->PublishMessage("ARM_STATE", spoof); },
                                 [&] {
                                   const status_t s = LastStatus();
                                   return s.foreign_messages > 0 && s.last_foreign_run_id == kForeignRunId;
                                 },
                                 kWait))
      << "foreign_messages " << LastStatus().foreign_messages;
  // And its own messages are not: everything counted came from this test.
  const std::int64_t run_id = outputs_->Latest<state_t>("ARM_STATE").value_or(state_t{}).run_id;
  EXPECT_NE(run_id, kForeignRunId);
  EXPECT_EQ(LastStatus().run_id, run_id);
  Stop();
}

TEST_F(Attack, BusStringsAreEscapedInTheLog) {
  const fs::path log = fs::temp_directory_path() / ("lagrange_attack_escape_" + std::to_string(getpid()) + ".log");
  fs::remove(log);
  Start(7944, {"--log-file", log.string()});
  const std::string forged = "2026-01-01T00:00:00.000 info forged";
  const std::vector<std::pair<std::string, std::string>> names = {
      {"x\n" + forged, "x\\n" + forged},
      {"\x1b]0;pwned\x07", "\\x1b]0;pwned\\x07"},
  };
  for (const auto& [name, escaped] : names) {
    // Refusals are logged at most once a second, and a reply may be lost on the
    // way: resend until this one is in the log and its reply has come.
    command_t c = Command(command_t::SWITCH_CONTROLLER, name);
    c.request_id = ++next_request_id_;
    EXPECT_TRUE(testing::SendUntil([&] { sender_->PublishMessage("ARM_COMMAND", c); },
                                   [&] {
                                     return LogText(log).find("'" + escaped + "'") != std::string::npos &&
                                            FindReply(c.request_id).has_value();
                                   },
                                   kWait, 1.2))
        << LogText(log);
    const std::optional<reply_t> reply = FindReply(c.request_id);
    ASSERT_TRUE(reply.has_value());
    EXPECT_FALSE(reply->accepted);
    EXPECT_NE(reply->reason.find("'" + escaped + "'"), std::string::npos) << reply->reason;
  }
  Stop();
  for (const fs::path& file : {log, fs::path(log.string() + ".start")}) {
    const std::string text = LogText(file);
    EXPECT_EQ(text.find('\x1b'), std::string::npos) << file;
    EXPECT_EQ(text.find('\x07'), std::string::npos) << file;
    for (const std::string& line : testing::Lines(text)) {
      EXPECT_NE(line.rfind(forged, 0), 0u) << file << ": a forged line: " << line;
    }
  }
  fs::remove(log);
  fs::remove(log.string() + ".start");
}

TEST_F(AttackFlood, CommandRefusalFloodKeepsTheStartupLines) {
  const fs::path log = fs::temp_directory_path() / ("lagrange_attack_refusals_" + std::to_string(getpid()) + ".log");
  fs::remove(log);
  Start(7945, {"--log-file", log.string()});
  command_t c = Command(command_t::SWITCH_CONTROLLER, "nope");
  for (int k = 0; k < 50000; ++k) {
    c.request_id = ++next_request_id_;
    sender_->PublishMessage("ARM_COMMAND", c);
    if (k % 50 == 49) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(AwaitStatus([](const status_t& s) { return s.commands_rejected > 0; }));
  const double seconds = Stop();
  // The start-up record survives whatever came after it.
  const std::string start = LogText(log.string() + ".start");
  EXPECT_NE(start.find("instance(s) at 1000 Hz"), std::string::npos) << start;
  EXPECT_EQ(start.find("command rejected"), std::string::npos) << "FILE.start closes once the loop runs";
  // Refusals are logged at most once a second (the rest counted in the next line), so the
  // main log, never rotated by them, still holds the start-up lines too.
  const std::string text = LogText(log);
  EXPECT_NE(text.find("instance(s) at 1000 Hz"), std::string::npos);
  std::int64_t refusal_lines = 0;
  for (const std::string& line : testing::Lines(text))
    refusal_lines += line.find("command rejected") != std::string::npos;
  EXPECT_GE(refusal_lines, 1);
  EXPECT_LE(refusal_lines, static_cast<std::int64_t>(seconds) + 2) << "over " << seconds << " s";
  fs::remove(log);
  fs::remove(log.string() + ".start");
}

TEST_F(Attack, SeparateInputBusKeepsOutputsClean) {
  ASSERT_EQ(testing::PrepareLoopbackMulticast(7946), "");
  ASSERT_EQ(testing::PrepareLoopbackMulticast(7947), "");
  const std::string out_url = testing::TestLcmUrl(7946), in_url = testing::TestLcmUrl(7947);
  BusCollector outputs(out_url, kOutputChannels);
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", out_url, "--input-lcm-url", in_url});
  ASSERT_TRUE(testing::WaitUntil([&] { return outputs.Count("LAGRANGE_STATUS") >= 2; }, kWait)) << daemon.Stderr();
  std::unique_ptr<Bus> input = OpenBus(in_url);
  // A setpoint on the input bus moves the arm (its state on the output bus).
  const std::vector<double> target = {0.5, 0.4};
  EXPECT_TRUE(
      testing::SendUntil([&] { input->PublishMessage("ARM_SETPOINT", testing::MakeSetpoint(target, WallMicros())); },
                         [&] {
                           const auto s = outputs.Latest<state_t>("ARM_STATE");
                           return s && std::abs(s->q[0] - target[0]) < 1e-3 && std::abs(s->q[1] - target[1]) < 1e-3;
                         },
                         kWait, 0.1));
  // A malformed flood on the input bus: not LCM at all, LC02 garbage on our channels, bad setpoints.
  testing::RawUdpSender raw(testing::kTestLcmGroup, 7947);
  std::mt19937 rng{42};
  std::uniform_int_distribution<int> byte(0, 255), length(0, 300);
  for (int k = 0; k < 20000; ++k) {
    Bytes junk(static_cast<std::size_t>(length(rng)));
    for (auto& b : junk) b = static_cast<std::uint8_t>(byte(rng));
    if (k % 2 == 0) {
      raw.Send(junk);
    } else {
      input->Publish(k % 4 == 1 ? "ARM_SETPOINT" : "ARM_COMMAND", junk.data(), junk.size());
    }
    if (k % 50 == 49) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(outputs.WaitForLatest<status_t>(
      "LAGRANGE_STATUS", [](const status_t& s) { return s.decode_errors > 0 && s.datagrams_malformed > 0; }));
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(kWait), 0) << daemon.Stderr();
  // Every datagram on the output bus was a message on one of lagranged's own channels.
  const BusStats seen = outputs.stats();
  EXPECT_GT(seen.received, 0);
  EXPECT_EQ(seen.delivered, seen.received);
  EXPECT_EQ(seen.malformed + seen.oversized + seen.fragments_dropped, 0);
}

// ---------------------------------------------------------------- hostile switch commands

// True when every value is finite.
bool AllFinite(std::initializer_list<const std::vector<double>*> arrays, std::initializer_list<double> scalars = {}) {
  for (const std::vector<double>* a : arrays) {
    for (const double x : *a) {
      if (!std::isfinite(x)) return false;
    }
  }
  for (const double x : scalars) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}

bool Printable(const std::string& text) {
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7f) return false;
  }
  return true;
}

// A hostile switch command: a switch kind (now and then an unknown code), a
// setting (a valid name, one with junk after it, another kind's name, random
// bytes, or longer than the wire allows: `undecodable`), and numbers from the
// edges of their types, or all 0 (the defaults) so that many switches apply.
command_t HostileSwitch(std::mt19937& rng, std::int64_t request_id, bool& undecodable) {
  static const std::vector<std::string> kIntegrators = {"explicit-euler", "semi-implicit-euler", "rk4", "dopri5",
                                                        "variational"};
  static const std::vector<std::string> kEffects = {"gravity", "coriolis",   "damping",    "friction",
                                                    "limits",  "saturation", "disturbance"};
  static const std::vector<std::string> kMethods = {"closed-form", "lagrangian", "recursive"};
  static const std::vector<std::int8_t> kUnknownKinds = {0, 12, -1, 127};
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN(), kInf = std::numeric_limits<double>::infinity();
  constexpr std::int32_t kMax32 = std::numeric_limits<std::int32_t>::max(), kMin32 = -kMax32 - 1;
  static const std::vector<std::int32_t> kCounts = {1, 2, 4, 1000, 1001, -1, -5, 10000000, 10000001, kMax32, kMin32};
  static const std::vector<double> kNumbers = {
      -0.0, 1e-8, 1e-3, 1.0, 5e-324, 1e-300, -1.0, kNan, -kNan, kInf, -kInf, 1e308, std::numeric_limits<double>::max()};
  std::uniform_int_distribution<int> percent(0, 99);
  const auto pick = [&rng](const auto& v) {
    return v[std::uniform_int_distribution<std::size_t>(0, v.size() - 1)(rng)];
  };
  const int k = percent(rng);
  const std::int8_t kind = k < 40   ? command_t::SET_INTEGRATOR
                           : k < 60 ? command_t::SET_EFFECT
                           : k < 80 ? command_t::SET_METHOD
                           : k < 95 ? command_t::SET_FORCES
                                    : pick(kUnknownKinds);
  const std::vector<std::string>& names = kind == command_t::SET_EFFECT   ? kEffects
                                          : kind == command_t::SET_METHOD ? kMethods
                                                                          : kIntegrators;
  testing::SwitchFields f;
  const int how = percent(rng);
  undecodable = false;
  if (how < 60) {
    f.setting = pick(names);
  } else if (how < 68) {
    f.setting = pick(names) + (percent(rng) < 50 ? "\x1b[31m" : "\n2026-01-01T00:00:00.000 info forged");
  } else if (how < 74) {
    f.setting = pick(kEffects) + pick(kMethods);
  } else if (how < 97) {
    std::uniform_int_distribution<int> byte(1, 255);  // a NUL would end the string on the wire
    f.setting.resize(std::uniform_int_distribution<std::size_t>(0, 64)(rng));
    for (char& ch : f.setting) ch = static_cast<char>(byte(rng));
  } else {
    f.setting = std::string(300, 'x');  // over the 256 bytes a string may take: refused before decoding
    undecodable = true;
  }
  if (percent(rng) < 50) {  // hostile numbers; else all 0 (the defaults)
    f.substeps = pick(kCounts);
    f.rtol = pick(kNumbers);
    f.atol = pick(kNumbers);
    f.max_steps = pick(kCounts);
  }
  f.on = percent(rng) < 50;
  return testing::MakeSwitchCommand(kind, request_id, WallMicros(), std::move(f));
}

// Thousands of switches, most of them hostile, a few thousand valid ones
// flipping the integrator, method and effects back and forth, with resets
// (out of the faults that bad tolerances and explicit Euler cause) and a
// setpoint stream moving the arm: lagranged keeps ticking, publishes only
// finite states, answers each command at most once (refusals with a
// printable reason), counts what it refuses or does not answer, and afterwards
// runs exactly what the last valid switches set.
TEST_F(Attack, HostileSwitchCommandsAreRefusedAndNeverStopTheLoop) {
  Start(7770);
  std::mt19937 rng{42};
  constexpr int kCommands = 8000;
  constexpr int kPerMillisecond = 8;  // under the 32 a tick takes: most reach the tick
  const std::int64_t first_id = next_request_id_ + 1;
  std::int64_t sent = 0, undecodable = 0;
  auto next = std::chrono::steady_clock::now();
  for (int k = 0; k < kCommands; ++k) {
    bool bad = false;
    command_t c = HostileSwitch(rng, ++next_request_id_, bad);
    if (k % 500 == 250) {  // legal, and fails its first step: a fault, until the reset below
      c = testing::MakeSwitchCommand(command_t::SET_INTEGRATOR, next_request_id_, WallMicros(),
                                     {.setting = "dopri5", .rtol = 1e-300, .atol = 1e-300, .max_steps = 1});
      bad = false;
    }
    if (k % 500 == 499) {
      c = testing::MakeCommand(command_t::RESET, next_request_id_, WallMicros());
      bad = false;
    }
    sender_->PublishMessage("ARM_COMMAND", c);
    ++sent;
    undecodable += bad;
    if (k % 50 == 0) {
      const std::vector<double> target =
          (k / 50) % 2 == 0 ? std::vector<double>{0.5, 0.4} : std::vector<double>{-0.3, 0.8};
      sender_->PublishMessage("ARM_SETPOINT", testing::MakeSetpoint(target, WallMicros()));
    }
    if (k % kPerMillisecond == kPerMillisecond - 1) {
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
    }
  }
  const std::int64_t last_flood_id = next_request_id_;
  ASSERT_TRUE(daemon_->Running()) << daemon_->Stderr();
  const std::int64_t ticks_after_flood = LastStatus().ticks;

  // A known configuration, each switch resent until answered: every one applies.
  using testing::SwitchFields;
  const std::vector<std::pair<std::int8_t, SwitchFields>> settle = {
      {command_t::SET_INTEGRATOR, {.setting = "rk4", .substeps = 2}},
      {command_t::SET_EFFECT, {.setting = "coriolis", .on = true}},
      {command_t::SET_EFFECT, {.setting = "gravity", .on = true}},
      {command_t::SET_METHOD, {.setting = "closed-form"}},
      {command_t::SET_FORCES, {.setting = "", .on = true}},
  };
  for (const auto& [kind, fields] : settle) {
    const reply_t r = Request(testing::MakeSwitchCommand(kind, 0, WallMicros(), fields));
    EXPECT_TRUE(r.accepted) << fields.setting << ": " << r.reason;
  }
  const reply_t reset = Request(Command(command_t::RESET));
  EXPECT_TRUE(reset.accepted) << reset.reason;
  const std::int64_t requests = 1 + static_cast<std::int64_t>(settle.size());
  const auto most_sends_per_request = static_cast<std::int64_t>(kWait / 0.25) + 1;  // Request resends every 0.25 s

  // The loop still ticks and the status shows what the last switches set.
  EXPECT_TRUE(AwaitStatus([&](const status_t& s) {
    return s.ticks > ticks_after_flood + 500 && s.instance_integrators.size() == 2 &&
           s.instance_integrators[0] == "rk4 x2" && s.instance_methods[0] == "closed-form" &&
           s.instance_effects[0] == "gravity,coriolis" && s.instance_forces[0] != 0 &&
           s.instance_modes[0] == state_t::MODE_RUNNING;
  })) << "integrator '"
      << LastStatus().instance_integrators.at(0) << "', method '" << LastStatus().instance_methods.at(0)
      << "', effects '" << LastStatus().instance_effects.at(0) << "', mode "
      << static_cast<int>(LastStatus().instance_modes.at(0));
  EXPECT_TRUE(outputs_->WaitForLatest<telemetry_t>("ARM_TELEMETRY", [](const telemetry_t& m) {
    return m.integrator == "rk4" && m.substeps == 2 && m.evaluations == 8 && m.method == "closed-form" &&
           m.mode == state_t::MODE_RUNNING;
  }));
  EXPECT_TRUE(outputs_->WaitForLatest<forces_t>(
      "ARM_FORCES", [](const forces_t& f) { return f.num_dofs == 2 && f.gravity_on && f.coriolis_on; }));
  ASSERT_TRUE(daemon_->Running()) << daemon_->Stderr();

  // Replies: at most one per command; a refusal says why, printably.
  std::map<std::int64_t, int> replies_per_id;
  std::int64_t accepted = 0, refused = 0;
  for (const reply_t& r : outputs_->Decoded<reply_t>("ARM_REPLY")) {
    ++replies_per_id[r.request_id];
    (r.accepted ? accepted : refused) += 1;
    EXPECT_EQ(r.accepted, r.reason.empty()) << r.request_id << ": " << r.reason;
    EXPECT_TRUE(Printable(r.reason)) << r.request_id << ": " << r.reason;
  }
  std::int64_t flood_replies = 0;
  for (const auto& [id, count] : replies_per_id) {
    if (id < first_id || id > last_flood_id) continue;
    ++flood_replies;
    EXPECT_EQ(count, 1) << "request " << id << " answered " << count << " times";
  }
  EXPECT_GT(flood_replies, 0);
  EXPECT_GT(refused, 0);
  // Counted: a status published after every reply above was sent holds them
  // all, and each command decoded was answered or counted as not answered.
  const std::int64_t ticks_now = LastStatus().ticks;
  ASSERT_TRUE(AwaitStatus([&](const status_t& s) { return s.ticks > ticks_now + 300; }));
  const status_t s = LastStatus();
  EXPECT_GE(s.commands_rejected, refused);
  EXPECT_GE(s.commands_accepted, accepted);
  const std::int64_t decided = s.commands_accepted + s.commands_rejected;
  EXPECT_GE(decided, accepted + refused + s.replies_suppressed) << "a verdict neither sent nor counted";
  EXPECT_LE(decided, sent - undecodable + requests * most_sends_per_request) << "more verdicts than commands";
  EXPECT_GT(s.decode_errors, 0);
  EXPECT_LE(s.decode_errors, undecodable);
  EXPECT_TRUE(Printable(s.last_command_error)) << s.last_command_error;
  RecordProperty("commands_sent", static_cast<int>(sent));
  RecordProperty("commands_accepted", static_cast<int>(s.commands_accepted));
  RecordProperty("commands_rejected", static_cast<int>(s.commands_rejected));
  RecordProperty("replies_suppressed", static_cast<int>(s.replies_suppressed));

  // Every state, telemetry and forces message of this run was finite.
  const std::int64_t run_id = s.run_id;
  std::int64_t states = 0, faulted = 0;
  for (const std::string channel : {"ARM_STATE", "CARTPOLE_STATE"}) {
    for (const state_t& st : outputs_->Decoded<state_t>(channel)) {
      if (st.run_id != run_id) continue;
      ++states;
      faulted += st.mode == state_t::MODE_FAULT;
      EXPECT_TRUE(AllFinite({&st.q, &st.qd, &st.qdd, &st.tau, &st.q_des, &st.qd_des},
                            {st.t, st.kinetic_energy, st.potential_energy}))
          << channel << " tick " << st.tick << " mode " << static_cast<int>(st.mode);
    }
  }
  EXPECT_GT(states, 0);
  EXPECT_GT(faulted, 0) << "the failing dopri5 never faulted the arm";
  RecordProperty("states_in_fault", static_cast<int>(faulted));
  for (const telemetry_t& m : outputs_->Decoded<telemetry_t>("ARM_TELEMETRY")) {
    EXPECT_TRUE(AllFinite({}, {m.t, m.energy, m.energy_residual, m.quadrature_bound, m.work, m.power, m.error_estimate,
                               m.step, m.compute_us}))
        << "tick " << m.tick << " integrator " << m.integrator << " mode " << static_cast<int>(m.mode);
  }
  for (const forces_t& f : outputs_->Decoded<forces_t>("ARM_FORCES")) {
    EXPECT_TRUE(AllFinite(
        {&f.gravity, &f.coriolis, &f.damping, &f.friction, &f.limits, &f.disturbance, &f.tau_cmd, &f.tau_applied}))
        << "tick " << f.tick;
  }
  Stop();
}

// ---------------------------------------------------------------- a flood of clears (issue 32)

constexpr double kEstopDwell = 0.5;        // s: the default scene's (the scene reader's default) estop_dwell
constexpr std::int64_t kUtimeSlack = 1000;  // µs: a state's utime is read a few µs before its tick's clock

// Sends clear_estop to the arm from a thread of its own, every 0.2 ms, under
// fresh request ids, until destroyed: anyone on an unsigned bus can.
class ClearFlood {
 public:
  explicit ClearFlood(const std::string& url) {
    thread_ = std::thread([this, url] {
      std::unique_ptr<Bus> bus = OpenBus(url);
      command_t c{};
      c.command = command_t::CLEAR_ESTOP;
      for (std::int64_t k = 1; !stop_; ++k) {
        c.utime = WallMicros();
        c.request_id = 0x0c1ea2000000 + k;
        bus->PublishMessage("ARM_COMMAND", c);
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    });
  }
  ~ClearFlood() {
    stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// The arm's states of one run from its first estop on: the first in estop
// and the first after it that was not.
std::pair<std::optional<state_t>, std::optional<state_t>> EstopSpan(const std::vector<state_t>& states) {
  std::optional<state_t> first, left;
  for (const state_t& s : states) {
    if (!first && s.mode == state_t::MODE_ESTOP) first = s;
    if (first && !left && s.run_id == first->run_id && s.tick > first->tick && s.mode != state_t::MODE_ESTOP) left = s;
  }
  return {first, left};
}

// Issue 32: an estop lasted one tick against a flood of clears (on an
// unsigned bus anyone can send them; on a signed one any key holder). Now it
// lasts the scene's estop_dwell whatever clears arrive, lagrangectl says it
// stayed, and the flood ends it only once the dwell is over (into hold),
// as the daemon's own state timestamps show.
TEST_F(Attack, AFloodOfClearsCannotShortenAnEstopBelowItsDwell) {
  Start(8554);
  ClearFlood flood(url_);
  const testing::ProcessResult r = testing::RunProcess({LAGRANGECTL_PATH, "command", "arm", "estop", "--lcm-url", url_});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_EQ(r.out.rfind("arm: estop done; now estop with computed-torque", 0), 0u) << r.out << r.err;
  ASSERT_TRUE(outputs_->WaitForLatest<state_t>("ARM_STATE", [](const state_t& s) {
    return s.mode == state_t::MODE_HOLD;
  })) << "the flood of clears never ended the estop";
  const auto [estop, left] = EstopSpan(outputs_->Decoded<state_t>("ARM_STATE"));
  ASSERT_TRUE(estop && left);
  EXPECT_EQ(left->mode, state_t::MODE_HOLD);
  EXPECT_GE(left->utime - estop->utime, static_cast<std::int64_t>(kEstopDwell * 1e6) - kUtimeSlack)
      << "the estop lasted ticks " << estop->tick << " to " << left->tick;
  Stop();
}

// The client's check: a scene with no dwell (estop_dwell: 0) under the same
// flood loses its estop the tick after it landed, and lagrangectl says so
// and exits 1 instead of "done".
TEST_F(Attack, LagrangectlExitsOneWhenAnEstopDidNotStay) {
  const fs::path scene = fs::temp_directory_path() / ("lagrange_no_dwell_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(scene) << R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.7853981633974483, 0.0]}
    controller: {type: computed-torque, kp: 100, kd: 20}
    estop_dwell: 0
)";
  Start(8555, {"--config", scene.string()});
  ClearFlood flood(url_);
  const testing::ProcessResult r = testing::RunProcess({LAGRANGECTL_PATH, "command", "arm", "estop", "--lcm-url", url_});
  fs::remove(scene);
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_EQ(r.out.find("done"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("estop applied, but the estop did not stay: hold with computed-torque"), std::string::npos)
      << r.err;
  Stop();
}

}  // namespace
}  // namespace lagrange
