#pragma once
// What the process-level benchmarks (loop_bench, hostile_bench,
// external_bench, live_bench) share: the private LCM URL, clocks and waiting,
// child processes (lagranged, cyclictest, lcm-logger), the messages they send
// and reading what lcm-logger recorded. Their options and set-up are
// bench/options.hpp; statistics bench/stats.hpp.

#include <netinet/in.h>
#include <sys/types.h>
#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "protocol/lcm_log.hpp"
#include "protocol/wire.hpp"

namespace lagrange::bench {

using Clock = std::chrono::steady_clock;

// ---- the bus ----------------------------------------------------------------------------

// udpm://239.255.76.67:PORT?ttl=0 (this host only).
std::string Url(int port);

// `url` with a 4 MiB receive buffer (net.core.rmem_max on Debian's default):
// a receiver descheduled on a busy machine must not lose what it counts.
std::string WithReceiveBuffer(const std::string& url);

// LCM on this host only needs multicast routed through the loopback
// interface. As root, adds the route when it is missing (ip link set lo
// multicast on; ip route add 239.255.0.0/16 dev lo); then "" when a message
// published on `url` comes back to this process, else what to do about it.
std::string PrepareLoopback(const std::string& url);

// ---- raw datagrams ------------------------------------------------------------------------

// What a hostile sender puts on the wire, written here rather than with the
// bus's formatter (a hostile sender does not use our code).
using Bytes = std::vector<std::uint8_t>;
// An LC02 datagram: magic, `seqno`, `channel`, NUL, `payload`.
Bytes Lc02(std::uint32_t seqno, std::string_view channel, std::span<const std::uint8_t> payload);

// A plain UDP socket sending to the bench group 239.255.76.67:`port` (multicast TTL 0, loopback on).
class RawSender {
 public:
  explicit RawSender(int port);
  ~RawSender();
  RawSender(const RawSender&) = delete;
  RawSender& operator=(const RawSender&) = delete;
  bool ok() const { return fd_ >= 0; }
  // Sends `b` as one datagram (blocking); false when not all of it went.
  bool Send(std::span<const std::uint8_t> b);

 private:
  int fd_ = -1;
  sockaddr_in to_{};
};

// ---- clocks and waiting --------------------------------------------------------------------

// steady clock, ns.
std::int64_t MonotonicNs();
// wall clock, µs since the Unix epoch (as in the messages' utime).
std::int64_t WallMicros();

// Polls `done` every `poll` until it holds (true) or `timeout_s` has passed (false).
template <class Done>
bool Await(Done done, double timeout_s, Clock::duration poll = std::chrono::milliseconds(1)) {
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  while (!done()) {
    if (Clock::now() > deadline) return false;
    std::this_thread::sleep_for(poll);
  }
  return true;
}

// A prober's schedule: one wake every `period` plus 0–999 µs of seeded
// jitter (std::mt19937{42}), on absolute deadlines from construction, so that
// it does not lock to the tick's phase and two runs draw the same jitter.
class JitteredSchedule {
 public:
  explicit JitteredSchedule(Clock::duration period);
  // Sleeps until the next deadline.
  void SleepUntilNext();

 private:
  Clock::duration period_;
  Clock::time_point next_;
  std::mt19937 rng_{42};
  std::uniform_int_distribution<int> jitter_us_{0, 999};
};

// /proc/loadavg's first three fields.
std::string LoadAverage();

// ---- child processes -------------------------------------------------------------------------

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
// SIGTERM to `pid`, then WaitExit.
Exit Terminate(pid_t pid, double timeout_s);
// "exit 0", "signal 11 (SIGSEGV)", "killed (did not exit)".
std::string DescribeExit(int status);

// lagranged's command line on `url`, warnings and errors logged, on `scene`
// ("": the daemon's default scene); with `rt_priority` > 0 also --mlockall
// --rt-priority P (SCHED_FIFO tick P, publish P − 1, receive P − 2).
std::vector<std::string> LagrangedArgs(const std::string& lagranged, const std::string& scene, const std::string& url,
                                       int rt_priority = 0);

// cyclictest's command line for a 1 kHz, one-thread run of `seconds` (whole
// seconds) writing its histogram (µs bins up to `histogram_us`) and summary
// to `json`. SCHED_OTHER unless `fifo_priority` > 0; pinned when `cpu` >= 0;
// `--mlockall` when `mlockall`. Always --default-system: cyclictest must not
// tune the machine (/dev/cpu_dma_latency) for the daemon beside it.
std::vector<std::string> CyclictestArgs(int seconds, const std::filesystem::path& json, int fifo_priority, int cpu,
                                        bool mlockall, int histogram_us = 20000);

// ---- what the benchmarks send -----------------------------------------------------------------

// A setpoint for q (rad or m) at rest: qd and qdd zero.
setpoint_t SetpointMessage(std::int64_t utime, std::vector<double> q);
// A command of `kind` stamped now (WallMicros), with no gains and every other field zero or empty.
command_t CommandMessage(std::int8_t kind, std::int64_t request_id);

// The bits of a vector, as a key: the daemon passes setpoints and torques
// through bit for bit, so that is how they are matched.
std::string Bits(std::span<const double> v);

// ---- lcm-logger and its logs ---------------------------------------------------------------------

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

// Calls `on_event` for each event of the LCM log `file` (protocol/lcm_log.hpp:
// a truncated last event, a logger that crashed, ends the read); false, and
// no call, when the file cannot be read as a log.
bool ForEachLogEvent(const std::filesystem::path& file, const std::function<void(const LcmLogEvent&)>& on_event);

// The state_t ticks recorded in an LCM log, by channel, for the channels in
// `channels`; only messages of `run_id` unless it is 0.
std::map<std::string, std::vector<std::int64_t>> ReadStateTicks(const std::filesystem::path& file,
                                                                const std::vector<std::string>& channels,
                                                                std::int64_t run_id);

// The ticks in [from, to) that `ticks` lacks (a tick logged twice counts once).
std::int64_t TicksMissing(std::vector<std::int64_t> ticks, std::int64_t from, std::int64_t to);

}  // namespace lagrange::bench
