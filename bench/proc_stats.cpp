#include "bench/proc_stats.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;

double TicksPerSecond() { return static_cast<double>(sysconf(_SC_CLK_TCK)); }

// A /proc/<pid>/stat line: "pid (comm) state ... utime stime ..." (fields 14, 15).
struct StatLine {
  std::string name;
  double seconds = 0.0;
  bool ok = false;
};

StatLine ReadStat(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return {};
  const auto open = line.find('('), close = line.rfind(')');
  if (open == std::string::npos || close == std::string::npos) return {};
  std::istringstream rest(line.substr(close + 2));
  std::string field;
  double utime = 0.0, stime = 0.0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stod(field);
    if (i == 15) stime = std::stod(field);
  }
  return {line.substr(open + 1, close - open - 1), (utime + stime) / TicksPerSecond(), true};
}

bool IsNumber(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
}

}  // namespace

double ProcessCpuSeconds(pid_t pid) { return ReadStat(fs::path("/proc") / std::to_string(pid) / "stat").seconds; }

std::string ThreadName(pid_t pid, pid_t tid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/task/" + std::to_string(tid) + "/comm");
  std::string name;
  std::getline(in, name);
  return name;
}

long VmRssKiB(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (in >> key) {
    if (key == "VmRSS:") {
      long kib = -1;
      in >> kib;
      return kib;
    }
    in.ignore(4096, '\n');
  }
  return -1;
}

std::map<pid_t, double> ThreadCpuSeconds(pid_t pid) {
  std::map<pid_t, double> threads;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(fs::path("/proc") / std::to_string(pid) / "task", ec)) {
    const std::string tid = entry.path().filename();
    if (!IsNumber(tid)) continue;
    const StatLine s = ReadStat(entry.path() / "stat");
    if (s.ok) threads[static_cast<pid_t>(std::stol(tid))] = s.seconds;
  }
  return threads;
}

std::string ThreadState(pid_t pid, pid_t tid) {
  static const std::map<std::string, std::string> kNames = {{"0", "read"},
                                                            {"7", "poll"},
                                                            {"23", "select"},
                                                            {"45", "recvfrom"},
                                                            {"47", "recvmsg"},
                                                            {"61", "wait4"},
                                                            {"128", "rt_sigtimedwait"},
                                                            {"202", "futex"},
                                                            {"230", "clock_nanosleep"},
                                                            {"232", "epoll_wait"},
                                                            {"270", "pselect6"},
                                                            {"271", "ppoll"},
                                                            {"281", "epoll_pwait"}};
  std::ifstream in(fs::path("/proc") / std::to_string(pid) / "task" / std::to_string(tid) / "syscall");
  std::string first;
  if (!(in >> first)) return "?";
  const auto it = kNames.find(first);
  return it == kNames.end() ? first : it->second;
}

MachineCpu ReadMachineCpu() {
  std::ifstream in("/proc/stat");
  std::string cpu;
  in >> cpu;  // "cpu": the sum over cores
  double v[10] = {};
  for (double& x : v) in >> x;
  // user nice system idle iowait irq softirq steal guest guest_nice; guest time is inside user.
  const double idle = v[3] + v[4];
  double total = 0.0;
  for (int i = 0; i < 8; ++i) total += v[i];
  return {(total - idle) / TicksPerSecond(), total / TicksPerSecond()};
}

// pid => (name, CPU s) for every process now.
template <class F>
void ForEachProcess(F&& f) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc", ec)) {
    const std::string pid = entry.path().filename();
    if (!IsNumber(pid)) continue;
    const StatLine s = ReadStat(entry.path() / "stat");
    if (s.ok) f(static_cast<pid_t>(std::stol(pid)), s);
  }
}

ProcessCpuTracker::ProcessCpuTracker() {
  ForEachProcess([this](pid_t pid, const StatLine& s) { seen_[pid] = {s.name, s.seconds, s.seconds}; });
}

void ProcessCpuTracker::Sample() {
  ForEachProcess([this](pid_t pid, const StatLine& s) {
    seen_.try_emplace(pid, Seen{s.name, 0.0, 0.0}).first->second.last = s.seconds;  // born in the window: from 0
  });
}

std::vector<std::pair<std::string, double>> ProcessCpuTracker::Top(int count) const {
  std::vector<std::pair<std::string, double>> used;
  for (const auto& [pid, p] : seen_) {
    if (p.last > p.first) used.emplace_back(p.name + " [" + std::to_string(pid) + "]", p.last - p.first);
  }
  std::sort(used.begin(), used.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  if (static_cast<int>(used.size()) > count) used.resize(static_cast<std::size_t>(count));
  return used;
}

}  // namespace lagrange::bench
