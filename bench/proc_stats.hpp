#pragma once
// CPU accounting from /proc for the loop benchmark: one process and its
// threads, the whole machine, and every process on it (to name the noise).
// Times are in seconds of CPU; differences of two snapshots over a wall-clock
// window give utilisation (1.0 = one core busy).

#include <sys/types.h>

#include <map>
#include <string>
#include <vector>

namespace lagrange::bench {

// utime + stime of one process or thread, s.
double ProcessCpuSeconds(pid_t pid);
// The threads of `pid` (ids ascending, i.e. in creation order) and their CPU, s.
std::map<pid_t, double> ThreadCpuSeconds(pid_t pid);

// VmRSS of `pid`, KiB (/proc/<pid>/status); -1 when it cannot be read (the process is gone).
long VmRssKiB(pid_t pid);

// A thread's name (/proc/<pid>/task/<tid>/comm, as pthread_setname_np set it); "" when gone.
std::string ThreadName(pid_t pid, pid_t tid);

// Where a thread is now: the name of the system call it is blocked in
// ("clock_nanosleep", "poll", ...), "running", or the call's number.
std::string ThreadState(pid_t pid, pid_t tid);

// The machine's busy and total CPU time over all cores, s (/proc/stat).
struct MachineCpu {
  double busy = 0.0;
  double total = 0.0;
};
MachineCpu ReadMachineCpu();

// Every process's CPU over a window, from snapshots of /proc/<pid>/stat taken
// by Sample() (say once a second): a process born in the window counts from 0,
// one that exits keeps its last sample.
class ProcessCpuTracker {
 public:
  ProcessCpuTracker();  // the first snapshot
  void Sample();
  // The `count` processes that used the most CPU, as ("name [pid]", s), most first.
  std::vector<std::pair<std::string, double>> Top(int count) const;

 private:
  struct Seen {
    std::string name;
    double first = 0.0, last = 0.0;  // s
  };
  std::map<pid_t, Seen> seen_;
};

}  // namespace lagrange::bench
