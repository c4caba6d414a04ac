// lagrangectl on recorded runs: log2csv and plot; replaying a setpoint log
// with lcm-logplayer; several daemons on one bus; the lcm-spy types jar.

#include <gtest/gtest.h>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/support/lcm_testing.hpp"
#include "tests/support/mini_json.hpp"
#include "tests/support/png.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::RunCtl;

struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  int Column(const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? -1 : static_cast<int>(it - header.begin());
  }
  std::vector<double> Numbers(const std::string& name) const {
    std::vector<double> v;
    const int c = Column(name);
    for (const auto& r : rows) v.push_back(std::stod(r.at(static_cast<std::size_t>(c))));
    return v;
  }
};

// Enough CSV for our files: quoted fields never contain commas in the columns read here.
Csv ReadCsv(const fs::path& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  auto split = [](const std::string& l) {
    std::vector<std::string> cells;
    std::stringstream s(l);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    return cells;
  };
  if (std::getline(in, line)) csv.header = split(line);
  while (std::getline(in, line)) csv.rows.push_back(split(line));
  return csv;
}

class Logs : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_logs_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Url(int port) {
    EXPECT_EQ(testing::PrepareLoopbackMulticast(port), "");
    return testing::TestLcmUrl(port);
  }
  static std::unique_ptr<BackgroundProcess> Daemon(const std::string& url, std::vector<std::string> extra) {
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return std::make_unique<BackgroundProcess>(argv);
  }
  // Two seconds of the default scene with a setpoint stream and a foreign message, recorded.
  fs::path RecordRun(int port) {
    const std::string url = Url(port);
    const fs::path log = dir_ / "run.lcm";
    testing::LcmLoggerProcess logger(url, log.string());
    auto daemon = Daemon(url, {"--duration", "2"});
    LcmCollector status(url, "LAGRANGE_STATUS");
    EXPECT_TRUE(status.WaitFor("LAGRANGE_STATUS", [](const auto& m) { return !m.empty(); }, 20.0));
    EXPECT_EQ(RunCtl({"send", "arm", "--q", "0.5,0.4", "--for", "0.5", "--lcm-url", url}).status, 0);
    lcm::LCM other(url);
    const char bytes[] = "not a lagrange message";
    other.publish("OTHER", bytes, sizeof bytes);
    EXPECT_EQ(daemon->Wait(60.0), 0) << daemon->Stderr();
    logger.Stop();
    return log;
  }
  fs::path dir_;
};

TEST_F(Logs, Log2CsvWritesOneCsvPerChannelAndSkipsForeignTypes) {
  const fs::path log = RecordRun(7831);
  const fs::path out = dir_ / "csv";
  const auto r = RunCtl({"log2csv", log.string(), "-o", out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("skipped OTHER: 1 message of a type that is not lagrange's"), std::string::npos) << r.err;
  for (const char* channel : {"ARM_STATE", "CARTPOLE_STATE"}) {
    const Csv states = ReadCsv(out / (std::string(channel) + ".csv"));
    ASSERT_EQ(states.rows.size(), 2000u) << channel;
    const std::vector<double> tick = states.Numbers("tick");
    for (std::size_t k = 0; k < tick.size(); ++k) ASSERT_EQ(tick[k], static_cast<double>(k));
    for (const char* column : {"log_utime", "t", "q0", "q1", "q_des1", "tau0", "kinetic_energy", "mode"}) {
      EXPECT_GE(states.Column(column), 0) << column;
    }
  }
  const Csv setpoints = ReadCsv(out / "ARM_SETPOINT.csv");
  EXPECT_GT(setpoints.rows.size(), 100u);
  EXPECT_EQ(setpoints.Numbers("q0").front(), 0.5);
  EXPECT_GE(ReadCsv(out / "LAGRANGE_STATUS.csv").rows.size(), 19u);
  EXPECT_FALSE(fs::exists(out / "OTHER.csv"));

  const fs::path only = dir_ / "only";
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "--channel", "ARM_STATE", "-o", only.string()}).status, 0);
  EXPECT_EQ(std::distance(fs::directory_iterator(only), fs::directory_iterator()), 1);
}

TEST_F(Logs, Log2CsvRefusesWhatIsNotALogWithOneLine) {
  const fs::path text = dir_ / "notes.txt";
  std::ofstream(text) << "this is not an LCM log\n";
  struct Case {
    std::vector<std::string> args;
    std::string what;
  };
  const std::vector<Case> cases = {
      {{"log2csv", (dir_ / "missing.lcm").string()}, "cannot read " + (dir_ / "missing.lcm").string()},
      {{"log2csv", text.string()}, text.string() + " is not an LCM log"},
      {{"log2csv"}, "log is required"},
  };
  for (const Case& c : cases) {
    const auto r = RunCtl(c.args);
    EXPECT_NE(r.status, 0);
    ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
    EXPECT_NE(r.err.find(c.what), std::string::npos) << r.err;
  }
}

// Checks a PNG made by lagrangectl plot: a valid image, drawn from the
// expected series of `csv` (q, q_des, tau, T, V, E and the tracking error).
void ExpectPlotOf(const fs::path& png, const Csv& csv, const char* kinetic, const char* qdes) {
  const testing::PngInfo info = testing::ReadPng(png.string());
  ASSERT_TRUE(info.valid) << info.error;
  EXPECT_GE(info.width, 400u);
  EXPECT_GE(info.height, 400u);
  ASSERT_TRUE(info.text.count("lagrange:series"));
  const testing::Json record = testing::ParseJson(info.text.at("lagrange:series"));
  EXPECT_EQ(record["rows"].number, static_cast<double>(csv.rows.size()));
  const std::vector<std::string> expected = {"E", "T", "V", "e0", "e1", "q0", "q1", "qdes0", "qdes1", "tau0", "tau1"};
  std::vector<std::string> drawn;
  for (const auto& [name, _] : record["series"].object) drawn.push_back(name);
  EXPECT_EQ(drawn, expected);
  for (const auto& [name, column] : std::vector<std::pair<std::string, std::string>>{
           {"q0", "q0"}, {"qdes1", std::string(qdes) + "1"}, {"tau0", "tau0"}, {"T", kinetic}}) {
    const std::vector<double> v = csv.Numbers(column);
    const testing::Json& s = record["series"][name];
    EXPECT_EQ(s["points"].number, static_cast<double>(v.size())) << name;
    EXPECT_NEAR(s["min"].number, *std::min_element(v.begin(), v.end()), 1e-12) << name;
    EXPECT_NEAR(s["max"].number, *std::max_element(v.begin(), v.end()), 1e-12) << name;
  }
}

TEST_F(Logs, PlotDrawsTheExpectedSeriesFromASimulationCsvAndFromALog) {
  const fs::path csv = dir_ / "sim.csv";
  ASSERT_EQ(RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/chain7_minjerk.yaml", "--duration", "1",
                    "--csv", csv.string()}).status, 0);
  // A chain has 7 joints; plot the arm run instead for a compact check of series names.
  const fs::path arm = dir_ / "arm.csv";
  ASSERT_EQ(RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/gravity_compensation.yaml", "--duration",
                    "1", "--csv", arm.string()}).status, 0);
  const fs::path png = dir_ / "arm.png";
  auto r = RunCtl({"plot", arm.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, png.string() + "\n");
  ExpectPlotOf(png, ReadCsv(arm), "T", "qdes");

  const fs::path log = RecordRun(7835);
  const fs::path log_png = dir_ / "log.png";
  r = RunCtl({"plot", log.string(), "--channel", "ARM_STATE", "-o", log_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "--channel", "ARM_STATE", "-o", (dir_ / "c").string()}).status, 0);
  ExpectPlotOf(log_png, ReadCsv(dir_ / "c" / "ARM_STATE.csv"), "kinetic_energy", "q_des");
}

TEST_F(Logs, PlotRefusesBadInputWithOneLine) {
  const fs::path no_columns = dir_ / "bad.csv";
  std::ofstream(no_columns) << "a,b\n1,2\n";
  const fs::path binary = dir_ / "noise.bin";
  std::ofstream(binary, std::ios::binary) << std::string("\x01\x02\x03\xff\xfe", 5);
  struct Case {
    std::vector<std::string> args;
    int status;
    std::string what;
  };
  const std::vector<Case> cases = {
      {{"plot", (dir_ / "missing.csv").string()}, 1, "cannot read"},
      {{"plot", no_columns.string()}, 1, "lacks the columns t, q0.."},
      {{"plot", binary.string()}, 1, "is neither a CSV nor an LCM log"},
      {{"plot", no_columns.string(), "--channel", "ARM_STATE"}, 2, "--channel: only for an LCM log"},
  };
  for (const Case& c : cases) {
    const auto r = RunCtl(c.args);
    EXPECT_EQ(r.status, c.status) << r.err;
    ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("lagrangectl plot: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.what), std::string::npos) << r.err;
  }
}

// The arm's q from the first tick whose setpoint left the initial hold.
std::vector<std::array<double, 2>> MotionAfterFirstSetpoint(const std::vector<state_t>& states) {
  std::vector<std::array<double, 2>> q;
  bool moving = false;
  for (const state_t& s : states) {
    moving = moving || std::abs(s.q_des[0] - states.front().q_des[0]) > 1e-12;
    if (moving) q.push_back({s.q[0], s.q[1]});
  }
  return q;
}

TEST_F(Logs, SetpointsRecordedInOneRunDriveTheSameTrajectoryWhenPlayedBack) {
  // Run A: a 3 s sine streamed by lagrangectl, its setpoints recorded.
  const std::string url_a = Url(7832);
  const fs::path log = dir_ / "setpoints.lcm";
  std::vector<state_t> run_a;
  {
    testing::LcmLoggerProcess logger(url_a, log.string(), "ARM_SETPOINT");
    LcmCollector states(url_a, "ARM_STATE");
    auto daemon = Daemon(url_a, {});
    ASSERT_TRUE(states.WaitFor("ARM_STATE", [](const auto& m) { return m.size() > 100; }, 20.0));
    ASSERT_EQ(RunCtl({"send", "arm", "--sine", "0.3,0.5", "--q", "0.6,0.2", "--for", "3", "--lcm-url", url_a}).status, 0);
    daemon->Signal(SIGTERM);
    ASSERT_EQ(daemon->Wait(10.0), 0);
    logger.Stop();
    run_a = states.Decoded<state_t>("ARM_STATE");
  }
  // Run B: a fresh daemon driven only by lcm-logplayer replaying that log. Its
  // setpoints carry run A's timestamps, so the daemon judges their age within the stream.
  const std::string url_b = Url(7833);
  LcmCollector states_b(url_b, "ARM_STATE|LAGRANGE_STATUS");
  auto daemon_b = Daemon(url_b, {"--setpoint-age", "stream"});
  ASSERT_TRUE(states_b.WaitFor("ARM_STATE", [](const auto& m) { return m.size() > 100; }, 20.0));
  BackgroundProcess player({LCM_LOGPLAYER_PATH, "--lcm-url=" + url_b, "--regexp=ARM_SETPOINT", log.string()});
  ASSERT_EQ(player.Wait(30.0), 0) << player.Stderr();
  states_b.WaitFor("ARM_STATE", [](const auto&) { return false; }, 0.5);  // the last setpoints settle
  daemon_b->Signal(SIGTERM);
  ASSERT_EQ(daemon_b->Wait(10.0), 0);
  const auto status_b = states_b.Decoded<status_t>("LAGRANGE_STATUS").back();
  EXPECT_GT(status_b.setpoints_accepted, 2500);
  EXPECT_EQ(status_b.setpoints_rejected, 0);

  // Same trajectory: every state of run B lies on run A's path in (q0, q1), and the
  // motion lasts as long. (Compared as paths, not tick by tick: replay timing moves
  // each setpoint by a few ticks on a loaded machine, which shifts the motion in time only.)
  const auto a = MotionAfterFirstSetpoint(run_a);
  const auto b = MotionAfterFirstSetpoint(states_b.Decoded<state_t>("ARM_STATE"));
  ASSERT_GT(a.size(), 2900u);
  ASSERT_GT(b.size(), 2900u);
  double worst = 0.0, lo = 1e9, hi = -1e9;
  for (std::size_t k = 0; k < 2900; k += 5) {
    double nearest = 1e9;
    for (std::size_t j = 0; j < a.size(); ++j) {
      nearest = std::min(nearest, std::hypot(a[j][0] - b[k][0], a[j][1] - b[k][1]));
    }
    worst = std::max(worst, nearest);
    lo = std::min(lo, a[k][1]);
    hi = std::max(hi, a[k][1]);
  }
  EXPECT_GT(hi - lo, 0.5);   // a real motion ...
  EXPECT_LT(worst, 5e-3);    // ... along the same path
  auto moving_ticks = [](const std::vector<state_t>& states) {  // from the first to the last streamed change of q_des
    std::size_t first = 0, last = 0;
    for (std::size_t k = 1; k < states.size(); ++k) {
      if (states[k].mode == state_t::MODE_RUNNING && states[k].q_des[0] != states[k - 1].q_des[0]) {
        if (first == 0) first = k;
        last = k;
      }
    }
    return static_cast<double>(last - first);
  };
  EXPECT_NEAR(moving_ticks(states_b.Decoded<state_t>("ARM_STATE")), moving_ticks(run_a), 100.0);  // within 0.1 s of 3 s
}

TEST_F(Logs, SeveralDaemonsShareOneBusUnderTheirPrefixesAndOneLoggerRecordsThemAll) {
  const std::string url = Url(7834);
  const fs::path log = dir_ / "fleet.lcm";
  {
    testing::LcmLoggerProcess logger(url, log.string());
    auto a = Daemon(url, {"--channel-prefix", "LEFT_", "--duration", "2"});
    auto b = Daemon(url, {"--channel-prefix", "RIGHT_", "--duration", "2", "--config",
                          std::string(LAGRANGE_SOURCE_DIR) + "/config/pendulum.yaml"});
    ASSERT_EQ(a->Wait(60.0), 0) << a->Stderr();
    ASSERT_EQ(b->Wait(60.0), 0) << b->Stderr();
    logger.Stop();
  }
  const fs::path out = dir_ / "csv";
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "-o", out.string()}).status, 0);
  for (const char* channel : {"LEFT_ARM_STATE", "LEFT_CARTPOLE_STATE", "RIGHT_PENDULUM_STATE"}) {
    const std::vector<double> tick = ReadCsv(out / (std::string(channel) + ".csv")).Numbers("tick");
    ASSERT_EQ(tick.size(), 2000u) << channel;
    for (std::size_t k = 0; k < tick.size(); ++k) ASSERT_EQ(tick[k], static_cast<double>(k)) << channel;
  }
  EXPECT_TRUE(fs::exists(out / "LEFT_LAGRANGE_STATUS.csv"));
  EXPECT_TRUE(fs::exists(out / "RIGHT_LAGRANGE_STATUS.csv"));
  EXPECT_FALSE(fs::exists(out / "ARM_STATE.csv"));
}

TEST(LcmSpy, TheTypesJarHoldsEveryLagrangeTypeForLcmSpy) {
  const std::string jar = LAGRANGE_LCM_JAR;
  if (jar.empty()) GTEST_SKIP() << "no JDK at configure time: the jar is not built";
  const auto list = testing::RunProcess({JAR_PATH, "tf", jar});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  for (const char* type : {"state_t", "setpoint_t", "command_t", "status_t"}) {
    EXPECT_NE(list.out.find(std::string("lagrange/") + type + ".class"), std::string::npos) << type;
    // lcm-spy finds types as LCMEncodable classes on its class path.
    const auto javap = testing::RunProcess({JAVAP_PATH, "-cp", std::string(LCM_JAR_PATH) + ":" + jar,
                                            std::string("lagrange.") + type});
    EXPECT_NE(javap.out.find("implements lcm.lcm.LCMEncodable"), std::string::npos) << javap.out << javap.err;
  }
}

}  // namespace
}  // namespace lagrange
