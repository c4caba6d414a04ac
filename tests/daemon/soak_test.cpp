// Soak (README, "Hard cases"): lagranged runs for LAGRANGE_SOAK_SECONDS (60 in
// CI; the README's command gives 600) on the default scene while a setpoint
// stream drives the arm: resident memory grows by at most 1 MiB (plain build),
// nothing faults, the loop runs exactly its --duration's ticks, and every
// state received over the bus is finite with increasing tick numbers (how
// many arrive is UDP's business on a loaded machine, not the daemon's).

#include <gtest/gtest.h>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <regex>
#include <thread>

#include "tests/support/lcm_testing.hpp"

namespace lagrange {
namespace {

using testing::BackgroundProcess;
using testing::LcmCollector;

double SoakSeconds() {
  const char* v = std::getenv("LAGRANGE_SOAK_SECONDS");
  return v != nullptr ? std::atof(v) : 60.0;
}

TEST(Soak, RunsItsWholeDurationWithFlatMemoryAndNoFault) {
  const double seconds = SoakSeconds();
  const long ticks = std::lround(seconds * 1000.0);
  ASSERT_EQ(testing::PrepareLoopbackMulticast(7846), "");
  const std::string url = testing::TestLcmUrl(7846);
  LcmCollector collector(url, ".*_STATE");
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--duration", std::to_string(seconds)});
  ASSERT_TRUE(collector.WaitFor(
      "ARM_STATE", [](const auto& m) { return !m.empty(); }, 60.0));

  // A sine stream on the arm at 100 Hz for the whole run.
  std::atomic<bool> done{false};
  std::thread stream([&] {
    lcm::LCM lcm(url);
    const auto start = std::chrono::steady_clock::now();
    for (auto next = start; !done; next += std::chrono::milliseconds(10)) {
      const double t = std::chrono::duration<double>(next - start).count();
      setpoint_t s;
      s.utime = testing::WallMicros();
      s.num_dofs = 2;
      s.q = {0.7 + 0.3 * std::sin(t), 0.2 * std::cos(t)};
      s.qd = {0.3 * std::cos(t), -0.2 * std::sin(t)};
      s.qdd = {-0.3 * std::sin(t), -0.2 * std::cos(t)};
      lcm.publish("ARM_SETPOINT", &s);
      std::this_thread::sleep_until(next + std::chrono::milliseconds(10));
    }
  });
  // Resident memory after a 5 s warm-up, then its largest value until the end.
  std::this_thread::sleep_for(std::chrono::seconds(5));
  const long rss_warm = daemon.ResidentKiB();
  long rss_peak = rss_warm;
  while (daemon.Running()) {
    rss_peak = std::max(rss_peak, daemon.ResidentKiB());
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  done = true;
  stream.join();
  ASSERT_EQ(daemon.Wait(60.0), 0) << daemon.Stderr();
  if (testing::kResidentSizeMeaningful) {
    EXPECT_LE(rss_peak - rss_warm, 1024) << "KiB";
  }

  std::smatch m;
  const std::string err = daemon.Stderr();
  ASSERT_TRUE(std::regex_search(err, m, std::regex("stopped after ([0-9]+) ticks"))) << err;
  EXPECT_EQ(std::stol(m[1]), ticks);
  for (const char* channel : {"ARM_STATE", "CARTPOLE_STATE"}) {
    const auto states = collector.Decoded<state_t>(channel);
    ASSERT_FALSE(states.empty()) << channel;
    for (std::size_t k = 0; k < states.size(); ++k) {
      const state_t& s = states[k];
      ASSERT_NE(s.mode, state_t::MODE_FAULT) << channel << " tick " << s.tick;
      ASSERT_LT(s.tick, ticks) << channel;
      if (k > 0) {
        ASSERT_GT(s.tick, states[k - 1].tick) << channel;
      }
      bool finite = std::isfinite(s.t) && std::isfinite(s.kinetic_energy) && std::isfinite(s.potential_energy);
      for (const auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) {
        for (const double x : *v) finite = finite && std::isfinite(x);
      }
      ASSERT_TRUE(finite) << channel << " tick " << s.tick;
    }
  }
  EXPECT_EQ(err.find(": fault at t = "), std::string::npos) << err;  // the daemon logs no fault
}

}  // namespace
}  // namespace lagrange
