// lagranged running a mujoco plant as a separate process on a private LCM
// port: the Panda on MuJoCo follows a stream of setpoints sent by another
// process, publishes only finite states, and stops with exit 0. Only what a
// loaded machine cannot break is asserted (lagranged_test.cpp's rules).

#include <gtest/gtest.h>
#include <signal.h>
#include <lagrange/base_state_t.hpp>
#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tests/support/lcm_messages.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"

namespace lagrange {
namespace {

using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::WallMicros;

constexpr double kWait = 30.0;     // s: bound on waiting for an effect; a pass takes far less
constexpr double kSettled = 2e-3;  // rad: the arm at its setpoint

bool Finite(const state_t& s) {
  bool ok = std::isfinite(s.t) && std::isfinite(s.kinetic_energy) && std::isfinite(s.potential_energy);
  for (const auto* v : {&s.q, &s.qd, &s.qdd, &s.tau}) {
    for (const double x : *v) ok = ok && std::isfinite(x);
  }
  return ok;
}

TEST(MujocoLive, LagrangedRunsThePandaOnMujocoUnderASetpointStream) {
  const int port = 8401;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
  const std::string url = testing::TestLcmUrl(port);
  LcmCollector collector(url);
  BackgroundProcess daemon(
      {LAGRANGED_PATH, "--lcm-url", url, "--config", std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mujoco_minjerk.yaml"});
  ASSERT_TRUE(collector.WaitFor("PANDA_STATE", [](const auto& m) { return m.size() >= 100; }, kWait))
      << daemon.Stderr();
  // A stream: a setpoint per few milliseconds, moving from the ready pose towards the target, then holding it.
  const std::vector<double> start = {0, -0.785, 0, -2.356, 0, 1.571, 0.785};
  const std::vector<double> target = {0.2, -0.6, 0.1, -2.1, 0.0, 1.7, 0.5};
  lcm::LCM sender(url);
  int sent = 0;
  const bool reached = testing::SendUntil(
      [&] {
        const double s = std::min(1.0, sent++ / 100.0);
        std::vector<double> q(7);
        for (std::size_t i = 0; i < 7; ++i) q[i] = start[i] + s * (target[i] - start[i]);
        const setpoint_t sp = testing::MakeSetpoint(q, WallMicros());
        sender.publish("PANDA_SETPOINT", &sp);
      },
      [&] {
        const auto states = collector.Decoded<state_t>("PANDA_STATE");
        if (states.empty() || states.back().q_des != target) return false;
        double err = 0.0;
        for (std::size_t i = 0; i < 7; ++i) err = std::max(err, std::abs(states.back().q[i] - target[i]));
        return err < kSettled;
      },
      kWait, /*every_s=*/0.01);
  EXPECT_TRUE(reached) << daemon.Stderr();
  const std::vector<state_t> states = collector.Decoded<state_t>("PANDA_STATE");
  for (const state_t& s : states) {
    ASSERT_TRUE(Finite(s)) << "tick " << s.tick;
    // Running, or holding where a stalled (loaded) machine let the stream's setpoints go stale; never a fault.
    ASSERT_TRUE(s.mode == state_t::MODE_RUNNING || s.mode == state_t::MODE_HOLD) << int{s.mode} << daemon.Stderr();
  }
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(kWait), 0) << daemon.Stderr();
}

// The quadruped standing (config/quadruped_mujoco_stand.yaml, run as the README
// runs it): lagranged's A1_BASE messages show the trunk, dropped 0.1 m, at its
// standing height (2 × 0.2 cos 0.9 + 0.02 m, within MuJoCo's contact sinking)
// and upright once it has landed, and A1_STATE the 12 joints running.
TEST(MujocoLive, LagrangedStandsTheQuadrupedOnMujocosGround) {
  const int port = 9100;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
  const std::string url = testing::TestLcmUrl(port);
  LcmCollector collector(url);
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--config",
                            std::string(LAGRANGE_SOURCE_DIR) + "/config/quadruped_mujoco_stand.yaml"});
  constexpr double kLanded = 2.0;  // s of simulated time: landed and settled (the offline test's figures)
  ASSERT_TRUE(collector.WaitFor(
      "A1_BASE",
      [](const std::vector<LcmCollector::Message>& m) {
        base_state_t b;
        return !m.empty() && b.decode(m.back().data.data(), 0, static_cast<int>(m.back().data.size())) >= 0 &&
               b.t > kLanded;
      },
      kWait))
      << daemon.Stderr();
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(kWait), 0) << daemon.Stderr();
  const double standing = 2 * 0.2 * std::cos(0.9) + 0.02;
  const std::vector<base_state_t> bases = collector.Decoded<base_state_t>("A1_BASE");
  ASSERT_FALSE(bases.empty());
  const base_state_t& last = bases.back();
  EXPECT_GT(last.t, kLanded);
  EXPECT_NEAR(last.position[2], standing, 5e-3);
  const double x = last.orientation[0], y = last.orientation[1];
  EXPECT_LT(2.0 * (x * x + y * y), 1e-4);  // 1 − cos(tilt): within 0.01 rad of upright
  EXPECT_LT(std::abs(last.linear_velocity[2]), 1e-2);
  const std::vector<state_t> states = collector.Decoded<state_t>("A1_STATE");
  ASSERT_FALSE(states.empty());
  for (const state_t& s : states) {
    ASSERT_EQ(s.num_dofs, 12);
    ASSERT_TRUE(Finite(s)) << "tick " << s.tick;
    ASSERT_EQ(s.mode, state_t::MODE_RUNNING) << daemon.Stderr();
  }
}

// A live start (`lagranged --config`) whose MuJoCo model is refused before
// the loop, as a URDF would be: a 50 MB MJCF names the file and the 2 MiB
// bound; an <include> of a FIFO is refused at once instead of blocking the
// start until a SIGTERM (RunProcess's 30 s bound: exit −1 had it blocked).
// Exit 2 with one line, as every bad scene.
TEST(MujocoLive, LagrangedRefusesAnOversizedMjcfAndAnIncludedFifoAtStartWithOneLine) {
  const int port = 8700;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "mujoco_live_files";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string big = (dir / "big.xml").string(), world = (dir / "world.xml").string(),
                    fifo = (dir / "parts.xml").string();
  std::ofstream(big) << "<mujoco><!--" << std::string(50'000'000, ' ') << "--><worldbody/></mujoco>";
  std::ofstream(world) << "<mujoco><include file=\"parts.xml\"/></mujoco>";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string urdf = std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf";
  for (const auto& [file, why] :
       {std::pair{big, big + ": larger than 2 MiB"},
        std::pair{world, world + ": <include file=\"parts.xml\">: " + fifo + ": not a regular file (a FIFO)"}}) {
    const std::string scene = (dir / "scene.yaml").string();
    std::ofstream(scene) << "period: 0.001\ninstances:\n  - name: panda\n    plant: {type: mujoco, file: " << file
                         << ", model: {type: urdf, file: " << urdf
                         << "}}\n    initial: {q: [0, -0.785, 0, -2.356, 0, 1.571, 0.785]}\n"
                            "    controller: {type: gravity-compensation}\n";
    const testing::ProcessResult r =
        testing::RunProcess({LAGRANGED_PATH, "--lcm-url", testing::TestLcmUrl(port), "--config", scene}, 30.0);
    EXPECT_EQ(r.exit_code, 2) << r.err.substr(0, 300);
    EXPECT_EQ(testing::Lines(r.err).size(), 1u) << r.err.substr(0, 300);
    EXPECT_NE(r.err.find("instances[0].plant.file: " + why), std::string::npos) << r.err.substr(0, 300);
  }
  std::filesystem::remove_all(dir);
}

// The reference driver (examples/cpp/mujoco_driver.cpp) in the loop: MuJoCo
// as the robot behind lagranged's external plant, lagranged's computed torque
// (config/panda_external_mujoco.yaml) driving it over the bus through the
// 3 s min-jerk move to its target. Both are ordinary processes on a shared
// machine: the watchdogs get 0.5 s here instead of the shipped 0.05 s, and a
// tripped lagranged is re-armed (clear), as an operator would.
TEST(MujocoLive, TheReferenceDriverClosesTheLoopWithLagranged) {
  const int port = 8402;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
  const std::string url = testing::TestLcmUrl(port);
  const std::string source = LAGRANGE_SOURCE_DIR;
  std::ifstream in(source + "/config/panda_external_mujoco.yaml");
  std::string scene((std::istreambuf_iterator<char>(in)), {});
  scene.replace(scene.find("state_timeout: 0.05"), 19, "state_timeout: 0.5");
  scene.replace(scene.find("file: robots/panda.urdf"), 23, "file: " + source + "/config/robots/panda.urdf");
  const std::string scene_path = ::testing::TempDir() + "panda_external_mujoco_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(scene_path) << scene;
  LcmCollector collector(url);
  BackgroundProcess driver({MUJOCO_DRIVER_PATH, "--model", source + "/config/robots/panda.urdf", "--initial",
                            "0,-0.785,0,-2.356,0,1.571,0.785", "--lcm-url", url, "--torque-timeout", "0.5"});
  ASSERT_TRUE(collector.WaitFor("PANDA_ROBOT_STATE", [](const auto& m) { return !m.empty(); }, kWait))
      << driver.Stderr();
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--config", scene_path});
  const std::vector<double> target = {0.6, -0.3, -0.4, -1.9, 0.5, 2.1, 0.3};
  lcm::LCM sender(url);
  std::int64_t request = 0;
  const bool reached = testing::SendUntil(
      [&] {  // re-arm a watchdog that a stalled process tripped
        const auto ours = collector.Decoded<state_t>("PANDA_STATE");
        if (ours.empty() || ours.back().mode != state_t::MODE_STOPPED) return;
        const command_t clear = testing::MakeCommand(command_t::CLEAR_ESTOP, ++request, WallMicros());
        sender.publish("PANDA_COMMAND", &clear);
      },
      [&] {
        const auto states = collector.Decoded<state_t>("PANDA_ROBOT_STATE");
        if (states.empty() || states.back().mode != state_t::MODE_RUNNING) return false;
        double err = 0.0;
        for (std::size_t i = 0; i < 7; ++i) err = std::max(err, std::abs(states.back().q[i] - target[i]));
        return err < kSettled;
      },
      kWait);
  EXPECT_TRUE(reached) << daemon.Stderr() << driver.Stderr();
  for (const state_t& s : collector.Decoded<state_t>("PANDA_ROBOT_STATE")) ASSERT_TRUE(Finite(s)) << "tick " << s.tick;
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(kWait), 0) << daemon.Stderr();
  driver.Signal(SIGTERM);
  EXPECT_EQ(driver.Wait(kWait), 0) << driver.Stderr();
  std::remove(scene_path.c_str());
}

}  // namespace
}  // namespace lagrange
