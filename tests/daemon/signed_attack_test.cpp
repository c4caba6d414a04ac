// The attacks of issue 21 against a live lagranged whose bus is signed
// (--bus-key, protocol/signing.hpp): a process without the key forges
// setpoints, commands, torques and measured states as raw datagrams
// (unsigned, or signed with another key), replays a key holder's datagram
// captured off the bus, or answers lagrangectl with forged states and
// replies. Each moves nothing, and the daemon counts it on its channel in the
// status. A key holder's messages are still obeyed (the control that proves
// the test could see an effect). The same attacks without a key are
// attack_test.cpp's. Private ports 8101-8106, 8109, 8110, 8112 and 8113 (8107-8108: logs_test.cpp); nothing here measures time.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/torque_t.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "protocol/bus.hpp"
#include "protocol/signing.hpp"
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

constexpr double kWait = 30.0;                        // s: bound on waiting for an effect; a pass takes far less
constexpr double kQ0[2] = {0.7853981633974483, 0.0};  // config/default.yaml's arm, held while no setpoint comes
constexpr double kHeld = 1e-3;                        // rad: the arm held at q0 under computed torque stays this close
constexpr double kBounded = 3.0;  // rad, rad/s: an external loop that was not taken over stays well within

// An LC02 datagram carrying `payload` on `channel`, as any sender could write it.
Bytes Datagram(const std::string& channel, const Bytes& payload) {
  Bytes out(payload.size() + 128);
  std::size_t written = 0;
  FormatDatagram(7, channel, payload.data(), payload.size(), out.data(), out.size(), written);
  out.resize(written);
  return out;
}

// `payload` followed by a signature trailer made with `signer`.
Bytes SignedBy(Signer& signer, const std::string& channel, Bytes payload) {
  const std::size_t n = payload.size();
  payload.resize(n + kSignatureTrailerBytes);
  signer.Sign(channel, payload.data(), n, payload.data() + n);
  return payload;
}

BusKey MakeKey(const fs::path& path) {
  WriteNewBusKey(path.string());
  return BusKey::FromFile(path.string());
}

// Listens on a signed bus, on its own thread, keeping the latest state per
// channel and the latest status per first instance name.
class SignedObserver {
 public:
  SignedObserver(const std::string& url, const BusKey& key, const std::vector<std::string>& state_channels)
      : bus_(OpenBus(url, &key)) {
    for (const std::string& channel : state_channels) {
      bus_->Subscribe(channel, [this](std::string_view name, const std::uint8_t* d, std::size_t n) {
        state_t s;
        if (s.decode(d, 0, static_cast<int>(n)) != static_cast<int>(n)) return;
        std::lock_guard<std::mutex> lock(mutex_);
        for (int i = 0; i < s.num_dofs; ++i) {
          max_abs_ = std::max(
              {max_abs_, std::abs(s.q[static_cast<std::size_t>(i)]), std::abs(s.qd[static_cast<std::size_t>(i)])});
        }
        states_[std::string(name)] = std::move(s);
      });
    }
    bus_->Subscribe("LAGRANGE_STATUS", [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      status_t s;
      if (s.decode(d, 0, static_cast<int>(n)) != static_cast<int>(n) || s.num_instances < 1) return;
      std::lock_guard<std::mutex> lock(mutex_);
      statuses_[s.instance_names[0]] = std::move(s);
    });
    thread_ = std::thread([this] {
      while (!stop_) bus_->Handle(20);
    });
  }
  ~SignedObserver() {
    stop_ = true;
    thread_.join();
  }
  std::optional<state_t> State(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = states_.find(channel);
    return it == states_.end() ? std::nullopt : std::optional<state_t>(it->second);
  }
  std::optional<status_t> Status(const std::string& first_instance) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = statuses_.find(first_instance);
    return it == statuses_.end() ? std::nullopt : std::optional<status_t>(it->second);
  }
  // The largest |q| or |q̇| of any state seen.
  double max_abs() {
    std::lock_guard<std::mutex> lock(mutex_);
    return max_abs_;
  }
  Bus& bus() { return *bus_; }

 private:
  std::unique_ptr<Bus> bus_;
  std::mutex mutex_;
  std::map<std::string, state_t> states_;
  std::map<std::string, status_t> statuses_;
  double max_abs_ = 0.0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// The messages a status says it refused on `channel` for their signature.
std::int64_t RefusedOn(const status_t& s, const std::string& channel) {
  for (std::size_t k = 0; k < s.unauthenticated_channels.size(); ++k) {
    if (s.unauthenticated_channels[k] == channel) return s.unauthenticated_counts[k];
  }
  return 0;
}

class SignedAttack : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_signed_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    key_path_ = (dir_ / "bus.key").string();
    key_.emplace(MakeKey(key_path_));
    other_key_.emplace(MakeKey(dir_ / "other.key"));
  }
  void TearDown() override { fs::remove_all(dir_); }

  void Prepare(int port) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    port_ = port;
    url_ = testing::TestLcmUrl(port);
    raw_ = std::make_unique<testing::RawUdpSender>(testing::kTestLcmGroup, port);
  }
  std::unique_ptr<BackgroundProcess> Lagranged(const std::string& scene = "") {
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_, "--bus-key", key_path_, "--log-level", "warn"};
    if (!scene.empty()) argv.insert(argv.end(), {"--config", std::string(LAGRANGE_SOURCE_DIR) + "/config/" + scene});
    return std::make_unique<BackgroundProcess>(argv);
  }
  // `payload` on `channel` from a process without the key: unsigned, and signed with another key.
  void Forge(const std::string& channel, const Bytes& payload) {
    raw_->Send(Datagram(channel, payload));
    Signer forger(*other_key_);
    raw_->Send(Datagram(channel, SignedBy(forger, channel, payload)));
  }
  static void Stop(BackgroundProcess& daemon) {
    daemon.Signal(SIGTERM);
    EXPECT_EQ(daemon.Wait(60.0), 0) << daemon.Stderr();
  }

  fs::path dir_;
  std::string key_path_;
  std::optional<BusKey> key_, other_key_;
  int port_ = 0;
  std::string url_;
  std::unique_ptr<testing::RawUdpSender> raw_;
};

TEST_F(SignedAttack, ForgedSetpointsAndCommandsMoveNothingAndAreCountedOnTheirChannels) {
  Prepare(8101);
  auto daemon = Lagranged();
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil([&] { return observer.Status("arm").has_value(); }, kWait)) << daemon->Stderr();

  // A setpoint far from q0, and an estop, pause and controller switch, until the daemon has counted them.
  const std::vector<Bytes> commands = {
      testing::Encode(testing::MakeCommand(command_t::ESTOP, 0x8101001, WallMicros())),
      testing::Encode(testing::MakeCommand(command_t::PAUSE, 0x8101002, WallMicros()))};
  EXPECT_TRUE(testing::SendUntil(
      [&] {
        Forge("ARM_SETPOINT", testing::Encode(testing::MakeSetpoint({2.0, 1.0}, WallMicros())));
        for (const Bytes& c : commands) Forge("ARM_COMMAND", c);
      },
      [&] {
        const auto s = observer.Status("arm");
        return s && RefusedOn(*s, "ARM_SETPOINT") >= 2 && RefusedOn(*s, "ARM_COMMAND") >= 4;
      },
      kWait));
  const status_t s = *observer.Status("arm");
  EXPECT_TRUE(s.bus_signed);
  EXPECT_GE(s.datagrams_unauthenticated, 6);
  EXPECT_EQ(s.setpoints_accepted, 0);
  EXPECT_EQ(s.setpoints_rejected, 0) << "dropped by the bus, never reaching the checks";
  EXPECT_EQ(s.commands_accepted, 0);
  EXPECT_EQ(s.commands_rejected, 0);
  EXPECT_EQ(s.decode_errors, 0);
  EXPECT_EQ(s.instance_modes[0], state_t::MODE_RUNNING);
  const auto arm = observer.State("ARM_STATE");
  ASSERT_TRUE(arm);
  EXPECT_EQ(arm->mode, state_t::MODE_RUNNING);
  EXPECT_NEAR(arm->q[0], kQ0[0], kHeld);
  EXPECT_NEAR(arm->q[1], kQ0[1], kHeld);

  // The control: the same setpoint from a key holder moves the arm.
  EXPECT_TRUE(testing::SendUntil(
      [&] {
        observer.bus().PublishMessage("ARM_SETPOINT", testing::MakeSetpoint({1.0, 0.5}, WallMicros()));
      },
      [&] {
        const auto st = observer.State("ARM_STATE");
        return st && std::abs(st->q[0] - 1.0) < 0.05;
      },
      kWait));
  Stop(*daemon);
}

TEST_F(SignedAttack, ACapturedSignedCommandReplayedAndAStaleOneAreDroppedAndCounted) {
  Prepare(8102);
  auto daemon = Lagranged();
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil([&] { return observer.State("ARM_STATE").has_value(); }, kWait)) << daemon->Stderr();

  // A key holder's pause, exactly as it went over the wire: it is obeyed.
  Signer holder(*key_);
  const Bytes pause = testing::Encode(testing::MakeCommand(command_t::PAUSE, 0x8102001, WallMicros()));
  const Bytes captured = Datagram("ARM_COMMAND", SignedBy(holder, "ARM_COMMAND", pause));
  ASSERT_TRUE(testing::SendUntil([&] { raw_->Send(captured); },
                                 [&] {
                                   const auto st = observer.State("ARM_STATE");
                                   return st && st->mode == state_t::MODE_PAUSED;
                                 },
                                 kWait));
  // Resumed by the key holder; then the captured pause replayed (at once), and one signed 10 s ago.
  ASSERT_TRUE(testing::SendUntil(
      [&] {
        observer.bus().PublishMessage("ARM_COMMAND", testing::MakeCommand(command_t::RESUME, 0x8102002, WallMicros()));
      },
      [&] {
        const auto st = observer.State("ARM_STATE");
        return st && st->mode == state_t::MODE_RUNNING;
      },
      kWait));
  Signer recorded(*key_, 0, [] { return WallMicros() - 10'000'000; });
  const Bytes stale =
      Datagram("ARM_COMMAND",
               SignedBy(recorded, "ARM_COMMAND",
                        testing::Encode(testing::MakeCommand(command_t::PAUSE, 0x8102003, WallMicros() - 10'000'000))));
  EXPECT_TRUE(testing::SendUntil(
      [&] {
        raw_->Send(captured);
        raw_->Send(stale);
      },
      [&] {
        const auto s = observer.Status("arm");
        return s && RefusedOn(*s, "ARM_COMMAND") >= 2;
      },
      kWait));
  const status_t s = *observer.Status("arm");
  EXPECT_EQ(s.instance_modes[0], state_t::MODE_RUNNING);
  EXPECT_EQ(s.commands_accepted, 2) << "the pause and the resume, once each";
  EXPECT_EQ(observer.State("ARM_STATE")->mode, state_t::MODE_RUNNING);
  Stop(*daemon);
}

TEST_F(SignedAttack, ForgedTorquesAndMeasuredStatesCannotTakeOverTheExternalLoop) {
  Prepare(8103);
  auto plant = Lagranged("arm_external_controller.yaml");  // the simulated arm, torques from ARM_TORQUE
  auto controller = Lagranged("arm_external_plant.yaml");  // computed torque for it, states from ARM_STATE
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil(
      [&] {
        const auto p = observer.Status("arm"), c = observer.Status("arm_controller");
        return p && c && p->instance_modes[0] == state_t::MODE_RUNNING &&
               c->instance_modes[0] == state_t::MODE_RUNNING && p->torques_accepted > 0;
      },
      kWait))
      << plant->Stderr() << controller->Stderr();
  const std::int64_t plant_run = observer.State("ARM_STATE")->run_id;

  // Full torque under a run id of its own and under the plant's; states far away under the plant's run id.
  std::int64_t sequence = 1'000'000'000;
  EXPECT_TRUE(testing::SendUntil(
      [&] {
        for (int k = 0; k < 20; ++k) {
          for (const std::int64_t run : {std::int64_t{0x0bad}, plant_run}) {
            torque_t t{};
            t.utime = WallMicros();
            t.run_id = run;
            t.sequence = ++sequence;
            t.state_tick = observer.State("ARM_STATE")->tick;
            t.num_dofs = 2;
            t.tau = {40.0, 15.0};
            Forge("ARM_TORQUE", testing::Encode(t));
          }
          state_t forged = testing::MakeState(observer.State("ARM_STATE")->tick + 1'000'000, plant_run);
          forged.utime = WallMicros();
          forged.q = {-2.5, 2.5};
          Forge("ARM_STATE", testing::Encode(forged));
        }
      },
      [&] {
        const auto p = observer.Status("arm"), c = observer.Status("arm_controller");
        return p && c && RefusedOn(*p, "ARM_TORQUE") >= 80 && RefusedOn(*c, "ARM_STATE") >= 40 &&
               RefusedOn(*p, "ARM_STATE") >= 40;
      },
      kWait));
  const status_t p = *observer.Status("arm"), c = *observer.Status("arm_controller");
  EXPECT_EQ(p.instance_modes[0], state_t::MODE_RUNNING);
  EXPECT_EQ(c.instance_modes[0], state_t::MODE_RUNNING) << c.instance_reasons[0];
  EXPECT_EQ(p.torques_rejected, 0) << "dropped by the bus, before the torque checks";
  EXPECT_EQ(c.measured_rejected, 0) << "no second source ever reached the controller";
  EXPECT_LT(observer.max_abs(), kBounded) << "the arm stayed under its own controller";
  Stop(*controller);
  Stop(*plant);
}

TEST_F(SignedAttack, TheExampleClientWithTheKeyClosesTheLoopOnASignedDaemon) {
  Prepare(8109);
  auto daemon = Lagranged("arm_impedance_client.yaml");
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil([&] { return observer.State("ARM_STATE").has_value(); }, kWait)) << daemon->Stderr();
  BackgroundProcess client({IMPEDANCE_CLIENT_PATH, "--lcm-url", url_, "--target", "0.3,0.6", "--bus-key", key_path_});
  constexpr double kNear = 1e-2;  // rad: on its way to the target under the client's torques
  EXPECT_TRUE(testing::WaitUntil(
      [&] {
        const auto s = observer.State("ARM_STATE");
        return s && s->mode == state_t::MODE_RUNNING && s->controller == "external" &&
               std::abs(s->q[0] - 0.3) < kNear && std::abs(s->q[1] - 0.6) < kNear;
      },
      kWait))
      << client.Stderr();
  const auto status = observer.Status("arm");
  ASSERT_TRUE(status);
  EXPECT_GT(status->torques_accepted, 0);
  EXPECT_TRUE(client.Running()) << client.Stderr();
  Stop(*daemon);
}

// lagrangectl with the key, run as a process against forgers without it.
std::string LagrangectlPath() { return LAGRANGECTL_PATH; }

TEST_F(SignedAttack, LagrangectlWithTheKeyIgnoresForgedStatesAndRepliesWhenNoDaemonRuns) {
  Prepare(8104);
  std::atomic<bool> stop{false};
  // A forger on the bus: states of a made-up run, and "accepted" to every command it sees.
  std::thread forger([&] {
    std::unique_ptr<Bus> bus = OpenBus(url_);
    std::int64_t tick = 0;
    bus->Subscribe("ARM_COMMAND", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
      command_t c;
      if (c.decode(d, 0, static_cast<int>(n)) < 0) return;
      reply_t r{};
      r.utime = WallMicros();
      r.run_id = 0x0bad;
      r.request_id = c.request_id;
      r.command = c.command;
      r.accepted = true;
      Forge("ARM_REPLY", testing::Encode(r));
    });
    while (!stop) {
      state_t s = testing::MakeState(++tick, 0x0bad);
      s.utime = WallMicros();
      Forge("ARM_STATE", testing::Encode(s));
      bus->Handle(2);
    }
  });
  const testing::ProcessResult r = testing::RunProcess(
      {LagrangectlPath(), "command", "arm", "estop", "--lcm-url", url_, "--bus-key", key_path_, "--wait", "1"});
  stop = true;
  forger.join();
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_EQ(r.out.find("done"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("no state from instance 'arm'"), std::string::npos) << r.err;
}

TEST_F(SignedAttack, AForgedRefusalDoesNotMakeLagrangectlReportAnAppliedEstopAsRefused) {
  Prepare(8105);
  auto daemon = Lagranged();
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil([&] { return observer.State("ARM_STATE").has_value(); }, kWait)) << daemon->Stderr();
  const std::int64_t run = observer.State("ARM_STATE")->run_id;
  std::atomic<bool> stop{false};
  // The forger reads each command off the bus (it is not encrypted) and answers at once, under the daemon's run id.
  std::thread forger([&] {
    std::unique_ptr<Bus> bus = OpenBus(url_);
    bus->Subscribe("ARM_COMMAND", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
      command_t c;
      if (c.decode(d, 0, static_cast<int>(n)) < 0) return;
      reply_t r{};
      r.utime = WallMicros();
      r.run_id = run;
      r.request_id = c.request_id;
      r.command = c.command;
      r.accepted = false;
      r.reason = "forged refusal";
      for (int k = 0; k < 3; ++k) Forge("ARM_REPLY", testing::Encode(r));
    });
    while (!stop) bus->Handle(5);
  });
  const testing::ProcessResult r =
      testing::RunProcess({LagrangectlPath(), "command", "arm", "estop", "--lcm-url", url_, "--bus-key", key_path_});
  stop = true;
  forger.join();
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("estop done"), std::string::npos) << r.out;
  EXPECT_EQ((r.out + r.err).find("forged refusal"), std::string::npos);
  EXPECT_TRUE(testing::WaitUntil(
      [&] {
        const auto s = observer.Status("arm");
        return s && RefusedOn(*s, "ARM_REPLY") > 0 && s->instance_modes[0] == state_t::MODE_ESTOP;
      },
      kWait))
      << "the daemon counts the forged replies on its own output channel";
  Stop(*daemon);
}

// A flood of CLEAR_ESTOP from a process without the key (unsigned, and signed
// with another key) cannot undo a key holder's estop; the key holder's own
// clear does (into hold, never straight back to running).
TEST_F(SignedAttack, AFloodOfForgedClearsCannotUndoAKeyHoldersEstop) {
  Prepare(8112);
  auto daemon = Lagranged();
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil([&] { return observer.State("ARM_STATE").has_value(); }, kWait)) << daemon->Stderr();
  std::atomic<bool> stop{false};
  std::thread flood([&] {
    for (std::int64_t k = 0; !stop; ++k) {
      Forge("ARM_COMMAND", testing::Encode(testing::MakeCommand(command_t::CLEAR_ESTOP, 0x8112000 + k, WallMicros())));
    }
  });
  EXPECT_TRUE(testing::SendUntil(
      [&] { observer.bus().PublishMessage("ARM_COMMAND", testing::MakeCommand(command_t::ESTOP, 0x8112, WallMicros())); },
      [&] {
        const auto st = observer.State("ARM_STATE");
        return st && st->mode == state_t::MODE_ESTOP;
      },
      kWait));
  // The flood goes on until the daemon has counted a thousand more forged clears; the arm stays stopped.
  const auto refused_then = observer.Status("arm");
  const std::int64_t before = refused_then ? RefusedOn(*refused_then, "ARM_COMMAND") : 0;
  EXPECT_TRUE(testing::WaitUntil(
      [&] {
        const auto st = observer.Status("arm");
        return st && RefusedOn(*st, "ARM_COMMAND") >= before + 1000;
      },
      kWait));
  stop = true;
  flood.join();
  const auto st = observer.State("ARM_STATE");
  ASSERT_TRUE(st);
  EXPECT_EQ(st->mode, state_t::MODE_ESTOP);
  const auto status = observer.Status("arm");
  ASSERT_TRUE(status);
  EXPECT_EQ(status->instance_modes[0], state_t::MODE_ESTOP);
  EXPECT_EQ(status->commands_rejected, 0) << "dropped by the bus, never reaching the tick";
  // The control: the key holder's clear leaves the estop, into hold.
  EXPECT_TRUE(testing::SendUntil(
      [&] {
        observer.bus().PublishMessage("ARM_COMMAND",
                                      testing::MakeCommand(command_t::CLEAR_ESTOP, 0x8112001, WallMicros()));
      },
      [&] {
        const auto now = observer.State("ARM_STATE");
        return now && now->mode != state_t::MODE_ESTOP;
      },
      kWait));
  EXPECT_EQ(observer.State("ARM_STATE")->mode, state_t::MODE_HOLD);
  Stop(*daemon);
}

// The lies to the operator's tools, told by a process without the key
// under the daemon's run id: "accepted" for a refused gain command, a start
// state at (−2.5, 2.5) for send --min-jerk, and a status saying no setpoint
// arrived. lagrangectl with the key believes none of them.
TEST_F(SignedAttack, ForgedVerdictsStartStatesAndStatusesDoNotFoolLagrangectlWithTheKey) {
  Prepare(8113);
  auto daemon = Lagranged();
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil([&] { return observer.State("ARM_STATE").has_value(); }, kWait)) << daemon->Stderr();
  const state_t real = *observer.State("ARM_STATE");
  std::atomic<bool> stop{false};
  std::thread forger([&] {
    std::unique_ptr<Bus> bus = OpenBus(url_);
    bus->Subscribe("ARM_COMMAND", [&](std::string_view, const std::uint8_t* d, std::size_t n) {
      command_t c;
      if (c.decode(d, 0, static_cast<int>(n)) < 0) return;
      reply_t r{};
      r.utime = WallMicros();
      r.run_id = real.run_id;
      r.request_id = c.request_id;
      r.command = c.command;
      r.accepted = true;
      for (int k = 0; k < 3; ++k) Forge("ARM_REPLY", testing::Encode(r));
    });
    state_t lie = real;
    lie.q = {-2.5, 2.5};
    status_t none{};
    none.run_id = real.run_id;
    none.num_instances = 1;
    none.instance_names = {"arm"};
    none.instance_modes = {state_t::MODE_RUNNING};
    none.instance_dofs = {2};
    none.instance_reasons = none.instance_integrators = none.instance_methods = none.instance_effects = {""};
    none.instance_forces = {0};
    for (std::int64_t k = 1; !stop; ++k) {
      lie.tick = real.tick + 1'000'000 + k;
      lie.utime = none.utime = WallMicros();
      Forge("ARM_STATE", testing::Encode(lie));
      Forge("LAGRANGE_STATUS", testing::Encode(none));
      bus->Handle(1);
    }
  });
  // Kp h² = 1e9 × 1e-6 > 1: the daemon refuses; the forged acceptance must not turn that into "done".
  const testing::ProcessResult gains = testing::RunProcess({LagrangectlPath(), "command", "arm", "gains", "--kp", "1e9",
                                                            "--kd", "1", "--lcm-url", url_, "--bus-key", key_path_});
  EXPECT_EQ(gains.exit_code, 1) << gains.out << gains.err;
  EXPECT_NE(gains.err.find("refused"), std::string::npos) << gains.err;
  EXPECT_EQ(gains.out.find("done"), std::string::npos) << gains.out;
  // The plan starts from the real state (q ≈ (π/4, 0)), and the real status's count is the one reported.
  const testing::ProcessResult send = testing::RunProcess({LagrangectlPath(), "send", "arm", "--min-jerk", "0.5", "--q",
                                                           "0.9,0.1", "--lcm-url", url_, "--bus-key", key_path_});
  stop = true;
  forger.join();
  EXPECT_EQ(send.exit_code, 0) << send.out << send.err;
  EXPECT_NE(send.out.find("lagranged accepted"), std::string::npos) << send.out;
  EXPECT_EQ((send.out + send.err).find("none of"), std::string::npos) << send.err;
  EXPECT_LT(observer.max_abs(), 2.0) << "a plan from (-2.5, 2.5) would swing the arm through |q| 2.5 at |q̇| ~17 rad/s";
  const auto s = observer.Status("arm");
  ASSERT_TRUE(s);
  EXPECT_GT(RefusedOn(*s, "ARM_STATE"), 0);
  EXPECT_GT(RefusedOn(*s, "LAGRANGE_STATUS"), 0);
  Stop(*daemon);
}

TEST_F(SignedAttack, LagrangectlWithoutTheKeyActsOnNothingAndSaysTheStatesAreSigned) {
  Prepare(8110);
  auto daemon = Lagranged();
  SignedObserver observer(url_, *key_, {"ARM_STATE"});
  ASSERT_TRUE(testing::WaitUntil([&] { return observer.State("ARM_STATE").has_value(); }, kWait)) << daemon->Stderr();
  const testing::ProcessResult r =
      testing::RunProcess({LagrangectlPath(), "command", "arm", "pause", "--lcm-url", url_, "--wait", "1"});
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("are signed; give the daemon's key (--bus-key FILE or LAGRANGE_BUS_KEY_FILE)"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(observer.State("ARM_STATE")->mode, state_t::MODE_RUNNING);
  Stop(*daemon);
}

TEST_F(SignedAttack, ADaemonWithAKeyReadableByOthersOrOfTheWrongSizeRefusesToStart) {
  Prepare(8106);
  const fs::path open = dir_ / "open.key";
  fs::copy_file(key_path_, open);
  fs::permissions(open, fs::perms::owner_read | fs::perms::group_read);
  const testing::ProcessResult r =
      testing::RunProcess({LAGRANGED_PATH, "--lcm-url", url_, "--bus-key", open.string(), "--duration", "0.1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("bus key " + open.string() + ": readable by group or others (mode 0440)"), std::string::npos)
      << r.err;
  const fs::path short_key = dir_ / "short.key";
  testing::RunProcess(
      {"/bin/sh", "-c", "printf 0123456789 > " + short_key.string() + "; chmod 600 " + short_key.string()});
  const testing::ProcessResult s =
      testing::RunProcess({LAGRANGED_PATH, "--lcm-url", url_, "--bus-key", short_key.string(), "--duration", "0.1"});
  EXPECT_EQ(s.exit_code, 2);
  EXPECT_NE(s.err.find("bus key " + short_key.string() + ": 10 bytes"), std::string::npos) << s.err;
}

}  // namespace
}  // namespace lagrange
