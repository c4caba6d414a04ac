// lagranged as a process (the security issue's list): every bad option or log
// file exits 2 with one line; signals that would kill it are ignored, SIGHUP
// reopens the log, SIGTERM stops it with its final status; the log reaches
// its file while it runs; a scene whose worst-case tick exceeds the period is
// refused; the I/O threads run SCHED_FIFO below the tick; --version and
// --log-level debug say more. Private LCM ports 7960-7979 and 8557-8559.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <thread>
#include <tuple>

#include "tests/support/mujoco_scenes.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::BackgroundProcess;
using testing::LcmCollector;
using testing::ReadFile;

constexpr double kExitWait = 10.0;    // s: generous, for "it ended at all"
constexpr double kAppearWait = 10.0;  // s: for a line or a file to appear

bool WaitUntil(const std::function<bool()>& condition, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

std::size_t Count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

class Service : public ::testing::Test {
 protected:
  void SetUp() override {
    // Children inherit the forking thread's mask: make sure the signals under test reach them.
    sigset_t signals;
    sigemptyset(&signals);
    for (int s : {SIGPIPE, SIGUSR1, SIGUSR2, SIGALRM, SIGHUP, SIGTERM, SIGINT}) sigaddset(&signals, s);
    pthread_sigmask(SIG_UNBLOCK, &signals, nullptr);
    dir_ = fs::temp_directory_path() / ("lagrange_service_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void Prepare(int port) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    url_ = testing::TestLcmUrl(port);
  }
  std::vector<std::string> Argv(std::vector<std::string> extra) const {
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return argv;
  }
  std::unique_ptr<BackgroundProcess> Start(std::vector<std::string> extra = {}) {
    return std::make_unique<BackgroundProcess>(Argv(std::move(extra)));
  }
  static void AwaitStates(LcmCollector& c, std::size_t n = 10) {
    ASSERT_TRUE(c.WaitFor(
        "ARM_STATE", [&](const auto& m) { return m.size() >= n; }, 20.0))
        << "no ARM_STATE";
  }
  static std::string Scene(const std::string& name) { return std::string(LAGRANGE_SOURCE_DIR) + "/config/" + name; }

  fs::path dir_;
  std::string url_;
};

// Exit 2 and exactly one line on stderr, naming what was wrong.
void ExpectOneLineRefusal(const testing::ProcessResult& r, const std::string& names) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
  EXPECT_NE(r.err.find(names), std::string::npos) << r.err;
}

TEST_F(Service, AnUnwritableLogFileExitsTwoWithOneLineAndCreatesNothing) {
  Prepare(7960);
  for (const std::string& path : {std::string("/nonexistent/lagrange_dir/x.log"), dir_.string()}) {
    const auto r = testing::RunProcess(Argv({"--log-file", path, "--duration", "0.1"}), 60.0);
    ExpectOneLineRefusal(r, "lagranged: --log-file '" + path + "': cannot open");
  }
  EXPECT_FALSE(fs::exists("/nonexistent/lagrange_dir"));  // a missing directory is never created
}

// Issue 32: a log file that takes no line (/dev/full took every one, silently,
// and exited 0; at a file size limit SIGXFSZ killed the daemon) is refused at
// start, exit 2, saying why.
TEST_F(Service, ALogFileThatCannotBeWrittenExitsTwoAtStartSayingWhy) {
  Prepare(8558);
  const auto full = testing::RunProcess(Argv({"--log-file", "/dev/full", "--duration", "0.1"}), 60.0);
  ExpectOneLineRefusal(full, "lagranged: --log-file '/dev/full': cannot open: not a regular file (a character device)");
  const fs::path log = dir_ / "limited.log";
  std::vector<std::string> argv = {"/bin/sh", "-c", "ulimit -f 0 && exec \"$@\"", "sh"};
  for (const std::string& a : Argv({"--log-file", log.string(), "--duration", "0.1"})) argv.push_back(a);
  const auto limited = testing::RunProcess(argv, 60.0);
  EXPECT_EQ(limited.exit_code, 2) << limited.err;
  EXPECT_NE(limited.err.find("--log-file '" + log.string() + "': cannot write: File too large"), std::string::npos)
      << limited.err;
}

// Issue 32: an empty key path (an unset variable in a unit or a script) ran
// unsigned without a word; an all-zero key was taken; a key behind a
// symbolic link (a Kubernetes secret mount) was refused as "Too many levels
// of symbolic links". Each is refused in one line saying what it is.
TEST_F(Service, AnEmptyKeyPathAZeroKeyOrASymlinkedKeyIsRefusedSayingWhy) {
  Prepare(8559);
  ExpectOneLineRefusal(testing::RunProcess(Argv({"--bus-key", "", "--duration", "0.1"}), 60.0),
                       "bus key '': an empty path (an unset variable in a unit or script?)");
  ExpectOneLineRefusal(
      testing::RunProcess({"/usr/bin/env", "LAGRANGE_BUS_KEY_FILE=", LAGRANGED_PATH, "--lcm-url", url_, "--duration",
                           "0.1"},
                          60.0),
      "$LAGRANGE_BUS_KEY_FILE is set but empty");
  const fs::path zeros = dir_ / "zeros.key";
  std::ofstream(zeros, std::ios::binary) << std::string(32, '\0');
  fs::permissions(zeros, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  ExpectOneLineRefusal(testing::RunProcess(Argv({"--bus-key", zeros.string(), "--duration", "0.1"}), 60.0),
                       "bus key " + zeros.string() + ": every byte is 0x00: a placeholder, not a random key");
  const fs::path key = dir_ / "..data" / "bus.key";
  fs::create_directories(key.parent_path());
  std::string bytes(32, '\0');
  std::mt19937 rng{42};
  for (char& b : bytes) b = static_cast<char>(rng());
  std::ofstream(key, std::ios::binary) << bytes;
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  const fs::path link = dir_ / "bus.key";
  fs::create_symlink("..data/bus.key", link);
  const auto linked = testing::RunProcess(Argv({"--bus-key", link.string(), "--duration", "0.1"}), 60.0);
  ExpectOneLineRefusal(linked, "bus key " + link.string() + ": a symbolic link (to ..data/bus.key)");
  EXPECT_NE(linked.err.find("name the key file itself (" + fs::canonical(key).string() + ")"), std::string::npos)
      << linked.err;
  EXPECT_EQ(linked.err.find("Too many levels"), std::string::npos) << linked.err;
}

// Issue 32: a daemon without a key says at start that its bus is unsigned.
TEST_F(Service, AnUnsignedBusIsSaidAtStart) {
  Prepare(8557);
  const auto r = testing::RunProcess(Argv({"--duration", "0.2"}), 60.0);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("bus unsigned: anyone who can send to " + url_ + " can command these instances"),
            std::string::npos)
      << r.err;
}

TEST_F(Service, BadLcmUrlsAndOptionsExitTwoWithOneLine) {
  for (const std::string& url : {std::string("tcpq://127.0.0.1:1"), std::string("udpm://239.255.76.67:7667?ttl=abc"),
                                 std::string("udpm://239.255.76.67:7667?ttl=300")}) {
    // --duration: should a URL be accepted after all, the run still ends.
    const auto r = testing::RunProcess({LAGRANGED_PATH, "--lcm-url", url, "--duration", "0.1"}, 60.0);
    ExpectOneLineRefusal(r, "'" + url + "'");
  }
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--overrun", "sometimes"}, std::vector<std::string>{"--rt-priority", "0"},
        std::vector<std::string>{"--log-level", "loud"}, std::vector<std::string>{"--no-such-option"}}) {
    std::vector<std::string> argv = {LAGRANGED_PATH};
    argv.insert(argv.end(), bad.begin(), bad.end());
    ExpectOneLineRefusal(testing::RunProcess(argv, 60.0), "lagranged: ");
  }
}

// Starts lagranged with stderr a pipe whose read end is already closed, stdout /dev/null.
pid_t StartWithClosedStderr(const std::vector<std::string>& argv) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return -1;
  close(fds[0]);  // no reader from the first byte on
  const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
  const pid_t pid = testing::Spawn(argv, null, fds[1]);
  close(null);
  close(fds[1]);
  return pid;
}

// Exit status (128 + signal if killed), or -1 if still running after `timeout_s`.
int WaitForExit(pid_t pid, double timeout_s) {
  int status = 0;
  pid_t r = 0;
  WaitUntil([&] { return (r = waitpid(pid, &status, WNOHANG)) != 0; }, timeout_s);
  if (r != pid) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST_F(Service, AClosedStderrDoesNotKillItAndSigtermStillEndsItCleanly) {
  Prepare(7962);
  LcmCollector states(url_, "ARM_STATE");
  const pid_t pid = StartWithClosedStderr(Argv({}));
  ASSERT_GT(pid, 0);
  AwaitStates(states);  // it logged its start-up lines into the closed pipe and runs
  kill(pid, SIGTERM);   // the final status goes into the closed pipe too
  EXPECT_EQ(WaitForExit(pid, kExitWait), 0);
}

// Start-up (the scene, the work bound, each method's timing) runs while the
// main thread answers signals: a SIGTERM during it stops lagranged there,
// exit 0, its line logged, however long the scene would take to start.
TEST_F(Service, SigtermDuringStartUpStopsItThere) {
  Prepare(7970);
  // Many long chains: a start-up of seconds (each instance's methods are timed).
  std::string scene = "period: 0.001\ninstances:\n";
  for (int i = 0; i < 60; ++i) {
    scene += "  - {name: c" + std::to_string(i) + ", plant: {type: chain, method: lagrangian, params: {links: 48}}}\n";
  }
  const fs::path file = dir_ / "slow_start.yaml";
  std::ofstream(file) << scene;
  auto daemon = Start({"--config", file.string()});
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  daemon->Signal(SIGTERM);
  ASSERT_EQ(daemon->Wait(kExitWait), 0) << daemon->Stderr();
  EXPECT_NE(daemon->Stderr().find("stopped by signal 15 during start-up"), std::string::npos) << daemon->Stderr();
  EXPECT_EQ(daemon->Stderr().find("scene "), std::string::npos) << "the loop never started";
}

// --mlockall refused for want of lockable memory: lagranged goes on without
// it, and its warning names RLIMIT_MEMLOCK, the limit, and how to raise it.
// Root's lagranged is made to lack CAP_IPC_LOCK by util-linux's setpriv
// (dropped from the bounding and inheritable sets before the exec).
// AddressSanitizer intercepts mlockall (it returns 0 and locks nothing), so
// under it (scripts/test's sanitizer tree) the refusal cannot happen: the
// test runs in a plain build (build/).
TEST_F(Service, AnMlockallRefusedForLockedMemoryNamesRlimitMemlock) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's mlockall locks nothing and never fails";
#endif
  Prepare(7972);
  std::string command = "ulimit -l 64 && exec";
  for (const std::string& a : Argv({"--mlockall", "--duration", "0.2"})) command += " '" + a + "'";
  std::vector<std::string> argv = {"/bin/bash", "-c", command};
  if (geteuid() == 0) argv.insert(argv.begin(), {"/usr/bin/setpriv", "--bounding-set", "-ipc_lock", "--inh-caps", "-ipc_lock"});
  const auto r = testing::RunProcess(argv, 60.0);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("mlockall: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" (RLIMIT_MEMLOCK is 64 KiB: raise it, e.g. LimitMEMLOCK=infinity in the service unit or "
                       "ulimit -l, or run as root)"),
            std::string::npos)
      << r.err;
}

// A FIFO as the scene would block the reader forever: refused at once.
TEST_F(Service, AFifoAsTheSceneIsRefusedWithoutWaitingForAWriter) {
  Prepare(7971);
  const fs::path fifo = dir_ / "scene.fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto r = testing::RunProcess(Argv({"--config", fifo.string()}), 60.0);
  ExpectOneLineRefusal(r, fifo.string() + ": not a regular file (a FIFO)");
}

TEST_F(Service, SighupReopensTheLogFileAfterLogrotateRenamedIt) {
  Prepare(7963);
  const fs::path log = dir_ / "lagranged.log";
  const fs::path rotated = dir_ / "lagranged.log.rotated";
  auto daemon = Start({"--log-file", log.string()});
  ASSERT_TRUE(WaitUntil([&] { return ReadFile(log).find("scene ") != std::string::npos; }, kAppearWait))
      << daemon->Stderr();
  fs::rename(log, rotated);
  daemon->Signal(SIGHUP);
  ASSERT_TRUE(WaitUntil([&] { return fs::exists(log) && ReadFile(log).find("reopened (SIGHUP)") != std::string::npos; },
                        kAppearWait))
      << daemon->Stderr();
  EXPECT_TRUE(daemon->Running());
  daemon->Signal(SIGTERM);
  ASSERT_EQ(daemon->Wait(kExitWait), 0) << daemon->Stderr();
  EXPECT_NE(ReadFile(log).find("stopped by signal 15"), std::string::npos) << ReadFile(log);  // the new file
  EXPECT_NE(ReadFile(rotated).find("scene "), std::string::npos);                             // the old one kept
  EXPECT_EQ(ReadFile(rotated).find("stopped by signal"), std::string::npos);
}

TEST_F(Service, StraySignalsAreIgnoredAndTheFinalStatusIsStillLogged) {
  Prepare(7964);
  LcmCollector states(url_, "ARM_STATE");
  auto daemon = Start();
  AwaitStates(states);
  for (int s : {SIGUSR1, SIGUSR2, SIGALRM, SIGPIPE}) daemon->Signal(s);
  // It keeps ticking after them: more states arrive than had when they were sent.
  const std::size_t before = states.Count("ARM_STATE");
  AwaitStates(states, before + 200);
  EXPECT_TRUE(daemon->Running());
  daemon->Signal(SIGTERM);
  ASSERT_EQ(daemon->Wait(kExitWait), 0) << daemon->Stderr();
  EXPECT_NE(daemon->Stderr().find("stopped by signal 15"), std::string::npos) << daemon->Stderr();
}

TEST_F(Service, StartUpLinesReachTheLogFileAndItsStartRecordWhileItRuns) {
  Prepare(7965);
  const fs::path log = dir_ / "lagranged.log";
  auto daemon = Start({"--log-file", log.string()});
  // Info lines sit in the file's buffer until a flush: the once-a-second flush writes them.
  ASSERT_TRUE(WaitUntil([&] { return ReadFile(log).find("scene ") != std::string::npos; }, kAppearWait))
      << daemon->Stderr();
  EXPECT_TRUE(daemon->Running());
  const std::string start = ReadFile(log.string() + ".start");
  EXPECT_NE(start.find("scene " + Scene("default.yaml")), std::string::npos) << start;
  EXPECT_NE(start.find("  arm: "), std::string::npos) << start;
  daemon->Signal(SIGTERM);
  ASSERT_EQ(daemon->Wait(kExitWait), 0) << daemon->Stderr();
  // The start record holds the start-up only; the log holds everything.
  EXPECT_EQ(ReadFile(log.string() + ".start").find("stopped"), std::string::npos);
  EXPECT_NE(ReadFile(log).find("stopped by signal 15"), std::string::npos);
}

TEST_F(Service, ASceneWhoseWorstCaseTickExceedsThePeriodIsRefusedNamingMaxSteps) {
  Prepare(7966);
  // The scene: damping 2e8 makes dopri5 take ~1e5 steps per tick; max_steps 1e7
  // let one tick run for 13.7 s, and SIGTERM waited for it.
  const fs::path scene = dir_ / "stiff.yaml";
  std::ofstream(scene) << "period: 0.001\n"
                          "instances:\n"
                          "  - name: pendulum\n"
                          "    plant: {type: pendulum}\n"
                          "    initial: {q: [1.0]}\n"
                          "    effects: {damping: [2.0e8]}\n"
                          "    integrator: {type: dopri5, max_steps: 10000000}\n"
                          "    controller: {type: none}\n";
  const auto r = testing::RunProcess(Argv({"--config", scene.string()}), 60.0);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(scene.string() + ": the instances' worst case per tick, "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(pendulum: dopri5 worst case 60000002 evaluations"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("does not fit 80 % of the period 1 ms; for instances[0] (pendulum), the largest, lower "
                       "integrator.max_steps (at most "),
            std::string::npos)
      << r.err;
}

TEST_F(Service, EveryShippedSceneFitsItsPeriod) {
  Prepare(7967);
  for (const auto& entry : fs::directory_iterator(std::string(LAGRANGE_SOURCE_DIR) + "/config")) {
    if (entry.path().extension() != ".yaml" || testing::NeedsMujocoThisBuildLacks(entry.path())) continue;
    const auto r = testing::RunProcess(Argv({"--config", entry.path().string(), "--duration", "0.05"}), 60.0);
    EXPECT_EQ(r.exit_code, 0) << entry.path() << ": " << r.err;
  }
}

// Each thread of a process: name (comm) → (policy, rt_priority), from /proc/PID/task/TID/stat.
std::map<std::string, std::pair<int, int>> ThreadScheduling(int pid) {
  std::map<std::string, std::pair<int, int>> threads;
  for (const auto& task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task")) {
    std::string comm = ReadFile(task.path() / "comm");
    if (!comm.empty() && comm.back() == '\n') comm.pop_back();
    const std::string stat = ReadFile(task.path() / "stat");
    std::istringstream fields(stat.substr(stat.rfind(')') + 2));  // from field 3 on
    std::vector<std::string> f;
    for (std::string w; fields >> w;) f.push_back(w);
    if (f.size() < 39) continue;
    threads[comm] = {std::stoi(f[41 - 3]), std::stoi(f[40 - 3])};  // policy (41), rt_priority (40)
  }
  return threads;
}

TEST_F(Service, PublishAndReceiveThreadsRunFifoJustBelowTheTick) {
  Prepare(7968);
  LcmCollector states(url_, "ARM_STATE");
  for (const auto& [tick, publish, receive] : {std::tuple{10, 9, 8}, std::tuple{2, 1, 1}}) {  // clamped at 1
    auto daemon = Start({"--rt-priority", std::to_string(tick)});
    AwaitStates(states, states.Count("ARM_STATE") + 10);
    const auto threads = ThreadScheduling(daemon->pid());
    daemon->Signal(SIGTERM);
    ASSERT_EQ(daemon->Wait(kExitWait), 0) << daemon->Stderr();
    const std::string err = daemon->Stderr();
    if (err.find("real-time set-up not permitted") != std::string::npos) {
      // Refused here (no CAP_SYS_NICE, RLIMIT_RTPRIO 0): said once for all three threads.
      EXPECT_EQ(Count(err, "real-time set-up not permitted"), 1u) << err;
      GTEST_SKIP() << "SCHED_FIFO not permitted on this machine: " << err;
    }
    ASSERT_TRUE(threads.count("lagranged-tick") && threads.count("lagranged-pub") && threads.count("lagranged-recv"));
    EXPECT_EQ(threads.at("lagranged-tick"), std::make_pair(SCHED_FIFO, tick));
    EXPECT_EQ(threads.at("lagranged-pub"), std::make_pair(SCHED_FIFO, publish));
    EXPECT_EQ(threads.at("lagranged-recv"), std::make_pair(SCHED_FIFO, receive));
    for (const auto& [name, sched] : threads) {  // main, spdlog's flusher: ordinary threads
      if (name != "lagranged-tick" && name != "lagranged-pub" && name != "lagranged-recv") {
        EXPECT_EQ(sched.first, SCHED_OTHER) << name;
      }
    }
  }
}

TEST_F(Service, VersionPrintsTheProjectVersion) {
  const auto r = testing::RunProcess({LAGRANGED_PATH, "--version"}, 60.0);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out, std::string("lagranged ") + LAGRANGE_VERSION + "\n");
}

TEST_F(Service, DebugLevelAddsEachThreadsRealtimeOutcomeAndTheWorkBound) {
  Prepare(7969);
  const auto info = testing::RunProcess(Argv({"--duration", "0.1"}), 60.0);
  const auto debug = testing::RunProcess(Argv({"--duration", "0.1", "--log-level", "debug"}), 60.0);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  ASSERT_EQ(debug.exit_code, 0) << debug.err;
  EXPECT_EQ(info.err.find(" debug "), std::string::npos) << info.err;
  for (const char* line : {"real-time: memory not locked", "real-time: tick thread runs SCHED_OTHER",
                           "real-time: publish thread runs SCHED_OTHER", "real-time: receive thread runs SCHED_OTHER",
                           "work bound: arm: worst case 5 evaluations"}) {
    EXPECT_NE(debug.err.find(line), std::string::npos) << line << "\n" << debug.err;
  }
  EXPECT_GT(testing::Lines(debug.err).size(), testing::Lines(info.err).size());
}

}  // namespace
}  // namespace lagrange
