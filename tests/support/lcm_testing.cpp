#include "tests/support/lcm_testing.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "protocol/lcm_log.hpp"
#include "tests/support/lcm_subscribe.hpp"
#include "tests/support/process.hpp"

namespace lagrange::testing {

std::string TestLcmUrl(int port) {
  return std::string("udpm://") + kTestLcmGroup + ":" + std::to_string(port) + "?ttl=0";
}

void WriteLcmLog(const std::string& path,
                 const std::vector<std::pair<std::string, std::vector<std::uint8_t>>>& events) {
  lcm::LogFile file(path, "w");
  if (!file.good()) throw std::runtime_error("cannot write the LCM log " + path);
  std::int64_t n = 0;
  for (const auto& [channel, bytes] : events) {
    std::vector<std::uint8_t> data = bytes;
    lcm::LogEvent e{};
    e.eventnum = n;
    e.timestamp = 1000 * ++n;
    e.channel = channel;
    e.datalen = static_cast<int32_t>(data.size());
    e.data = data.data();
    if (file.writeEvent(&e) != 0) throw std::runtime_error("writing the LCM log " + path + " failed");
  }
}

std::int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

bool WaitUntil(const std::function<bool()>& done, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

bool SendUntil(const std::function<void()>& send, const std::function<bool()>& done, double timeout_s, double every_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    send();
    if (WaitUntil(done, every_s)) return true;
  }
  return done();
}

std::string PrepareLoopbackMulticast(int port) {
  if (geteuid() == 0 && std::system("ip route show 239.255.0.0/16 2>/dev/null | grep -q 'dev lo'") != 0) {
    if (std::system("ip link set lo multicast on && ip route add 239.255.0.0/16 dev lo") != 0) {
      return "could not add the multicast route on lo (ip link set lo multicast on; ip route add 239.255.0.0/16 dev "
             "lo)";
    }
  }
  lcm::LCM lcm(TestLcmUrl(port));
  if (!lcm.good()) return "cannot open LCM at " + TestLcmUrl(port);
  int received = 0;
  lcm.subscribeFunction(
      "LAGRANGE_TEST_LOOPBACK", +[](const lcm::ReceiveBuffer*, const std::string&, int* n) { ++*n; }, &received);
  for (int i = 0; i < 20 && received == 0; ++i) {
    const char byte = 1;
    lcm.publish("LAGRANGE_TEST_LOOPBACK", &byte, 1);
    lcm.handleTimeout(50);
  }
  if (received == 0) {
    return "LCM multicast does not loop back on this host; as root: ip link set lo multicast on; "
           "ip route add 239.255.0.0/16 dev lo";
  }
  return "";
}

LcmCollector::LcmCollector(const std::string& url, const std::string& channel_regex) : lcm_(url) {
  // A deep queue: a test flooding the bus must not make the collector itself drop messages.
  Subscribe<&LcmCollector::OnMessage>(lcm_, channel_regex, this)->setQueueCapacity(100000);
  thread_ = std::thread([this] {
    while (!stop_) lcm_.handleTimeout(20);
  });
}

LcmCollector::~LcmCollector() {
  stop_ = true;
  thread_.join();
}

void LcmCollector::OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  const auto* p = static_cast<const std::uint8_t*>(rbuf->data);
  std::lock_guard<std::mutex> lock(mutex_);
  messages_[channel].push_back({rbuf->recv_utime, std::vector<std::uint8_t>(p, p + rbuf->data_size)});
}

std::vector<LcmCollector::Message> LcmCollector::Messages(const std::string& channel) {
  std::lock_guard<std::mutex> lock(mutex_);
  return messages_[channel];
}

std::size_t LcmCollector::Count(const std::string& channel) {
  std::lock_guard<std::mutex> lock(mutex_);
  return messages_[channel].size();
}

bool LcmCollector::WaitFor(const std::string& channel,
                           const std::function<bool(const std::vector<Message>&)>& predicate, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (predicate(messages_[channel])) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  return predicate(messages_[channel]);
}

BackgroundProcess::BackgroundProcess(const std::vector<std::string>& argv) {
  char out_template[] = "/tmp/lagrange_proc_out_XXXXXX";
  char err_template[] = "/tmp/lagrange_proc_err_XXXXXX";
  const int out_fd = mkstemp(out_template);
  const int err_fd = mkstemp(err_template);
  out_path_ = out_template;
  err_path_ = err_template;
  pid_ = Spawn(argv, out_fd, err_fd);
  close(out_fd);
  close(err_fd);
}

BackgroundProcess::~BackgroundProcess() {
  if (Running()) {
    kill(pid_, SIGKILL);
    Wait(5.0);
  }
  unlink(out_path_.c_str());
  unlink(err_path_.c_str());
}

void BackgroundProcess::Signal(int signal) { kill(pid_, signal); }

bool BackgroundProcess::Running() { return Wait(0.0) < 0; }

int BackgroundProcess::Wait(double timeout_s) {
  if (status_ >= 0) return status_;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (true) {
    int raw = 0;
    const pid_t r = waitpid(pid_, &raw, WNOHANG);
    if (r == pid_) {
      status_ = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
      return status_;
    }
    if (std::chrono::steady_clock::now() >= deadline) return -1;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
}

long BackgroundProcess::ResidentKiB() const {
  std::ifstream status("/proc/" + std::to_string(pid_) + "/status");
  std::string key;
  long value = -1;
  while (status >> key) {
    if (key == "VmRSS:") {
      status >> value;
      break;
    }
  }
  return value;
}

std::string BackgroundProcess::Stdout() const {
  std::ifstream in(out_path_);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string BackgroundProcess::Stderr() const {
  std::ifstream in(err_path_);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace lagrange::testing

namespace lagrange::testing {

LcmLoggerProcess::LcmLoggerProcess(const std::string& url, const std::string& path, const std::string& channel_regex)
    : url_(url), path_(path), probe_(url) {
  std::remove(path.c_str());
  // Debian's lcm-logger 1.3.1 lists -l but accepts only the long form; -c takes a channel regex.
  std::vector<std::string> argv = {LCM_LOGGER_PATH, "--lcm-url=" + url, "-f", "-q"};
  if (!channel_regex.empty()) argv.push_back("--channel=" + channel_regex + "|LAGRANGE_TEST_PROBE");
  argv.push_back(path);
  logger_ = std::make_unique<BackgroundProcess>(argv);
  for (int i = 0; i < 200 && ProbesLogged() == 0; ++i) {
    const char byte = 0;
    probe_.publish("LAGRANGE_TEST_PROBE", &byte, 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (ProbesLogged() == 0) throw std::runtime_error("lcm-logger did not start recording " + url);
}

LcmLoggerProcess::~LcmLoggerProcess() {
  if (logger_ && logger_->Running()) Stop();
}

int LcmLoggerProcess::ProbesLogged() const {
  std::optional<LcmLogReader> file;
  try {
    file.emplace(path_);
  } catch (const LcmLogError&) {
    return 0;  // not there yet, or nothing written yet
  }
  int n = 0;
  while (const LcmLogEvent* e = file->Next()) n += e->channel == "LAGRANGE_TEST_PROBE";
  return n;
}

void LcmLoggerProcess::Stop() {
  const int before = ProbesLogged();
  for (int i = 0; i < 100 && ProbesLogged() == before; ++i) {
    const char byte = 0;
    probe_.publish("LAGRANGE_TEST_PROBE", &byte, 1);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  logger_->Signal(SIGINT);
  logger_->Wait(10.0);
}

}  // namespace lagrange::testing
