// An mpc controller's plans on the wire (<NAME>_MPC, mpc_t) from a live
// lagranged running the shipped swing-up scene for a second or two, and what
// lagrangectl makes of them: watch's line per plan, log2csv's columns and
// plot's panel of predicted beside actual paths. Ports 8920-8929.
//
// Multicast may drop a datagram on a loaded machine: nothing here counts on
// every plan or state arriving, only on what those that came say.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <lagrange/mpc_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::RunCtl;

constexpr double kWait = 20.0;  // s for the first message of a starting daemon
constexpr double kStateMatch = 1e-9;

std::string SwingUp() { return std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_mpc_swingup.yaml"; }

class MpcLive : public ::testing::Test {
 protected:
  void Start(int port) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    url_ = testing::TestLcmUrl(port);
    collector_ = std::make_unique<LcmCollector>(url_, "CARTPOLE_(STATE|MPC)|LAGRANGE_STATUS");
    daemon_ = std::make_unique<BackgroundProcess>(
        std::vector<std::string>{LAGRANGED_PATH, "--lcm-url", url_, "--log-level", "warn", "--config", SwingUp()});
    ASSERT_TRUE(collector_->WaitFor("LAGRANGE_STATUS", [](const auto& m) { return !m.empty(); }, kWait));
  }
  void TearDown() override {
    if (daemon_) {
      daemon_->Signal(SIGTERM);
      EXPECT_EQ(daemon_->Wait(10.0), 0) << daemon_->Stderr();
    }
  }
  std::string url_;
  std::unique_ptr<LcmCollector> collector_;
  std::unique_ptr<BackgroundProcess> daemon_;
};

// Each plan on CARTPOLE_MPC: followed with a usable status, from this run, its
// figures consistent, and its first knot the very state the cart-pole was
// published in at the tick the plan was planned from.
TEST_F(MpcLive, ThePlansChannelCarriesUsablePlansWhoseFirstKnotIsThePublishedStateTheyStartedFrom) {
  Start(8920);
  ASSERT_TRUE(collector_->WaitFor("CARTPOLE_MPC", [](const auto& m) { return m.size() >= 10; }, kWait));
  const std::vector<mpc_t> plans = collector_->Decoded<mpc_t>("CARTPOLE_MPC");
  const std::vector<state_t> states = collector_->Decoded<state_t>("CARTPOLE_STATE");
  const std::vector<status_t> statuses = collector_->Decoded<status_t>("LAGRANGE_STATUS");
  ASSERT_FALSE(statuses.empty());
  std::map<double, const state_t*> by_t;
  for (const state_t& s : states) by_t[s.t] = &s;
  int matched = 0;
  std::int64_t previous = 0;
  for (const mpc_t& p : plans) {
    EXPECT_EQ(p.run_id, statuses.back().run_id);
    EXPECT_EQ(p.controller, "mpc");
    EXPECT_TRUE(p.status == "converged" || p.status == "max-iterations") << p.status;
    EXPECT_TRUE(p.followed);
    EXPECT_GT(p.plan, previous) << "each plan once, in order";
    previous = p.plan;
    EXPECT_GE(p.age, 0.0);
    EXPECT_LT(p.age, p.horizon * p.dt) << "taken within its horizon";
    EXPECT_NEAR(p.t - p.start, p.age, 1e-9);
    EXPECT_GT(p.solve_time, 0.0);
    EXPECT_GE(p.iterations, 1);
    EXPECT_LE(p.iterations, 2);  // the scene's iterations per solve
    EXPECT_LE(p.cost, p.cost_before);
    EXPECT_EQ(p.horizon, 100);
    ASSERT_EQ(p.num_states, 4);
    ASSERT_EQ(p.num_knots, mpc_t::MAX_KNOTS);
    EXPECT_DOUBLE_EQ(p.knot_t.front(), p.start);
    EXPECT_NEAR(p.knot_t.back(), p.start + p.horizon * p.dt, 1e-9);
    for (const auto& x : p.knot_x) {
      for (double v : x) ASSERT_TRUE(std::isfinite(v));
    }
    const auto from = by_t.find(p.start);
    if (from == by_t.end()) continue;  // that state's datagram was not heard
    const state_t& s = *from->second;
    ++matched;
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(p.knot_x[0][static_cast<std::size_t>(j)], s.q[static_cast<std::size_t>(j)], kStateMatch);
      EXPECT_NEAR(p.knot_x[0][static_cast<std::size_t>(2 + j)], s.qd[static_cast<std::size_t>(j)], kStateMatch);
    }
  }
  EXPECT_GE(matched, 1) << "some plan's starting state was heard";
}

// watch: a line for the instance's latest plan, with its age, iterations, cost and status.
TEST_F(MpcLive, WatchShowsTheLatestPlansAgeSolveIterationsCostAndStatus) {
  Start(8921);
  ASSERT_TRUE(collector_->WaitFor("CARTPOLE_MPC", [](const auto& m) { return !m.empty(); }, kWait));
  const auto r = RunCtl({"watch", "--frames", "2", "--rate", "5", "--lcm-url", url_});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string frame = r.out.substr(r.out.rfind("lagranged run "));
  const std::size_t line = frame.find("\n  mpc plan ");
  ASSERT_NE(line, std::string::npos) << frame;
  const std::string plan = frame.substr(line + 1, frame.find('\n', line + 1) - line - 1);
  for (const char* text : {"   age ", " ms   solve ", " ms   iterations ", "   cost ", " -> "})
    EXPECT_NE(plan.find(text), std::string::npos) << text << "\n" << plan;
  EXPECT_TRUE(plan.find("converged (followed)") != std::string::npos ||
              plan.find("max-iterations (followed)") != std::string::npos)
      << plan;
}

// A recorded run: log2csv writes the plans with their knots, and plot draws the predicted paths beside the
// actual one, saying so.
TEST_F(MpcLive, PlotDrawsThePlansPredictedPathsBesideTheActualOneFromALog) {
  const fs::path dir = fs::temp_directory_path() / ("lagrange_mpc_live_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path log = dir / "run.lcm";
  {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(8922), "");
    const std::string url = testing::TestLcmUrl(8922);
    testing::LcmLoggerProcess logger(url, log.string());
    url_ = url;
    collector_ = std::make_unique<LcmCollector>(url_, "CARTPOLE_MPC|LAGRANGE_STATUS");
    daemon_ = std::make_unique<BackgroundProcess>(
        std::vector<std::string>{LAGRANGED_PATH, "--lcm-url", url_, "--log-level", "warn", "--config", SwingUp()});
    ASSERT_TRUE(collector_->WaitFor("CARTPOLE_MPC", [](const auto& m) { return m.size() >= 10; }, kWait));
    daemon_->Signal(SIGTERM);
    EXPECT_EQ(daemon_->Wait(10.0), 0) << daemon_->Stderr();
    daemon_.reset();
  }
  const auto csv = RunCtl({"log2csv", log.string(), "--channel", "CARTPOLE_MPC", "-o", (dir / "c").string()});
  ASSERT_EQ(csv.status, 0) << csv.err;
  std::ifstream in(dir / "c" / "CARTPOLE_MPC.csv");
  std::string header;
  ASSERT_TRUE(std::getline(in, header));
  for (const char* column : {"plan", "age", "solve_time", "iterations", "cost_before", "cost", "status", "followed",
                             "knot_t0", "knot_t15", "knot0_x_0", "knot15_x_3"}) {
    EXPECT_NE(("," + header + ",").find("," + std::string(column) + ","), std::string::npos) << column;
  }
  const fs::path png = dir / "run.png";
  const auto r = RunCtl({"plot", log.string(), "--channel", "CARTPOLE_STATE", "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::size_t at = r.out.find("; mpc: ");
  ASSERT_NE(at, std::string::npos) << r.out;
  int plans = 0, followed = 0, drawn = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str() + at, "; mpc: %d plans (%d followed), %d drawn", &plans, &followed, &drawn), 3)
      << r.out;
  EXPECT_GE(plans, 1);
  EXPECT_EQ(followed, plans) << "every plan of the swing-up is usable";
  EXPECT_EQ(drawn, std::min(followed, 12));
  EXPECT_GT(fs::file_size(png), 0u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lagrange
