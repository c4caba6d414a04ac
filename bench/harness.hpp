#pragma once
// What the process-level benchmarks (loop_bench, hostile_bench) share: the
// private LCM URL, clocks, child processes (lagranged, cyclictest,
// lcm-logger) and reading what lcm-logger recorded.

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace lagrange::bench {

// The options of a benchmark that runs lagranged on the project's scenes:
// --lagranged (default: ../daemon/lagranged beside this program, when there),
// --config-dir (`config_help` says what it must hold), --out and --port (a
// private LCM port on udpm://239.255.76.67).
void AddDaemonOptions(CLI::App& app, std::string& lagranged, std::string& config_dir, std::string& out, int& port,
                      const std::string& config_help);

// udpm://239.255.76.67:PORT?ttl=0 (this host only).
std::string Url(int port);

// steady clock, ns.
std::int64_t MonotonicNs();
// wall clock, µs since the Unix epoch (as in the messages' utime).
std::int64_t WallMicros();

// "" when a message published on `url` comes back to this process, else what to do about it.
std::string CheckLoopback(const std::string& url);

// /proc/loadavg's first three fields.
std::string LoadAverage();

// Starts `argv` (argv[0] looked up in PATH when it has no '/') with stdout
// and stderr in `log` (nothing when empty); returns its pid. With
// `timer_slack_ns` > 0 the child sets its timer slack first (inherited by its
// threads and kept across exec). Returns -1 when fork fails. lagrange::Spawn
// (tools/spawn.hpp) does the fork and exec.
pid_t Spawn(const std::vector<std::string>& argv, const std::filesystem::path& log, unsigned long timer_slack_ns = 0);

struct Exit {
  int status = -1;   // exit code, 128 + signal, or -1 if it had to be killed
  double cpu = 0.0;  // s, user + system over the whole run
};
// Waits up to `timeout_s` for `pid`, then kills it (SIGKILL).
Exit WaitExit(pid_t pid, double timeout_s);
// "exit 0", "signal 11 (SIGSEGV)", "killed (did not exit)".
std::string DescribeExit(int status);

// Debian's lcm-logger recording the channels matching `channels` (an LCM
// regular expression, anchored by LCM) on `url` into `file`.
class LcmLogger {
 public:
  LcmLogger(const std::string& url, const std::string& channels, const std::filesystem::path& file,
            const std::filesystem::path& log);
  ~LcmLogger();
  LcmLogger(const LcmLogger&) = delete;
  LcmLogger& operator=(const LcmLogger&) = delete;

  // Publishes a marker on `url` until the logger has written it (true), at most `timeout_s`.
  bool AwaitReady(double timeout_s = 5.0);
  // SIGINT, then waits for its exit (lcm-logger flushes and closes the file).
  Exit Stop();
  pid_t pid() const { return pid_; }

 private:
  std::string url_;
  std::filesystem::path file_;
  pid_t pid_ = -1;
  bool stopped_ = false;
};

// The state_t ticks recorded in an LCM log, by channel, for the channels in
// `channels`; only messages of `run_id` unless it is 0. A truncated last
// event (a logger that crashed) ends the read.
std::map<std::string, std::vector<std::int64_t>> ReadStateTicks(const std::filesystem::path& file,
                                                                const std::vector<std::string>& channels,
                                                                std::int64_t run_id);

// cyclictest's command line for a 1 kHz, one-thread run of `seconds` (whole
// seconds) writing its histogram (µs bins up to `histogram_us`) and summary
// to `json`. SCHED_OTHER unless `fifo_priority` > 0; pinned when `cpu` >= 0;
// `--mlockall` when `mlockall`. Always --default-system: cyclictest must not
// tune the machine (/dev/cpu_dma_latency) for the daemon beside it.
std::vector<std::string> CyclictestArgs(int seconds, const std::filesystem::path& json, int fifo_priority, int cpu,
                                        bool mlockall, int histogram_us = 20000);

// p50, p99 and max of a sample, nearest rank (as lagranged's status_t); NaN for none.
struct Summary {
  std::size_t n = 0;
  double p50 = std::numeric_limits<double>::quiet_NaN();
  double p99 = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
};
Summary Summarize(std::vector<double> v);

}  // namespace lagrange::bench
