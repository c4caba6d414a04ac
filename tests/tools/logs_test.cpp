// lagrangectl on recorded runs: log2csv and plot; replaying a setpoint log
// with lcm-logplayer; several daemons on one bus; the lcm-spy types jar. (The
// packet checks lagrangectl applies before decoding anything are
// tests/protocol/wire_test's.)
//
// Multicast may drop a datagram on a loaded machine, so nothing here counts
// on every message arriving or on when it arrives: the checks are on what
// the files hold (columns, consistent values, finite numbers).

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/base_state_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/telemetry_t.hpp>
#include <lagrange/torque_t.hpp>

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "daemon/runtime.hpp"
#include "protocol/signing.hpp"
#include "protocol/wire.hpp"
#include "tests/support/lcm_log_bytes.hpp"
#include "tests/support/lcm_messages.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::MakeState;
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
  std::vector<std::string> Texts(const std::string& name) const {
    std::vector<std::string> v;
    const int c = Column(name);
    for (const auto& r : rows) v.push_back(r.at(static_cast<std::size_t>(c)));
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
  // The default scene recorded while lagrangectl streams a setpoint, switches
  // the arm's controller (a command and its reply) and resets it (its t goes
  // back to 0), plus a message of a foreign type.
  fs::path RecordRun(int port) {
    const std::string url = Url(port);
    const fs::path log = dir_ / "run.lcm";
    testing::LcmLoggerProcess logger(url, log.string());
    auto daemon = Daemon(url, {});
    LcmCollector status(url, "LAGRANGE_STATUS");
    EXPECT_TRUE(status.WaitFor(
        "LAGRANGE_STATUS", [](const auto& m) { return !m.empty(); }, 20.0));
    const auto sent = RunCtl({"send", "arm", "--q", "0.5,0.4", "--for", "0.5", "--lcm-url", url});
    EXPECT_EQ(sent.status, 0) << sent.err;
    const auto switched = RunCtl({"command", "arm", "controller", "pd", "--lcm-url", url});
    EXPECT_EQ(switched.status, 0) << switched.err;
    const auto reset = RunCtl({"command", "arm", "reset", "--lcm-url", url});
    EXPECT_EQ(reset.status, 0) << reset.err;
    status.WaitFor(
        "LAGRANGE_STATUS", [](const auto&) { return false; }, 0.3);  // some states after the reset
    lcm::LCM other(url);
    const char bytes[] = "not a lagrange message";
    other.publish("OTHER", bytes, sizeof bytes);
    daemon->Signal(SIGTERM);
    EXPECT_EQ(daemon->Wait(60.0), 0) << daemon->Stderr();
    logger.Stop();
    return log;
  }
  fs::path dir_;
};

// Every cell of the columns that hold numbers is a finite number.
void ExpectFiniteNumbers(const Csv& csv, const std::vector<std::string>& text_columns, const std::string& what) {
  for (std::size_t c = 0; c < csv.header.size(); ++c) {
    if (std::find(text_columns.begin(), text_columns.end(), csv.header[c]) != text_columns.end()) continue;
    for (const auto& row : csv.rows) {
      ASSERT_EQ(row.size(), csv.header.size()) << what;
      std::size_t used = 0;
      const double v = std::stod(row[c], &used);
      ASSERT_EQ(used, row[c].size()) << what << " " << csv.header[c] << ": " << row[c];
      ASSERT_TRUE(std::isfinite(v)) << what << " " << csv.header[c] << ": " << row[c];
    }
  }
}

TEST_F(Logs, Log2CsvWritesOneCsvPerChannelAndSkipsForeignTypes) {
  const fs::path log = RecordRun(7831);
  const fs::path out = dir_ / "csv";
  const auto r = RunCtl({"log2csv", log.string(), "-o", out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("skipped OTHER: 1 message of a type that is not lagrange's"), std::string::npos) << r.err;
  std::string run;
  for (const char* channel : {"ARM_STATE", "CARTPOLE_STATE"}) {
    const Csv states = ReadCsv(out / (std::string(channel) + ".csv"));
    ASSERT_GT(states.rows.size(), 0u) << channel;
    for (const char* column :
         {"log_utime", "run_id", "tick", "t", "q0", "q1", "q_des1", "tau0", "kinetic_energy", "mode"}) {
      EXPECT_GE(states.Column(column), 0) << column;
    }
    ExpectFiniteNumbers(states, {"run_id", "controller"}, channel);  // lagranged never publishes a non-finite value
    const std::vector<double> tick = states.Numbers("tick");
    for (std::size_t k = 1; k < tick.size(); ++k)
      ASSERT_GT(tick[k], tick[k - 1]) << channel;  // one run: ticks only grow
    for (const std::string& id : states.Texts("run_id")) {
      if (run.empty()) run = id;
      ASSERT_EQ(id, run) << channel;  // one run id, on every instance
    }
  }
  ASSERT_EQ(run.size(), 16u);
  const Csv setpoints = ReadCsv(out / "ARM_SETPOINT.csv");
  ASSERT_GT(setpoints.rows.size(), 0u);
  for (double q0 : setpoints.Numbers("q0")) ASSERT_EQ(q0, 0.5);
  const Csv status = ReadCsv(out / "LAGRANGE_STATUS.csv");
  ASSERT_GT(status.rows.size(), 0u);
  for (const char* column :
       {"run_id", "datagrams_dropped_kernel", "fragments_dropped", "foreign_messages", "instances", "joints"}) {
    EXPECT_GE(status.Column(column), 0) << column;
  }
  for (const std::string& id : status.Texts("run_id")) ASSERT_EQ(id, run);
  {  // The last column names each instance's joints: the default scene's are generated.
    std::ifstream in(out / "LAGRANGE_STATUS.csv");
    std::string line, last;
    while (std::getline(in, line)) last = line;
    const std::string joints = "\"arm=q1,q2;cartpole=x,theta\"";
    EXPECT_EQ(last.substr(last.size() - std::min(last.size(), joints.size())), joints) << last;
  }
  // Each command lagrangectl sent has its own request id, and lagranged's replies echo them from its run.
  const Csv commands = ReadCsv(out / "ARM_COMMAND.csv");
  const Csv replies = ReadCsv(out / "ARM_REPLY.csv");
  EXPECT_EQ(replies.header,
            (std::vector<std::string>{"log_utime", "utime", "run_id", "request_id", "command", "accepted", "reason"}));
  const std::vector<std::string> requests = commands.Texts("request_id");
  ASSERT_GT(requests.size(), 0u);
  for (std::size_t k = 1; k < requests.size(); ++k) EXPECT_NE(requests[k], requests[k - 1]);  // fresh ids
  ASSERT_GT(replies.rows.size(), 0u);
  for (std::size_t k = 0; k < replies.rows.size(); ++k) {
    EXPECT_NE(std::find(requests.begin(), requests.end(), replies.Texts("request_id")[k]), requests.end());
    EXPECT_EQ(replies.Texts("run_id")[k], run);
    EXPECT_EQ(replies.Numbers("accepted")[k], 1.0);
  }
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

// The PNG's (height, width) in pixels, decoded by matplotlib as a user's viewer would; (0, 0) when it does not decode.
std::pair<int, int> ImageSize(const fs::path& png) {
  const std::string python = access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
  const auto r = testing::RunProcess(
      {python, "-c",
       "import sys, matplotlib.image; a = matplotlib.image.imread(sys.argv[1]); print(a.shape[0], a.shape[1])",
       png.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  int height = 0, width = 0;
  std::istringstream(r.out) >> height >> width;
  return {height, width};
}

// The PNG decodes as an image at least 400 × 400 pixels.
void ExpectImage(const fs::path& png) {
  const auto [height, width] = ImageSize(png);
  EXPECT_GE(width, 400);
  EXPECT_GE(height, 400);
}

// Where the plot must break its lines: rows where t goes back, the tick does
// not follow on, or the run changes. Returns the number of segments.
std::size_t Segments(const Csv& csv) {
  const std::vector<double> t = csv.Numbers("t");
  const bool ticks = csv.Column("tick") >= 0;
  const std::vector<double> tick = ticks ? csv.Numbers("tick") : std::vector<double>(t.size(), 0.0);
  const std::vector<std::string> run =
      csv.Column("run_id") >= 0 ? csv.Texts("run_id") : std::vector<std::string>(t.size());
  std::size_t segments = t.empty() ? 0 : 1;
  for (std::size_t k = 1; k < t.size(); ++k) {
    segments += t[k] < t[k - 1] || (ticks && tick[k] != tick[k - 1] + 1) || run[k] != run[k - 1];
  }
  return segments;
}

// plot's line for the state rows of `csv`, without the newline (and without
// what it adds for telemetry and forces panels).
std::string PlotLine(const fs::path& png, const Csv& csv) {
  const std::size_t segments = Segments(csv);
  return png.string() + ": " + std::to_string(csv.rows.size()) + " rows in " + std::to_string(segments) + " segment" +
         (segments == 1 ? "" : "s");
}

TEST_F(Logs, PlotDrawsASimulationCsvAndALogBreakingLinesAtAReset) {
  const fs::path arm = dir_ / "arm.csv";
  ASSERT_EQ(RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/gravity_compensation.yaml", "--duration",
                    "1", "--csv", arm.string()})
                .status,
            0);
  const fs::path png = dir_ / "arm.png";
  auto r = RunCtl({"plot", arm.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv simulated = ReadCsv(arm);
  // The arm's joints named by arm.joints.csv, which simulate wrote beside arm.csv.
  EXPECT_EQ(r.out, PlotLine(png, simulated) + "; joints: q1, q2\n");
  EXPECT_EQ(Segments(simulated), 1u);  // one run, no reset: one unbroken line per series
  ExpectImage(png);

  // The recorded run has a reset: the arm's t goes back to 0, and the plot starts a new segment there.
  const fs::path log = RecordRun(7835);
  const fs::path log_png = dir_ / "log.png";
  r = RunCtl({"plot", log.string(), "--channel", "ARM_STATE", "-o", log_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "--channel", "ARM_STATE", "-o", (dir_ / "c").string()}).status, 0);
  const Csv recorded = ReadCsv(dir_ / "c" / "ARM_STATE.csv");
  // simulate names a quantity as log2csv does: every column of its CSV is one of the recorded state CSV's.
  for (const std::string& column : simulated.header) EXPECT_GE(recorded.Column(column), 0) << column;
  // Drawn from the same rows log2csv writes, the joints named by the status, with the arm's telemetry
  // lagranged published beside its states.
  EXPECT_EQ(r.out.rfind(PlotLine(log_png, recorded) + "; joints: q1, q2; telemetry: ", 0), 0u) << r.out;
  const std::vector<double> t = recorded.Numbers("t");
  bool went_back = false;
  for (std::size_t k = 1; k < t.size(); ++k) went_back = went_back || t[k] < t[k - 1];
  EXPECT_TRUE(went_back);
  EXPECT_GE(Segments(recorded), 2u);
  ExpectImage(log_png);
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
// (q0, q1) of the states from the first that moves the setpoint on.
std::vector<std::array<double, 2>> MotionAfterFirstSetpoint(const std::vector<state_t>& states) {
  std::vector<std::array<double, 2>> q;
  bool moving = false;
  for (const state_t& s : states) {
    moving = moving || std::abs(s.q_des[0] - states.front().q_des[0]) > 1e-12;
    if (moving) q.push_back({s.q[0], s.q[1]});
  }
  return q;
}

// The distances from the points of `b` (every `stride`-th) to the nearest point of `a`, sorted.
std::vector<double> DistancesToPath(const std::vector<std::array<double, 2>>& a,
                                    const std::vector<std::array<double, 2>>& b, std::size_t stride) {
  std::vector<double> d;
  for (std::size_t k = 0; k < b.size(); k += stride) {
    double nearest = 1e9;
    for (const auto& p : a) nearest = std::min(nearest, std::hypot(p[0] - b[k][0], p[1] - b[k][1]));
    d.push_back(nearest);
  }
  std::sort(d.begin(), d.end());
  return d;
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
    ASSERT_TRUE(states.WaitFor(
        "ARM_STATE", [](const auto& m) { return m.size() > 100; }, 20.0));
    ASSERT_EQ(RunCtl({"send", "arm", "--sine", "0.3,0.5", "--q", "0.6,0.2", "--for", "3", "--lcm-url", url_a}).status,
              0);
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
  ASSERT_TRUE(states_b.WaitFor(
      "ARM_STATE", [](const auto& m) { return m.size() > 100; }, 20.0));
  BackgroundProcess player({LCM_LOGPLAYER_PATH, "--lcm-url=" + url_b, "--regexp=ARM_SETPOINT", log.string()});
  ASSERT_EQ(player.Wait(30.0), 0) << player.Stderr();
  states_b.WaitFor(
      "ARM_STATE", [](const auto&) { return false; }, 0.5);  // the last setpoints settle
  daemon_b->Signal(SIGTERM);
  ASSERT_EQ(daemon_b->Wait(10.0), 0);
  const auto status_b = states_b.Decoded<status_t>("LAGRANGE_STATUS").back();
  EXPECT_GT(status_b.setpoints_accepted, 0);
  EXPECT_EQ(status_b.setpoints_rejected, 0);  // replayed with their own timing, none counts as stale

  const auto a = MotionAfterFirstSetpoint(run_a);
  const auto b = MotionAfterFirstSetpoint(states_b.Decoded<state_t>("ARM_STATE"));
  ASSERT_GT(a.size(), 100u);
  ASSERT_GT(b.size(), 100u);
  // Same trajectory: every state of run B lies on run A's path in (q0, q1).
  // Compared as paths, not tick by tick or in time: lcm-logplayer's timing
  // moves each setpoint by some milliseconds on a loaded machine (and a state
  // may be lost); along this path, at up to 1 rad/s, each millisecond moves the
  // arm's response up to 1e-3 rad off run A's, so 2e-2 allows replay jitter of
  // 20 ms for 95 % of the states, and 0.1 a stall of the player of up to 100 ms
  // for the rest (seen on a loaded machine: 0.049 at one state), while a motion
  // other than run A's (0.5 rad wide) is far outside both.
  double lo = 1e9, hi = -1e9;
  for (const auto& qa : a) {
    lo = std::min(lo, qa[1]);
    hi = std::max(hi, qa[1]);
  }
  EXPECT_GT(hi - lo, 0.5);                      // a real motion ...
  const std::vector<double> d = DistancesToPath(a, b, 5);
  ASSERT_FALSE(d.empty());
  EXPECT_LT(d[d.size() * 95 / 100], 2e-2);  // ... along the same path
  EXPECT_LT(d.back(), 0.1);
}

// Signed traffic (--bus-key): lcm-logger records it, log2csv decodes it (the
// trailer follows the message, where LCM's decoders ignore it), and the
// recording replayed by lcm-logplayer onto a signed daemon moves nothing:
// every replayed setpoint is refused for its stamp and counted on its channel.
TEST_F(Logs, ASignedRunIsRecordedAndDecodedAndItsReplayMovesNothing) {
  const std::string key = (dir_ / "bus.key").string();
  ASSERT_EQ(RunCtl({"keygen", key}).status, 0);
  const std::string url_a = Url(8107);
  const fs::path log = dir_ / "signed.lcm";
  {
    testing::LcmLoggerProcess logger(url_a, log.string());
    LcmCollector status(url_a, "LAGRANGE_STATUS");
    auto daemon = Daemon(url_a, {"--bus-key", key});
    ASSERT_TRUE(status.WaitFor(
        "LAGRANGE_STATUS", [](const auto& m) { return !m.empty(); }, 20.0));
    const auto sent = RunCtl({"send", "arm", "--q", "0.5,0.4", "--for", "0.5", "--lcm-url", url_a, "--bus-key", key});
    ASSERT_EQ(sent.status, 0) << sent.err;
    daemon->Signal(SIGTERM);
    ASSERT_EQ(daemon->Wait(60.0), 0) << daemon->Stderr();
    logger.Stop();
  }
  const fs::path out = dir_ / "csv";
  const auto r = RunCtl({"log2csv", log.string(), "-o", out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv states = ReadCsv(out / "ARM_STATE.csv");
  ASSERT_GT(states.rows.size(), 100u);
  ExpectFiniteNumbers(states, {"run_id", "controller"}, "ARM_STATE");
  const Csv setpoints = ReadCsv(out / "ARM_SETPOINT.csv");
  ASSERT_GT(setpoints.rows.size(), 0u);
  for (double q0 : setpoints.Numbers("q0")) ASSERT_EQ(q0, 0.5);
  const Csv statuses = ReadCsv(out / "LAGRANGE_STATUS.csv");  // the signing fields have columns too
  ASSERT_GT(statuses.rows.size(), 0u);
  for (double signs : statuses.Numbers("bus_signed")) ASSERT_EQ(signs, 1.0);
  for (double refused : statuses.Numbers("datagrams_unauthenticated")) ASSERT_GE(refused, 0.0);
  EXPECT_GE(statuses.Column("unauthenticated"), 0);

  const std::string url_b = Url(8108);
  LcmCollector b(url_b, "ARM_STATE|LAGRANGE_STATUS");
  auto daemon_b = Daemon(url_b, {"--bus-key", key, "--setpoint-age", "stream"});
  ASSERT_TRUE(b.WaitFor(
      "ARM_STATE", [](const auto& m) { return m.size() > 100; }, 20.0));
  BackgroundProcess player({LCM_LOGPLAYER_PATH, "--lcm-url=" + url_b, "--regexp=ARM_SETPOINT", log.string()});
  ASSERT_EQ(player.Wait(30.0), 0) << player.Stderr();
  EXPECT_TRUE(b.WaitForLatest<status_t>(
      "LAGRANGE_STATUS",
      [&](const status_t& s) {
        return s.num_unauthenticated_channels == 1 && s.unauthenticated_channels[0] == "ARM_SETPOINT" &&
               s.unauthenticated_counts[0] == static_cast<std::int64_t>(setpoints.rows.size());
      },
      20.0));
  daemon_b->Signal(SIGTERM);
  ASSERT_EQ(daemon_b->Wait(60.0), 0) << daemon_b->Stderr();
  const status_t last = b.Decoded<status_t>("LAGRANGE_STATUS").back();
  EXPECT_TRUE(last.bus_signed);
  EXPECT_EQ(last.setpoints_accepted, 0);
  const double q0 = 0.7853981633974483;  // config/default.yaml's arm, held while no setpoint comes
  for (const state_t& s : b.Decoded<state_t>("ARM_STATE")) ASSERT_NEAR(s.q[0], q0, 1e-3) << "tick " << s.tick;
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
  std::map<std::string, std::string> run_of;  // channel → its run id
  for (const char* channel : {"LEFT_ARM_STATE", "LEFT_CARTPOLE_STATE", "RIGHT_PENDULUM_STATE"}) {
    const Csv states = ReadCsv(out / (std::string(channel) + ".csv"));
    const std::vector<double> tick = states.Numbers("tick");
    ASSERT_GT(tick.size(), 0u) << channel;
    for (std::size_t k = 1; k < tick.size(); ++k) ASSERT_GT(tick[k], tick[k - 1]) << channel;
    const std::vector<std::string> runs = states.Texts("run_id");
    for (const std::string& id : runs) ASSERT_EQ(id, runs.front()) << channel;
    ExpectFiniteNumbers(states, {"run_id", "controller"}, channel);
    run_of[channel] = runs.front();
  }
  EXPECT_EQ(run_of["LEFT_ARM_STATE"], run_of["LEFT_CARTPOLE_STATE"]);   // one daemon, one run id ...
  EXPECT_NE(run_of["LEFT_ARM_STATE"], run_of["RIGHT_PENDULUM_STATE"]);  // ... another daemon, another
  EXPECT_TRUE(fs::exists(out / "LEFT_LAGRANGE_STATUS.csv"));
  EXPECT_TRUE(fs::exists(out / "RIGHT_LAGRANGE_STATUS.csv"));
  EXPECT_FALSE(fs::exists(out / "ARM_STATE.csv"));
}

// A 7-joint robot from URDF, recorded: log2csv writes its seven joints' columns
// and the status's joint names, and plot draws the log and a simulate CSV,
// each with the joints named as in the URDF.
TEST_F(Logs, Log2CsvAndPlotTakeASevenJointRobotsRun) {
  const std::string url = Url(7937);
  const fs::path log = dir_ / "panda.lcm";
  {
    testing::LcmLoggerProcess logger(url, log.string());
    auto daemon =
        Daemon(url, {"--duration", "1", "--config", std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_minjerk.yaml"});
    ASSERT_EQ(daemon->Wait(60.0), 0) << daemon->Stderr();
    logger.Stop();
  }
  const fs::path out = dir_ / "csv";
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "-o", out.string()}).status, 0);
  const Csv states = ReadCsv(out / "PANDA_STATE.csv");
  ASSERT_GT(states.rows.size(), 0u);
  for (const char* column : {"q0", "q6", "qd6", "tau6", "q_des6", "qd_des6"})
    EXPECT_GE(states.Column(column), 0) << column;
  EXPECT_LT(states.Column("q7"), 0);
  ExpectFiniteNumbers(states, {"run_id", "controller"}, "PANDA_STATE");
  std::ifstream in(out / "LAGRANGE_STATUS.csv");
  std::string line, last;
  while (std::getline(in, line)) last = line;
  const std::string joints =
      "\"panda=panda_joint1,panda_joint2,panda_joint3,panda_joint4,panda_joint5,panda_joint6,"
      "panda_joint7\"";
  EXPECT_EQ(last.substr(last.size() - std::min(last.size(), joints.size())), joints) << last;

  const fs::path log_png = dir_ / "panda_log.png";
  auto r = RunCtl({"plot", log.string(), "-o", log_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string panda_joints =
      "; joints: panda_joint1, panda_joint2, panda_joint3, panda_joint4, panda_joint5, panda_joint6, panda_joint7";
  EXPECT_EQ(r.out.rfind(PlotLine(log_png, states) + panda_joints + "; telemetry: ", 0), 0u) << r.out;
  ExpectImage(log_png);
  const fs::path csv = dir_ / "panda.csv", png = dir_ / "panda.png";
  ASSERT_EQ(RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/ur5_pd_gravity.yaml", "--duration", "1",
                    "--csv", csv.string()})
                .status,
            0);
  r = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, png.string() +
                       ": 1001 rows in 1 segment; joints: shoulder_pan_joint, shoulder_lift_joint, elbow_joint, "
                       "wrist_1_joint, wrist_2_joint, wrist_3_joint\n");
  ExpectImage(png);
}

// A simulate CSV's joints are labelled by the names beside it
// (FILE.joints.csv), read back as simulate wrote them: a URDF's name with a
// comma, quotes and a tab (escaped). Without that file, or with one that
// names another robot's joints, they are q0, q1, .. and the line names none;
// a file there that holds no names is one line.
TEST_F(Logs, PlotNamesASimulationsJointsByTheNamesBesideItsCsv) {
  fs::create_directories(dir_ / "robots");
  std::ofstream(dir_ / "robots" / "odd.urdf")
      << R"(<robot name="odd"><link name="base"/>)"
      << R"(<joint name="elbow, &quot;left&quot;&#9;x" type="revolute"><parent link="base"/><child link="a"/>)"
      << R"(<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>)"
      << R"(<link name="a"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>)"
      << R"(<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link></robot>)";
  std::ofstream(dir_ / "odd.yaml")
      << "instances:\n  - name: r\n    plant: {type: urdf, file: robots/odd.urdf}\n    initial: {q: [0.5]}\n";
  const fs::path csv = dir_ / "odd.csv", names = dir_ / "odd.joints.csv", png = dir_ / "odd.png";
  ASSERT_EQ(RunCtl({"simulate", (dir_ / "odd.yaml").string(), "--duration", "0.1", "--csv", csv.string()}).status, 0);
  auto r = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, png.string() + ": 101 rows in 1 segment; joints: elbow, \"left\"\\tx\n");

  std::ofstream(names) << "joint,name\n0,\"a\"\n1,\"b\"\n";
  r = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, png.string() + ": 101 rows in 1 segment\n");

  fs::remove(names);
  r = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, png.string() + ": 101 rows in 1 segment\n");

  std::ofstream(names) << "t,q0\n0,1\n";
  r = RunCtl({"plot", csv.string(), "-o", png.string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err, "lagrangectl plot: " + names.string() +
                       " lacks the columns joint, name (a FILE.joints.csv from lagrangectl simulate)\n");
}

TEST(LcmSpy, TheTypesJarHoldsEveryLagrangeTypeForLcmSpy) {
  const std::string jar = LAGRANGE_LCM_JAR;
  if (jar.empty()) GTEST_SKIP() << "no JDK at configure time: the jar is not built";
  const auto list = testing::RunProcess({JAR_PATH, "tf", jar});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  for (const char* type :
       {"state_t", "setpoint_t", "command_t", "status_t", "reply_t", "torque_t", "telemetry_t", "forces_t",
        "pose_setpoint_t", "task_state_t", "mpc_t", "base_state_t"}) {
    EXPECT_NE(list.out.find(std::string("lagrange/") + type + ".class"), std::string::npos) << type;
    // lcm-spy finds types as LCMEncodable classes on its class path.
    const auto javap = testing::RunProcess(
        {JAVAP_PATH, "-cp", std::string(LCM_JAR_PATH) + ":" + jar, std::string("lagrange.") + type});
    EXPECT_NE(javap.out.find("implements lcm.lcm.LCMEncodable"), std::string::npos) << javap.out << javap.err;
  }
}

// lcm-spy decodes a signed message: it constructs the type from a DataInput
// over the datagram's payload (lcm.spy.Spy: getConstructor(DataInput.class)),
// which reads the fields and leaves the signature trailer after them unread.
TEST(LcmSpy, TheTypesJarDecodesASignedStateAsLcmSpyDoes) {
  const std::string jar = LAGRANGE_LCM_JAR;
  if (jar.empty() || std::string(JAVA_PATH).empty()) GTEST_SKIP() << "no JDK at configure time";
  const fs::path dir = fs::temp_directory_path() / ("lagrange_spy_" + std::to_string(getpid()));
  fs::create_directories(dir);
  state_t state = MakeState(42);
  std::vector<std::uint8_t> bytes = testing::Encode(state);
  const std::size_t n = bytes.size();
  bytes.resize(n + kSignatureTrailerBytes);
  std::vector<std::uint8_t> key(kBusKeyMinBytes);
  for (std::size_t i = 0; i < key.size(); ++i) key[i] = static_cast<std::uint8_t>(7 + 31 * i);
  Signer signer(BusKey::FromBytes(key), "inprocess://");
  signer.Sign("ARM_STATE", bytes.data(), n, bytes.data() + n);
  std::ofstream(dir / "state.bin", std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  std::ofstream(dir / "Decode.java") << R"(
public class Decode {
  public static void main(String[] args) throws Exception {
    byte[] b = java.nio.file.Files.readAllBytes(java.nio.file.Paths.get(args[0]));
    Object o = Class.forName("lagrange.state_t").getConstructor(java.io.DataInput.class)
        .newInstance(new lcm.lcm.LCMDataInputStream(b, 0, b.length));
    lagrange.state_t s = (lagrange.state_t) o;
    System.out.println(s.tick + " " + s.q[1] + " " + s.controller);
  }
}
)";
  const auto run = testing::RunProcess({JAVA_PATH, "-cp", std::string(LCM_JAR_PATH) + ":" + jar,
                                        (dir / "Decode.java").string(), (dir / "state.bin").string()});
  fs::remove_all(dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "42 0.25 pd\n");
}

// Encodes an LCM message.
template <class Message>
std::vector<std::uint8_t> Encode(const Message& m) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  return bytes;
}

void PutInt32(std::vector<std::uint8_t>& bytes, std::size_t at, std::int32_t v) {
  for (int i = 0; i < 4; ++i)
    bytes[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(v) >> (24 - 8 * i));
}

// One tick's telemetry: rk4 in 4 sub-steps (16 evaluations), residual ε.
telemetry_t SomeTelemetry(std::int64_t tick, double residual) {
  telemetry_t m{};
  m.utime = 1'700'000'000'000'000 + 1000 * tick;
  m.run_id = 0x1234;
  m.tick = tick;
  m.t = 1e-3 * static_cast<double>(tick);
  m.mode = state_t::MODE_RUNNING;
  m.energy = 2.5;
  m.energy_residual = residual;
  m.quadrature_bound = 1e-9;
  m.work = 0.125;
  m.power = -0.5;
  m.integrator = "rk4";
  m.substeps = 4;
  m.method = "closed-form";
  m.evaluations = 16;
  m.steps_accepted = 4;
  m.error_estimate = -1.0;
  m.step = 2.5e-4;
  m.compute_us = 12.5;
  return m;
}

// forces_t's rows in its order.
constexpr const char* kForceRows[] = {"gravity",    "coriolis",    "damping", "friction",   "limits",
                                      "constraint", "disturbance", "tau_cmd", "tau_applied"};

// A distinct value for each row, joint and tick, exact in decimal.
double ForceValue(std::size_t row, int joint, std::int64_t tick) {
  return static_cast<double>(row + 1) + 0.25 * joint + 1e-3 * static_cast<double>(tick);
}

// Forces on n joints at `tick`; the effects on are the first of `on` (gravity,
// coriolis, damping, friction, limits, saturation, disturbance, constraint;
// the rest off). A row whose effect is off is zeros, as lagranged sends it.
forces_t SomeForces(std::int64_t tick, std::vector<bool> on, int n) {
  on.resize(8, false);
  forces_t f{};
  f.utime = 1'700'000'000'000'000 + 1000 * tick;
  f.run_id = 0x1234;
  f.tick = tick;
  f.t = 1e-3 * static_cast<double>(tick);
  f.gravity_on = on[0];
  f.coriolis_on = on[1];
  f.damping_on = on[2];
  f.friction_on = on[3];
  f.limits_on = on[4];
  f.saturation_on = on[5];
  f.disturbance_on = on[6];
  f.constraint_on = on[7];
  f.num_dofs = n;
  // Row → its effect's flag in `on` (tau_cmd: saturation; tau_applied: always there).
  const int flag[] = {0, 1, 2, 3, 4, 7, 6, -1, -1};
  std::vector<double>* rows[] = {&f.gravity,    &f.coriolis,    &f.damping, &f.friction,   &f.limits,
                                 &f.constraint, &f.disturbance, &f.tau_cmd, &f.tau_applied};
  for (std::size_t r = 0; r < std::size(rows); ++r) {
    for (int j = 0; j < n; ++j)
      rows[r]->push_back(flag[r] < 0 || on[static_cast<std::size_t>(flag[r])] ? ForceValue(r, j, tick) : 0.0);
  }
  return f;
}

TEST_F(Logs, Log2CsvSkipsARecordedStateWhoseLengthsLie) {
  const fs::path log = dir_ / "lying.lcm";
  const std::vector<std::uint8_t> good = Encode(MakeState());
  std::vector<std::uint8_t> bad = good;
  PutInt32(bad, 8 + 4 * 8, 0x7fffffff);  // num_dofs: would make the generated decoder allocate 96 GiB
  testing::WriteLcmLog(log.string(), {{"ARM_STATE", good}, {"ARM_STATE", bad}, {"ARM_STATE", good}});
  const auto r = RunCtl({"log2csv", log.string(), "-o", (dir_ / "csv").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("2 rows of state_t (1 skipped"), std::string::npos) << r.out;
  const Csv states = ReadCsv(dir_ / "csv" / "ARM_STATE.csv");
  EXPECT_EQ(states.rows.size(), 2u);
  EXPECT_EQ(states.Texts("run_id").front(), "0000000000001234");
}

torque_t SomeTorque(std::int64_t sequence, double tau0, double tau1) {
  torque_t t{};
  t.utime = 1'700'000'000'000'000 + sequence;
  t.run_id = 0xabc;
  t.sequence = sequence;
  t.state_tick = sequence == 1 ? -1 : 40 + sequence;
  t.num_dofs = 2;
  t.tau = {tau0, tau1};
  return t;
}

// A torque channel becomes a CSV of the sender's fields and one tau column per
// joint, checked like every packet (one whose num_dofs lies is skipped); the
// status CSV carries the torque and measured-state counters and each
// instance's reason.
TEST_F(Logs, Log2CsvWritesTorquesOneColumnPerJointAndTheStatusCountersAndReasons) {
  std::vector<std::uint8_t> lying = Encode(SomeTorque(3, 0.0, 0.0));
  PutInt32(lying, 8 + 4 * 8, 0x7fffffff);  // num_dofs, after utime, run_id, sequence, state_tick
  status_t status{};
  status.run_id = 0x1234;
  status.torques_accepted = 17;
  status.torques_rejected = 2;
  status.measured_accepted = 5;
  status.measured_rejected = 1;
  status.last_rejection = "arm: torque: run_id 0: expected the sender's non-zero id";
  status.last_command_error = "";
  status.num_instances = 2;
  status.instance_names = {"arm", "probe"};
  status.instance_modes = {state_t::MODE_HOLD, state_t::MODE_RUNNING};
  status.instance_dofs = {2, 1};
  status.instance_reasons = {kTorquesTimedOut, ""};
  status.instance_integrators = {"rk4 x4", "none"};
  status.instance_methods = {"closed-form", "recursive"};
  status.instance_effects = {"gravity,coriolis,damping", ""};
  status.instance_forces = {1, 0};
  status.num_joints = 3;
  status.joint_names = {"q1", "q2", "theta"};
  const fs::path log = dir_ / "torques.lcm";
  testing::WriteLcmLog(log.string(), {{"ARM_TORQUE", Encode(SomeTorque(1, 1.5, -0.25))},
                                      {"ARM_TORQUE", Encode(SomeTorque(2, 2.5, 1e-3))},
                                      {"ARM_TORQUE", lying},
                                      {"ARM_TORQUE", Encode(SomeTorque(4, -40.0, 15.0))},
                                      {"LAGRANGE_STATUS", Encode(status)}});
  const fs::path out = dir_ / "csv";
  const auto r = RunCtl({"log2csv", log.string(), "-o", out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("ARM_TORQUE.csv: 3 rows of torque_t (1 skipped"), std::string::npos) << r.out;

  const Csv torques = ReadCsv(out / "ARM_TORQUE.csv");
  EXPECT_EQ(torques.header, (std::vector<std::string>{"log_utime", "utime", "run_id", "sequence", "state_tick",
                                                      "num_dofs", "tau0", "tau1"}));
  ASSERT_EQ(torques.rows.size(), 3u);
  EXPECT_EQ(torques.Numbers("sequence"), (std::vector<double>{1, 2, 4}));
  EXPECT_EQ(torques.Numbers("state_tick"), (std::vector<double>{-1, 42, 44}));
  EXPECT_EQ(torques.Numbers("tau0"), (std::vector<double>{1.5, 2.5, -40.0}));  // shortest round-trip text: exact
  EXPECT_EQ(torques.Numbers("tau1"), (std::vector<double>{-0.25, 1e-3, 15.0}));
  EXPECT_EQ(torques.Texts("run_id"), std::vector<std::string>(3, "0000000000000abc"));
  EXPECT_EQ(torques.Texts("utime").front(), "1700000000000001");

  const Csv statuses = ReadCsv(out / "LAGRANGE_STATUS.csv");
  ASSERT_EQ(statuses.rows.size(), 1u);
  for (const auto& [column, value] : std::vector<std::pair<std::string, double>>{
           {"torques_accepted", 17}, {"torques_rejected", 2}, {"measured_accepted", 5}, {"measured_rejected", 1}}) {
    ASSERT_GE(statuses.Column(column), 0) << column;
    EXPECT_EQ(statuses.Numbers(column).front(), value) << column;
  }
  EXPECT_EQ(statuses.Texts("last_rejection").front(), "\"arm: torque: run_id 0: expected the sender's non-zero id\"");
  EXPECT_EQ(statuses.Texts("instances").front(), "\"arm=1;probe=0\"");
  EXPECT_EQ(statuses.Texts("reasons").front(), std::string("\"arm=") + kTorquesTimedOut + ";probe=\"");
  EXPECT_EQ(statuses.Texts("integrators").front(), "\"arm=rk4 x4;probe=none\"");
  EXPECT_EQ(statuses.Texts("methods").front(), "\"arm=closed-form;probe=recursive\"");
  std::ifstream status_csv(out / "LAGRANGE_STATUS.csv");  // effects hold commas: read as text, not by ReadCsv
  std::string row;
  std::getline(status_csv, row);
  std::getline(status_csv, row);
  EXPECT_NE(row.find(",\"arm=gravity,coriolis,damping;probe=\",\"arm=1;probe=0\","), std::string::npos) << row;
  EXPECT_EQ(statuses.header.back(), "joints");
}

// Telemetry becomes one column per field; forces one column per effect's flag
// and per row and joint (gravity_0, gravity_1, ..), every value exactly as
// sent. A forces packet whose num_dofs lies is skipped like any other.
TEST_F(Logs, Log2CsvWritesPoseSetpointsAndTaskStatesOneColumnPerComponent) {
  pose_setpoint_t pose{};
  pose.utime = 11;
  pose.frame = "tool0";
  pose.position[0] = 0.4;
  pose.position[2] = 0.25;
  pose.orientation[0] = 1.0;
  pose.duration = 2.0;
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events = {{"UR5_POSE", Encode(pose)}};
  for (std::int64_t k = 1; k <= 3; ++k) {
    task_state_t task{};
    task.utime = 100 + k;
    task.run_id = 0x1234;
    task.tick = k;
    task.t = 0.001 * static_cast<double>(k);
    task.frame = "tool0";
    task.controller = "operational-space";
    task.position[1] = 0.1 * static_cast<double>(k);
    task.orientation[0] = task.orientation_des[0] = 1.0;
    task.error[0] = -1e-4 * static_cast<double>(k);
    events.emplace_back("UR5_TASK", Encode(task));
  }
  const fs::path log = dir_ / "task.lcm";
  testing::WriteLcmLog(log.string(), events);
  const fs::path out = dir_ / "csv";
  const auto r = RunCtl({"log2csv", log.string(), "-o", out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("UR5_POSE.csv: 1 row of pose_setpoint_t"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("UR5_TASK.csv: 3 rows of task_state_t"), std::string::npos) << r.out;
  const Csv poses = ReadCsv(out / "UR5_POSE.csv");
  EXPECT_EQ(poses.Numbers("position0"), std::vector<double>{0.4});
  EXPECT_EQ(poses.Numbers("duration"), std::vector<double>{2.0});
  EXPECT_EQ(poses.Texts("frame"), std::vector<std::string>{"\"tool0\""});
  const Csv tasks = ReadCsv(out / "UR5_TASK.csv");
  EXPECT_EQ(tasks.Numbers("position1"), (std::vector<double>{0.1, 0.2, 0.30000000000000004}));
  EXPECT_EQ(tasks.Numbers("error0"), (std::vector<double>{-1e-4, -2e-4, -3.0000000000000003e-4}));
  EXPECT_EQ(tasks.Numbers("orientation_des0"), (std::vector<double>{1.0, 1.0, 1.0}));
  EXPECT_EQ(tasks.Texts("controller"), std::vector<std::string>(3, "\"operational-space\""));
  EXPECT_EQ(tasks.header.size(), 7u + 3 + 4 + 3 + 4 + 6 + 6);
}

// A floating base's states (<NAME>_BASE) are one column per component, in
// the type's order, every value exactly as sent.
TEST_F(Logs, Log2CsvWritesBaseStatesOneColumnPerComponent) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (std::int64_t k = 1; k <= 2; ++k) {
    base_state_t b{};
    b.utime = 200 + k;
    b.run_id = 0x42;
    b.tick = k;
    b.t = 0.001 * static_cast<double>(k);
    b.position[2] = 1.0 - 0.1 * static_cast<double>(k);
    b.orientation[3] = 1.0;
    b.angular_velocity[1] = 0.5;
    b.com[2] = 0.9;
    b.angular_momentum[0] = -2e-3;
    events.emplace_back("TREE_BASE", Encode(b));
  }
  const fs::path log = dir_ / "base.lcm";
  testing::WriteLcmLog(log.string(), events);
  const fs::path out = dir_ / "csv";
  const auto r = RunCtl({"log2csv", log.string(), "-o", out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("TREE_BASE.csv: 2 rows of base_state_t"), std::string::npos) << r.out;
  const Csv bases = ReadCsv(out / "TREE_BASE.csv");
  EXPECT_EQ(bases.Numbers("position2"), (std::vector<double>{0.9, 0.8}));
  EXPECT_EQ(bases.Numbers("orientation3"), (std::vector<double>{1.0, 1.0}));
  EXPECT_EQ(bases.Numbers("angular_velocity1"), (std::vector<double>{0.5, 0.5}));
  EXPECT_EQ(bases.Numbers("angular_momentum0"), (std::vector<double>{-2e-3, -2e-3}));
  EXPECT_EQ(bases.Numbers("tick"), (std::vector<double>{1, 2}));
  EXPECT_EQ(bases.header.size(), 5u + 3 + 4 + 3 + 3 + 3 + 3 + 3);
}

TEST_F(Logs, Log2CsvWritesTelemetryAndForcesOneColumnPerJointAndEffect) {
  const std::vector<double> residuals = {1e-12, -2.5e-10, 3.0000000000000001e-9};
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (std::size_t k = 0; k < residuals.size(); ++k)
    events.emplace_back("ARM_TELEMETRY", Encode(SomeTelemetry(static_cast<std::int64_t>(k) + 1, residuals[k])));
  std::vector<std::uint8_t> lying = Encode(SomeForces(3, {true, true}, 2));
  PutInt32(lying, 8 + 4 * 8 + 8, 0x7fffffff);              // num_dofs, after utime, run_id, tick, t and the eight flags
  const std::vector<bool> on = {true, true, false, true};  // gravity, coriolis, friction; damping off
  events.emplace_back("ARM_FORCES", Encode(SomeForces(1, on, 2)));
  events.emplace_back("ARM_FORCES", lying);
  events.emplace_back("ARM_FORCES", Encode(SomeForces(2, on, 2)));
  const fs::path log = dir_ / "telemetry.lcm";
  testing::WriteLcmLog(log.string(), events);
  const fs::path out = dir_ / "csv";
  const auto r = RunCtl({"log2csv", log.string(), "-o", out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("ARM_TELEMETRY.csv: 3 rows of telemetry_t\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ARM_FORCES.csv: 2 rows of forces_t (1 skipped"), std::string::npos) << r.out;

  const Csv telemetry = ReadCsv(out / "ARM_TELEMETRY.csv");
  std::string columns;
  for (const std::string& name : telemetry.header) columns += (columns.empty() ? "" : ",") + name;
  EXPECT_EQ(columns,
            "log_utime,utime,run_id,tick,t,mode,energy,energy_residual,quadrature_bound,work,power,integrator,"
            "substeps,method,evaluations,steps_accepted,steps_rejected,newton_iterations,failures,error_estimate,"
            "step,compute_us");
  EXPECT_EQ(telemetry.Numbers("energy_residual"), residuals);  // shortest round-trip text: exact
  EXPECT_EQ(telemetry.Numbers("tick"), (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(telemetry.Texts("integrator"), std::vector<std::string>(3, "\"rk4\""));
  EXPECT_EQ(telemetry.Texts("method"), std::vector<std::string>(3, "\"closed-form\""));
  EXPECT_EQ(telemetry.Texts("run_id"), std::vector<std::string>(3, "0000000000001234"));
  for (const auto& [column, value] : std::vector<std::pair<std::string, double>>{{"energy", 2.5},
                                                                                 {"quadrature_bound", 1e-9},
                                                                                 {"work", 0.125},
                                                                                 {"power", -0.5},
                                                                                 {"substeps", 4},
                                                                                 {"evaluations", 16},
                                                                                 {"steps_accepted", 4},
                                                                                 {"steps_rejected", 0},
                                                                                 {"error_estimate", -1},
                                                                                 {"step", 2.5e-4},
                                                                                 {"compute_us", 12.5}}) {
    EXPECT_EQ(telemetry.Numbers(column), std::vector<double>(3, value)) << column;
  }

  const Csv forces = ReadCsv(out / "ARM_FORCES.csv");
  std::vector<std::string> header = {"log_utime",     "utime",          "run_id",        "tick",        "t",
                                     "gravity_on",    "coriolis_on",    "damping_on",    "friction_on", "limits_on",
                                     "saturation_on", "disturbance_on", "constraint_on", "num_dofs"};
  for (const char* row : kForceRows) {
    for (int j = 0; j < 2; ++j) header.push_back(std::string(row) + "_" + std::to_string(j));
  }
  for (const char* column : {"contacts_total", "num_contacts", "contact_geom1", "contact_geom2", "contact_distance",
                             "contact_position", "contact_normal", "contact_force", "contact_torque"}) {
    header.push_back(column);
  }
  EXPECT_EQ(forces.header, header);
  ASSERT_EQ(forces.rows.size(), 2u);
  EXPECT_EQ(forces.Numbers("tick"), (std::vector<double>{1, 2}));
  for (const auto& [flag, value] : std::vector<std::pair<std::string, double>>{
           {"gravity_on", 1}, {"coriolis_on", 1}, {"damping_on", 0}, {"friction_on", 1}, {"saturation_on", 0}}) {
    EXPECT_EQ(forces.Numbers(flag), std::vector<double>(2, value)) << flag;
  }
  for (std::size_t row = 0; row < std::size(kForceRows); ++row) {
    const bool off = std::string(kForceRows[row]) == "damping" || std::string(kForceRows[row]) == "limits" ||
                     std::string(kForceRows[row]) == "disturbance" || std::string(kForceRows[row]) == "constraint";
    for (int j = 0; j < 2; ++j) {
      const std::string column = std::string(kForceRows[row]) + "_" + std::to_string(j);
      EXPECT_EQ(forces.Numbers(column),
                (std::vector<double>{off ? 0.0 : ForceValue(row, j, 1), off ? 0.0 : ForceValue(row, j, 2)}))
          << column;
    }
  }
}

// A plant MuJoCo steps: its constraint row and its contacts, each contact
// field a column of the contacts' values joined by ';' (a vector's three in a
// row, contact after contact), so that every row keeps the channel's columns.
TEST_F(Logs, Log2CsvWritesAForcesContactsOneColumnPerFieldJoinedBySemicolons) {
  forces_t f = SomeForces(1, {true, true, false, false, true, false, false, true}, 2);
  f.contacts_total = 3;  // one more than listed
  f.num_contacts = 2;
  f.contacts.resize(2);
  for (int k = 0; k < 2; ++k) {
    contact_t& c = f.contacts[static_cast<std::size_t>(k)];
    c.geom1 = 0;
    c.geom2 = k + 1;
    c.distance = -2.5e-5;
    c.position[0] = 0.25 * k;
    c.normal[2] = 1.0;
    c.force[2] = 15.0 + k;
    c.torque[1] = 0.5;
  }
  const fs::path log = dir_ / "contacts.lcm";
  testing::WriteLcmLog(log.string(), {{"PANDA_FORCES", Encode(f)}});
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "-o", (dir_ / "csv").string()}).status, 0);
  const Csv forces = ReadCsv(dir_ / "csv" / "PANDA_FORCES.csv");
  ASSERT_EQ(forces.rows.size(), 1u);
  EXPECT_EQ(forces.Numbers("constraint_on"), std::vector<double>{1});
  EXPECT_EQ(forces.Numbers("constraint_1"), std::vector<double>{ForceValue(5, 1, 1)});
  EXPECT_EQ(forces.Numbers("contacts_total"), std::vector<double>{3});
  EXPECT_EQ(forces.Numbers("num_contacts"), std::vector<double>{2});
  for (const auto& [column, text] :
       std::vector<std::pair<std::string, std::string>>{{"contact_geom1", "0;0"},
                                                        {"contact_geom2", "1;2"},
                                                        {"contact_distance", "-2.5e-05;-2.5e-05"},
                                                        {"contact_position", "0;0;0;0.25;0;0"},
                                                        {"contact_normal", "0;0;1;0;0;1"},
                                                        {"contact_force", "0;0;15;0;0;16"},
                                                        {"contact_torque", "0;0.5;0;0;0.5;0"}}) {
    EXPECT_EQ(forces.Texts(column), std::vector<std::string>{"\"" + text + "\""}) << column;
  }
}

// A log of an earlier lagrange, whose forces_t had no constraint row and no
// contacts (another fingerprint), still reads: constraint_on 0 and its row
// zeros (not computed then), no contacts, every other value as recorded.
TEST_F(Logs, Log2CsvReadsTheForcesOfAnEarlierLagrangeWithoutConstraintOrContacts) {
  const forces_t now = SomeForces(4, {true, true, false, true}, 2);
  testing::Bytes v1;
  testing::Put64(v1, static_cast<std::uint64_t>(kForcesV1Fingerprint));
  testing::Put64(v1, static_cast<std::uint64_t>(now.utime));
  testing::Put64(v1, static_cast<std::uint64_t>(now.run_id));
  testing::Put64(v1, static_cast<std::uint64_t>(now.tick));
  const auto put_double = [&](double x) {
    std::uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    testing::Put64(v1, bits);
  };
  put_double(now.t);
  for (std::int8_t flag : {now.gravity_on, now.coriolis_on, now.damping_on, now.friction_on, now.limits_on,
                           now.saturation_on, now.disturbance_on}) {
    v1.push_back(static_cast<std::uint8_t>(flag));
  }
  testing::Put32(v1, 2);
  for (const auto* row : {&now.gravity, &now.coriolis, &now.damping, &now.friction, &now.limits, &now.disturbance,
                          &now.tau_cmd, &now.tau_applied}) {
    for (double x : *row) put_double(x);
  }
  const fs::path log = dir_ / "v1.lcm";
  testing::WriteLcmLog(log.string(), {{"ARM_FORCES", v1}, {"ARM_FORCES", Encode(SomeForces(5, {true}, 2))}});
  const auto r = RunCtl({"log2csv", log.string(), "-o", (dir_ / "csv").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("ARM_FORCES.csv: 2 rows of forces_t\n"), std::string::npos) << r.out;
  const Csv forces = ReadCsv(dir_ / "csv" / "ARM_FORCES.csv");
  ASSERT_EQ(forces.rows.size(), 2u);
  EXPECT_EQ(forces.Numbers("tick"), (std::vector<double>{4, 5}));
  EXPECT_EQ(forces.Numbers("constraint_on"), (std::vector<double>{0, 0}));
  EXPECT_EQ(forces.Numbers("constraint_0"), (std::vector<double>{0, 0}));
  EXPECT_EQ(forces.Numbers("num_contacts"), (std::vector<double>{0, 0}));
  EXPECT_EQ(forces.Numbers("friction_on"), (std::vector<double>{1, 0}));
  for (std::size_t row = 0; row < std::size(kForceRows); ++row) {
    if (std::string(kForceRows[row]) == "constraint") continue;
    EXPECT_EQ(forces.Numbers(std::string(kForceRows[row]) + "_1")[0],
              (row == 2 || row == 4 || row == 6) ? 0.0 : ForceValue(row, 1, 4))
        << kForceRows[row];
  }
}

// An arm run of `ticks` ticks: states, telemetry and forces (gravity,
// coriolis and friction on; damping, limits, saturation and disturbance off).
std::vector<std::pair<std::string, std::vector<std::uint8_t>>> ArmRunWithTelemetryAndForces(int ticks) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (std::int64_t k = 0; k < ticks; ++k) {
    state_t s = MakeState(k);
    s.q = {0.5 * std::sin(1e-2 * static_cast<double>(k)), 0.25};
    events.emplace_back("ARM_STATE", Encode(s));
    events.emplace_back("ARM_TELEMETRY", Encode(SomeTelemetry(k, 1e-10 * std::sin(0.05 * static_cast<double>(k)))));
    events.emplace_back("ARM_FORCES", Encode(SomeForces(k, {true, true, false, true}, 2)));
  }
  return events;
}

// With the instance's telemetry and forces beside its states (in a log, or
// as log2csv's CSVs side by side), plot adds the ε and cost panels and one
// panel per joint, naming the effects it drew (those that were on).
TEST_F(Logs, PlotAddsTheResidualTheCostAndOneForcePanelPerJointWhenRecorded) {
  const fs::path log = dir_ / "arm.lcm";
  testing::WriteLcmLog(log.string(), ArmRunWithTelemetryAndForces(200));
  const std::string extra = "; telemetry: 200 rows; forces: 200 rows of gravity, coriolis, friction, tau_applied\n";
  const fs::path log_png = dir_ / "log.png";
  auto r = RunCtl({"plot", log.string(), "-o", log_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, log_png.string() + ": 200 rows in 1 segment" + extra);
  const auto [height, width] = ImageSize(log_png);

  // log2csv's CSVs: the state CSV finds its instance's siblings.
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "-o", (dir_ / "csv").string()}).status, 0);
  const fs::path csv_png = dir_ / "csv.png";
  r = RunCtl({"plot", (dir_ / "csv" / "ARM_STATE.csv").string(), "-o", csv_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, csv_png.string() + ": 200 rows in 1 segment" + extra);
  EXPECT_EQ(ImageSize(csv_png), std::make_pair(height, width));

  // The states alone: four panels, so a shorter picture of the same width.
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "--channel", "ARM_STATE", "-o", (dir_ / "state").string()}).status, 0);
  const fs::path state_png = dir_ / "state.png";
  r = RunCtl({"plot", (dir_ / "state" / "ARM_STATE.csv").string(), "-o", state_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, state_png.string() + ": 200 rows in 1 segment\n");
  const auto [state_height, state_width] = ImageSize(state_png);
  EXPECT_EQ(state_width, width);
  EXPECT_GE(state_height, 400);
  EXPECT_GT(height, state_height + 3 * 100);  // four panels more: ε, cost, and one per joint
}

// A floating base's run: its states and, beside each, its base (<NAME>_BASE)
// falling from 1 m, z = 1 − ½ g t², turning about z at 1 rad/s.
std::vector<std::pair<std::string, std::vector<std::uint8_t>>> TreeRunWithBase(int ticks) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (std::int64_t k = 0; k < ticks; ++k) {
    const state_t s = MakeState(k);
    events.emplace_back("TREE_STATE", Encode(s));
    base_state_t b{};
    b.run_id = s.run_id;
    b.tick = s.tick;
    b.t = s.t;
    b.position[2] = b.com[2] = 1.0 - 0.5 * 9.81 * s.t * s.t;
    b.orientation[2] = std::sin(0.5 * s.t);
    b.orientation[3] = std::cos(0.5 * s.t);
    b.angular_velocity[2] = 1.0;
    b.linear_momentum[2] = -9.81 * s.t;
    b.angular_momentum[2] = 0.1;
    events.emplace_back("TREE_BASE", Encode(b));
  }
  return events;
}

// A log's floating base (<NAME>_BASE beside <NAME>_STATE, or log2csv's
// NAME_BASE.csv beside NAME_STATE.csv): plot adds the base's three panels, as
// for a simulate CSV's base columns, and says what height the base fell from
// and to; the states alone draw three panels fewer.
TEST_F(Logs, PlotAddsTheBasesPanelsWhenALogsBaseIsBeside) {
  const fs::path log = dir_ / "tree.lcm";
  testing::WriteLcmLog(log.string(), TreeRunWithBase(200));
  const std::string base = "; base: 200 rows, height 1 to 0.8058 m\n";  // 1 − ½ 9.81 (0.199 s)²
  const fs::path log_png = dir_ / "log.png";
  auto r = RunCtl({"plot", log.string(), "-o", log_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, log_png.string() + ": 200 rows in 1 segment" + base);
  const auto [height, width] = ImageSize(log_png);

  ASSERT_EQ(RunCtl({"log2csv", log.string(), "-o", (dir_ / "csv").string()}).status, 0);
  const fs::path csv_png = dir_ / "csv.png";
  r = RunCtl({"plot", (dir_ / "csv" / "TREE_STATE.csv").string(), "-o", csv_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, csv_png.string() + ": 200 rows in 1 segment" + base);
  EXPECT_EQ(ImageSize(csv_png), std::make_pair(height, width));

  ASSERT_EQ(RunCtl({"log2csv", log.string(), "--channel", "TREE_STATE", "-o", (dir_ / "state").string()}).status, 0);
  const fs::path state_png = dir_ / "state.png";
  r = RunCtl({"plot", (dir_ / "state" / "TREE_STATE.csv").string(), "-o", state_png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, state_png.string() + ": 200 rows in 1 segment\n");
  EXPECT_GT(height, ImageSize(state_png).first + 2 * 100);  // three panels more

  // A base CSV that lacks a base's columns is refused in one line naming it.
  const fs::path bad = dir_ / "csv" / "TREE_BASE.csv";
  std::ofstream(bad) << "t,position2\n0,1\n";
  r = RunCtl({"plot", (dir_ / "csv" / "TREE_STATE.csv").string(), "-o", csv_png.string()});
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("TREE_BASE.csv lacks the columns com2"), std::string::npos) << r.err;
}

// The arm's states with a task-space frame's beside them (<NAME>_TASK), the
// frame going round a 0.1 m circle with a 1 mm error.
std::vector<std::pair<std::string, std::vector<std::uint8_t>>> ArmRunWithTaskStates(int ticks) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (std::int64_t k = 0; k < ticks; ++k) {
    const state_t s = MakeState(k);
    events.emplace_back("ARM_STATE", Encode(s));
    task_state_t task{};
    task.run_id = s.run_id;
    task.tick = s.tick;
    task.t = s.t;
    task.frame = "tool0";
    task.controller = "operational-space";
    task.position_des[0] = 0.1 * std::cos(s.t);
    task.position_des[1] = 0.1 * std::sin(s.t);
    task.position[0] = task.position_des[0] - 1e-3;
    task.position[1] = task.position_des[1];
    task.orientation[0] = task.orientation_des[0] = 1.0;
    task.error[0] = 1e-3;
    events.emplace_back("ARM_TASK", Encode(task));
  }
  return events;
}

// With a task-space frame beside the states (simulate's FILE.task.csv, a
// log's <NAME>_TASK or log2csv's NAME_TASK.csv beside NAME_STATE.csv), plot
// adds the end effector's panels and says so: its tracking error to its task
// target takes the joints' tracking panel's place (no row followed q_des), and
// its position against the target follows.
TEST_F(Logs, PlotAddsTheEndEffectorsPathAndErrorWhenATaskSpaceFrameIsBeside) {
  const fs::path csv = dir_ / "ur5.csv", png = dir_ / "ur5.png";
  auto r = RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/ur5_circle.yaml", "--duration", "0.2",
                   "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  r = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.out.ends_with("; task: 201 rows of flange\n")) << r.out;
  const auto [height, width] = ImageSize(png);
  fs::remove(dir_ / "ur5.task.csv");
  r = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.find("task:"), std::string::npos) << r.out;
  const auto [plain_height, plain_width] = ImageSize(png);
  EXPECT_EQ(plain_width, width);
  EXPECT_GT(height, plain_height + 100);  // one panel more: the task's error replaced the joints'

  const fs::path log = dir_ / "arm.lcm";
  testing::WriteLcmLog(log.string(), ArmRunWithTaskStates(200));
  const std::string tracking = "; tracking: tool0 to its task target on 200 rows, max |p_des - p| 1 mm, rotation 0 mrad";
  r = RunCtl({"plot", log.string(), "-o", (dir_ / "log.png").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, (dir_ / "log.png").string() + ": 200 rows in 1 segment" + tracking + "; task: 200 rows of tool0\n");
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "-o", (dir_ / "csv").string()}).status, 0);
  r = RunCtl({"plot", (dir_ / "csv" / "ARM_STATE.csv").string(), "-o", (dir_ / "csv.png").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, (dir_ / "csv.png").string() + ": 200 rows in 1 segment" + tracking + "; task: 200 rows of tool0\n");

  std::ofstream(dir_ / "csv" / "ARM_TASK.csv") << "t,frame\n0,\"tool0\"\n";
  r = RunCtl({"plot", (dir_ / "csv" / "ARM_STATE.csv").string(), "-o", (dir_ / "csv.png").string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("lacks the columns position0"), std::string::npos) << r.err;
}

// An mpc controller with a frame follows that frame's target, not the joint
// setpoint (the start pose): from simulate's FILE.task.csv, plot draws the
// flange's tracking and path panels and no joint setpoint, and says so.
TEST_F(Logs, PlotDrawsAnMpcFramesPanelsAndNoJointSetpoint) {
  const fs::path csv = dir_ / "panda.csv", png = dir_ / "panda.png";
  auto r = RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mpc_reach.yaml", "--duration", "0.2",
                   "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  r = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("; tracking: panda_link8 to its task target on 200 rows, max |p_des - p| "), std::string::npos)
      << r.out;  // every row but t = 0, before the controller's first evaluation
  EXPECT_TRUE(r.out.ends_with("; task: 201 rows of panda_link8\n")) << r.out;
  EXPECT_EQ(r.out.find("q_des"), std::string::npos) << r.out;
}

// "max |p_des - p| X mm" of plot's tracking line, or NaN.
double MaxTaskErrorMm(const std::string& out) {
  const std::string key = "max |p_des - p| ";
  const std::size_t at = out.find(key);
  return at == std::string::npos ? std::nan("") : std::stod(out.substr(at + key.size()));
}

// The UR5's flange runs a circle under operational-space control: the controller follows the
// flange's task target and never the joint setpoint, which stays at the start pose (0.49 rad from
// the arm once it moves). plot's tracking panel is the flange's error to its target, within
// micrometres, and no joint is said to miss its setpoint.
TEST_F(Logs, PlotTracksTheFrameToItsTaskTargetUnderATaskSpaceController) {
  const fs::path csv = dir_ / "ur5.csv";
  auto r = RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/ur5_circle.yaml", "--duration", "1.5",
                   "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  r = RunCtl({"plot", csv.string(), "-o", (dir_ / "ur5.png").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("; tracking: flange to its task target on 1500 rows, max |p_des - p| "), std::string::npos)
      << r.out;  // every row but t = 0, before the controller's first evaluation
  EXPECT_LT(MaxTaskErrorMm(r.out), 0.05) << r.out;
  EXPECT_EQ(r.out.find("q_des"), std::string::npos) << r.out;
}

// An arm under the external controller: held (its fallback follows q_des) for 100 ticks, then
// driven by streamed torques for 200 more, moving 0.49 rad away from the hold's q_des. plot compares
// q with q_des only over the hold; with no hold at all, it says no row followed a setpoint.
TEST_F(Logs, PlotComparesQWithTheSetpointOnlyWhereAControllerFollowedIt) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> held_then_driven, driven;
  for (std::int64_t k = 0; k < 300; ++k) {
    state_t s = MakeState(k);
    s.controller = "external";
    s.mode = k < 100 ? state_t::MODE_HOLD : state_t::MODE_RUNNING;
    s.q_des = {0.25, 0.25};
    s.q = {0.25 + (k < 100 ? 0.0 : 0.49 * static_cast<double>(k - 100) / 199.0), 0.25};
    held_then_driven.emplace_back("ARM_STATE", Encode(s));
    if (k >= 100) driven.emplace_back("ARM_STATE", Encode(s));
  }
  const fs::path log = dir_ / "external.lcm", only_driven = dir_ / "driven.lcm";
  testing::WriteLcmLog(log.string(), held_then_driven);
  testing::WriteLcmLog(only_driven.string(), driven);
  auto r = RunCtl({"plot", log.string(), "-o", (dir_ / "external.png").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, (dir_ / "external.png").string() +
                       ": 300 rows in 1 segment; tracking: joints to q_des on 100 of 300 rows, max |q_des - q| 0\n");
  r = RunCtl({"plot", only_driven.string(), "-o", (dir_ / "driven.png").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, (dir_ / "driven.png").string() +
                       ": 200 rows in 1 segment; tracking: none (no row followed a joint setpoint or a task target)\n");
}

// Runs the plot script lagrangectl embeds (tools/plot.py) with lagrangectl's
// arguments (CSV PNG TITLE TELEMETRY FORCES STATUS JOINTS [TASK]) and, as the figure
// is saved, prints a line for each legend: how many panels' data areas, and
// how many axes' ticks and labels, its box overlaps, and whether it lies
// within the figure (nothing of it cut off). The cost panel's right-hand axis
// is a panel of its own here.
constexpr const char* kLegendCheck = R"(
import sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.figure

script = sys.argv.pop(1)
save = matplotlib.figure.Figure.savefig


def checked(fig, *args, **kwargs):
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    panels = [ax.get_window_extent(renderer) for ax in fig.axes]
    axes = [box for ax in fig.axes for box in (ax.xaxis.get_tightbbox(renderer), ax.yaxis.get_tightbbox(renderer))
            if box is not None]
    whole = fig.bbox
    for legend in [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]:
        box = legend.get_window_extent(renderer)
        within = whole.x0 <= box.x0 and box.x1 <= whole.x1 and whole.y0 <= box.y0 and box.y1 <= whole.y1
        print("legend %s: over %d panels' data, %d axes' ticks or labels, %s the figure"
              % (legend.get_texts()[0].get_text(), sum(box.overlaps(p) for p in panels),
                 sum(box.overlaps(a) for a in axes), "within" if within else "cut off by"))
    return save(fig, *args, **kwargs)


matplotlib.figure.Figure.savefig = checked
with open(script) as f:
    exec(compile(f.read(), script, "exec"), {"__name__": "__main__"})
)";

// The legend lines kLegendCheck prints for the plot of `args` (lagrangectl's
// arguments to the script after the PNG), in the order of the panels.
std::vector<std::string> LegendLines(const fs::path& png, std::vector<std::string> args) {
  const std::string python = access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
  std::vector<std::string> argv = {
      python, "-c", kLegendCheck, std::string(LAGRANGE_SOURCE_DIR) + "/tools/plot.py", args.at(0), png.string()};
  argv.insert(argv.end(), args.begin() + 1, args.end());
  const auto r = testing::RunProcess(argv);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> lines;
  for (const std::string& line : testing::Lines(r.out))
    if (line.rfind("legend ", 0) == 0) lines.push_back(line);
  return lines;
}

// What kLegendCheck prints for a legend whose first entry is `first` and that covers nothing.
std::string ClearLegend(const std::string& first) {
  return "legend " + first + ": over 0 panels' data, 0 axes' ticks or labels, within the figure";
}

// Every panel's legend stands beside the panels: over no panel's data (the
// cost panel's compute spikes were under its legend), over no axis's ticks or
// labels (the cost panel's right-hand axis is between), and whole in the
// picture. A run with every panel (states, ε, cost, forces), a robot with
// long joint names, and its end effector's panels beside a telemetry's.
TEST_F(Logs, PlotLegendsCoverNoPanelsDataNorAnyAxisAndLieWithinThePicture) {
  const fs::path log = dir_ / "arm.lcm";
  testing::WriteLcmLog(log.string(), ArmRunWithTelemetryAndForces(200));
  const fs::path csv = dir_ / "csv";
  ASSERT_EQ(RunCtl({"log2csv", log.string(), "-o", csv.string()}).status, 0);
  EXPECT_EQ(
      LegendLines(dir_ / "arm.png", {(csv / "ARM_STATE.csv").string(), "ARM_STATE",
                                     (csv / "ARM_TELEMETRY.csv").string(), (csv / "ARM_FORCES.csv").string(), "", ""}),
      (std::vector<std::string>{ClearLegend("q0"), ClearLegend("q0"), ClearLegend("T"), ClearLegend("q0"),
                                ClearLegend("ε = E - E(0) - W"), ClearLegend("evaluations (left axis)"),
                                ClearLegend("G (gravity)"), ClearLegend("G (gravity)")}));

  const fs::path ur5 = dir_ / "ur5.csv";
  ASSERT_EQ(RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/ur5_pd_gravity.yaml", "--duration", "0.2",
                    "--csv", ur5.string()})
                .status,
            0);
  EXPECT_EQ(LegendLines(dir_ / "ur5.png", {ur5.string(), "ur5.csv", "", "", "", (dir_ / "ur5.joints.csv").string()}),
            (std::vector<std::string>{ClearLegend("shoulder_pan_joint"), ClearLegend("shoulder_pan_joint"),
                                      ClearLegend("T"), ClearLegend("shoulder_pan_joint")}));

  // The end effector's panels (a task-space controller's frame: the tracking
  // error with its rotation on a right-hand axis, in the joints' tracking
  // panel's place, then its position) with the telemetry's.
  const fs::path circle = dir_ / "circle.csv";
  ASSERT_EQ(RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/ur5_circle.yaml", "--duration", "0.2",
                    "--csv", circle.string()})
                .status,
            0);
  EXPECT_EQ(
      LegendLines(dir_ / "circle.png", {circle.string(), "circle.csv", (csv / "ARM_TELEMETRY.csv").string(), "", "",
                                        (dir_ / "circle.joints.csv").string(), (dir_ / "circle.task.csv").string()}),
      (std::vector<std::string>{ClearLegend("shoulder_pan_joint"), ClearLegend("shoulder_pan_joint"), ClearLegend("T"),
                                ClearLegend("|p_des - p| (left axis)"), ClearLegend("x"),
                                ClearLegend("ε = E - E(0) - W"), ClearLegend("evaluations (left axis)")}));
}

}  // namespace
}  // namespace lagrange
