#include "bench/harness.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <signal.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <lagrange/state_t.hpp>

#include <algorithm>
#include <cstring>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include "protocol/big_endian.hpp"
#include "protocol/bus.hpp"
#include "protocol/lcm_log.hpp"
#include "protocol/receive.hpp"
#include "tools/spawn.hpp"

namespace lagrange::bench {

namespace fs = std::filesystem;

std::string Url(int port) { return "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0"; }

std::string WithReceiveBuffer(const std::string& url) { return url + "&recv_buf_size=4194304"; }

Bytes Lc02(std::uint32_t seqno, std::string_view channel, std::span<const std::uint8_t> payload) {
  Bytes b(8 + channel.size() + 1 + payload.size(), 0);  // sized once (g++ 12 misreads a push_back after an insert)
  WriteBigEndian32(0x4c433032, b.data());                // "LC02"
  WriteBigEndian32(seqno, b.data() + 4);
  std::memcpy(b.data() + 8, channel.data(), channel.size());
  if (!payload.empty()) std::memcpy(b.data() + 8 + channel.size() + 1, payload.data(), payload.size());
  return b;
}

RawSender::RawSender(int port) {
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  const unsigned char ttl = 0, loop = 1;
  setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop);
  to_.sin_family = AF_INET;
  to_.sin_port = htons(static_cast<std::uint16_t>(port));
  inet_pton(AF_INET, "239.255.76.67", &to_.sin_addr);
}

RawSender::~RawSender() {
  if (fd_ >= 0) close(fd_);
}

bool RawSender::Send(std::span<const std::uint8_t> b) {
  return sendto(fd_, b.data(), b.size(), 0, reinterpret_cast<const sockaddr*>(&to_), sizeof to_) ==
         static_cast<ssize_t>(b.size());
}

std::int64_t MonotonicNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

std::int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string PrepareLoopback(const std::string& url) {
  if (geteuid() == 0 && std::system("ip route show 239.255.0.0/16 2>/dev/null | grep -q 'dev lo'") != 0 &&
      std::system("ip link set lo multicast on && ip route add 239.255.0.0/16 dev lo") != 0) {
    return "could not add the multicast route on lo (ip link set lo multicast on; ip route add 239.255.0.0/16 dev lo)";
  }
  std::unique_ptr<Bus> in, out;
  try {
    in = OpenBus(url);
    out = OpenBus(url);
  } catch (const BusError& e) {
    return e.what();
  }
  int received = 0;
  in->Subscribe("LAGRANGE_BENCH_LOOPBACK", [&](std::string_view, const std::uint8_t*, std::size_t) { ++received; });
  for (int i = 0; i < 20 && received == 0; ++i) {
    const char byte = 1;
    out->Publish("LAGRANGE_BENCH_LOOPBACK", &byte, 1);
    in->Handle(50);
  }
  if (received > 0) return "";
  return "LCM multicast does not loop back; as root: ip link set lo multicast on; ip route add 239.255.0.0/16 dev lo";
}

JitteredSchedule::JitteredSchedule(Clock::duration period) : period_(period), next_(Clock::now()) {}

void JitteredSchedule::SleepUntilNext() {
  next_ += period_ + std::chrono::microseconds(jitter_us_(rng_));
  std::this_thread::sleep_until(next_);
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

pid_t Spawn(const std::vector<std::string>& argv, const fs::path& log, unsigned long timer_slack_ns) {
  // The log is opened here, before fork, close-on-exec (no other child
  // inherits it); the child gets it as stdout and stderr. If it cannot be
  // opened the child keeps this process's, as it did when the child opened it.
  const std::string log_path = log.empty() ? "/dev/null" : log.string();
  const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  SpawnOptions options;
  options.stdout_fd = fd;
  options.stderr_fd = fd;
  options.search_path = true;
  options.timer_slack_ns = timer_slack_ns;
  const pid_t pid = lagrange::Spawn(argv, options);
  if (fd >= 0) close(fd);
  return pid;
}

Exit WaitExit(pid_t pid, double timeout_s) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  rusage usage{};
  pid_t done = 0;
  while ((done = wait4(pid, &status, WNOHANG, &usage)) == 0 && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  Exit e;
  if (done == 0) {
    kill(pid, SIGKILL);
    wait4(pid, &status, 0, &usage);
  } else if (done == pid) {
    e.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  e.cpu = seconds(usage.ru_utime) + seconds(usage.ru_stime);
  return e;
}

Exit Terminate(pid_t pid, double timeout_s) {
  kill(pid, SIGTERM);
  return WaitExit(pid, timeout_s);
}

std::string DescribeExit(int status) {
  if (status < 0) return "killed (did not exit)";
  if (status > 128) {
    const char* name = sigabbrev_np(status - 128);
    return "signal " + std::to_string(status - 128) + (name ? std::string(" (SIG") + name + ")" : "");
  }
  return "exit " + std::to_string(status);
}

std::vector<std::string> LagrangedArgs(const std::string& lagranged, const std::string& scene, const std::string& url,
                                       int rt_priority) {
  std::vector<std::string> argv = {lagranged, "--lcm-url", url, "--log-level", "warn"};
  if (!scene.empty()) argv.insert(argv.end(), {"--config", scene});
  if (rt_priority > 0) argv.insert(argv.end(), {"--mlockall", "--rt-priority", std::to_string(rt_priority)});
  return argv;
}

// ---- what the benchmarks send ------------------------------------------------------

setpoint_t SetpointMessage(std::int64_t utime, std::vector<double> q) {
  setpoint_t sp;
  sp.utime = utime;
  sp.num_dofs = static_cast<std::int32_t>(q.size());
  sp.qd.assign(q.size(), 0.0);
  sp.qdd.assign(q.size(), 0.0);
  sp.q = std::move(q);
  return sp;
}

command_t CommandMessage(std::int8_t kind, std::int64_t request_id) {
  command_t c{};
  c.utime = WallMicros();
  c.request_id = request_id;
  c.command = kind;
  c.num_gains = 0;
  return c;
}

std::string Bits(std::span<const double> v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size_bytes());
}

// ---- lcm-logger -------------------------------------------------------------------

namespace {
constexpr const char* kMarkChannel = "LAGRANGE_BENCH_MARK";
}

LcmLogger::LcmLogger(const std::string& url, const std::string& channels, const fs::path& file, const fs::path& log)
    : url_(url), file_(file) {
  fs::remove(file);
  pid_ = Spawn({"lcm-logger", "--quiet", "--force", "--lcm-url=" + url,
                "--channel=(" + channels + "|" + kMarkChannel + ")", file.string()},
               log);
}

LcmLogger::~LcmLogger() {
  if (!stopped_) Stop();
}

bool LcmLogger::AwaitReady(double timeout_s) {
  std::unique_ptr<Bus> bus = OpenBus(url_);
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (Clock::now() < deadline) {
    if (waitpid(pid_, nullptr, WNOHANG) != 0) return false;
    const char byte = 1;
    bus->Publish(kMarkChannel, &byte, 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    std::error_code error;
    if (fs::file_size(file_, error) > 0 && !error) return true;
  }
  return false;
}

Exit LcmLogger::Stop() {
  stopped_ = true;
  kill(pid_, SIGINT);
  return WaitExit(pid_, 5.0);
}

bool ForEachLogEvent(const fs::path& file, const std::function<void(const LcmLogEvent&)>& on_event) {
  std::optional<LcmLogReader> log;
  try {
    log.emplace(file.string());
  } catch (const LcmLogError&) {
    return false;
  }
  while (const LcmLogEvent* event = log->Next()) on_event(*event);
  return true;
}

std::map<std::string, std::vector<std::int64_t>> ReadStateTicks(const fs::path& file,
                                                                const std::vector<std::string>& channels,
                                                                std::int64_t run_id) {
  std::map<std::string, std::vector<std::int64_t>> ticks;
  for (const std::string& c : channels) ticks[c];
  state_t s;
  ForEachLogEvent(file, [&](const LcmLogEvent& event) {
    const auto it = ticks.find(std::string(event.channel));
    if (it == ticks.end()) return;
    if (ReceiveInto(s, event.data, event.size, Framing::kRecorded) != Drop::kNone) return;
    if (run_id != 0 && s.run_id != run_id) return;
    it->second.push_back(s.tick);
  });
  return ticks;
}

std::int64_t TicksMissing(std::vector<std::int64_t> ticks, std::int64_t from, std::int64_t to) {
  std::sort(ticks.begin(), ticks.end());
  ticks.erase(std::unique(ticks.begin(), ticks.end()), ticks.end());
  return (to - from) - std::count_if(ticks.begin(), ticks.end(), [&](std::int64_t t) { return t >= from && t < to; });
}

std::vector<std::string> CyclictestArgs(int seconds, const fs::path& json, int fifo_priority, int cpu, bool mlockall,
                                        int histogram_us) {
  std::vector<std::string> argv = {"cyclictest",
                                   "-t1",
                                   "-i1000",
                                   "-D" + std::to_string(seconds),
                                   "-q",
                                   "-h" + std::to_string(histogram_us),
                                   "--histfile=/dev/null",
                                   "--default-system",
                                   "--json=" + json.string()};
  if (fifo_priority > 0) argv.push_back("-p" + std::to_string(fifo_priority));
  if (cpu >= 0) argv.push_back("-a" + std::to_string(cpu));
  if (mlockall) argv.push_back("-m");
  return argv;
}

}  // namespace lagrange::bench
