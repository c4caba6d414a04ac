#pragma once
// LCM in tests stays on this host: udpm://239.255.76.67:PORT?ttl=0, a
// distinct port per test, and a multicast route on the loopback interface.

#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace lagrange::testing {

// The multicast group of every test URL.
inline constexpr const char* kTestLcmGroup = "239.255.76.67";
std::string TestLcmUrl(int port);

// When root and the route is missing: `ip link set lo multicast on` and
// `ip route add 239.255.0.0/16 dev lo`. Then checks that a message published
// on `port` comes back; returns a description of the problem, or "".
std::string PrepareLoopbackMulticast(int port);

// Records every message on the given channels (all channels when empty) of
// one URL, on its own thread.
class LcmCollector {
 public:
  struct Message {
    std::int64_t received_us;
    std::vector<std::uint8_t> data;
  };
  explicit LcmCollector(const std::string& url, const std::string& channel_regex = ".*");
  ~LcmCollector();

  std::vector<Message> Messages(const std::string& channel);
  std::size_t Count(const std::string& channel);
  // Waits until `predicate` holds over the messages of `channel`, up to `timeout_s`.
  bool WaitFor(const std::string& channel, const std::function<bool(const std::vector<Message>&)>& predicate,
               double timeout_s);

  // Waits until the latest message of `channel`, decoded as T, satisfies
  // `predicate` (false before the first message).
  template <class T, class Predicate>
  bool WaitForLatest(const std::string& channel, Predicate predicate, double timeout_s) {
    return WaitFor(
        channel,
        [&](const std::vector<Message>& m) {
          T msg;
          return !m.empty() && msg.decode(m.back().data.data(), 0, static_cast<int>(m.back().data.size())) >= 0 &&
                 predicate(msg);
        },
        timeout_s);
  }

  template <class T>
  std::vector<T> Decoded(const std::string& channel) {
    std::vector<T> out;
    for (const Message& m : Messages(channel)) {
      T msg;
      if (msg.decode(m.data.data(), 0, static_cast<int>(m.data.size())) >= 0) out.push_back(msg);
    }
    return out;
  }

 private:
  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::map<std::string, std::vector<Message>> messages_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A program of ours running in the background, its output in files.
class BackgroundProcess {
 public:
  explicit BackgroundProcess(const std::vector<std::string>& argv);
  ~BackgroundProcess();  // kills it if still running
  BackgroundProcess(const BackgroundProcess&) = delete;
  BackgroundProcess& operator=(const BackgroundProcess&) = delete;

  void Signal(int signal);
  // Waits up to `timeout_s` for the exit; returns the exit status (128 + signal if
  // killed), or -1 if it is still running.
  int Wait(double timeout_s);
  bool Running();
  int pid() const { return pid_; }
  // Resident memory now, KiB (from /proc/PID/status).
  long ResidentKiB() const;
  std::string Stdout() const;
  std::string Stderr() const;

 private:
  int pid_ = -1;
  int status_ = -1;
  std::string out_path_, err_path_;
};

// lcm-logger recording `url` into `path`: the constructor returns once it is
// recording; Stop() returns once everything published before it is in the
// file, then stops the logger.
class LcmLoggerProcess {
 public:
  LcmLoggerProcess(const std::string& url, const std::string& path, const std::string& channel_regex = "");
  ~LcmLoggerProcess();
  void Stop();

 private:
  int ProbesLogged() const;
  std::string url_, path_;
  lcm::LCM probe_;
  std::unique_ptr<BackgroundProcess> logger_;
};

// AddressSanitizer keeps freed memory in quarantine and ThreadSanitizer grows
// its shadow and history memory, so a process's resident size says nothing
// about leaks under either: memory bounds are checked in the plain build.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kResidentSizeMeaningful = false;
#else
inline constexpr bool kResidentSizeMeaningful = true;
#endif

// Writes `events` (channel, payload) to an LCM log at `path` with LCM's own
// writer: event number k, logged at 1000 (k + 1) µs. Throws when it cannot.
void WriteLcmLog(const std::string& path, const std::vector<std::pair<std::string, std::vector<std::uint8_t>>>& events);

// Wall clock, µs since the Unix epoch (what LCM utime fields carry).
std::int64_t WallMicros();

// Calls `send`, then waits up to `every_s` for `done`; again and again until
// `done` holds or `timeout_s` has passed. True if it held. For messages UDP
// may lose (a loaded machine, a flood): a loss then only delays the test.
bool SendUntil(const std::function<void()>& send, const std::function<bool()>& done, double timeout_s,
               double every_s = 0.25);

// Polls `done` every 10 ms up to `timeout_s`; true if it held.
bool WaitUntil(const std::function<bool()>& done, double timeout_s);

}  // namespace lagrange::testing
