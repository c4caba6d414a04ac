#include "daemon/timing_csv.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>
#include <cinttypes>

namespace lagrange {
namespace {

constexpr auto kIdleWait = std::chrono::milliseconds(10);  // the writer's poll when the ring is empty
constexpr int kWriterNice = 10;

// The writer never competes with the loop: ordinary scheduling, lowered niceness
// (lowering is always permitted, whatever the creating thread ran at).
void LowerThisThreadPriority() {
  sched_param param{};
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), kWriterNice);
}

}  // namespace

TimingCsvWriter::TimingCsvWriter(std::size_t capacity) : ring_(capacity, TimingRow{}) {}

TimingCsvWriter::~TimingCsvWriter() { Stop(); }

bool TimingCsvWriter::Open(const std::string& path) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) return false;
  return std::fputs("tick,utime_us,wake_latency_ns,compute_ns,overruns\n", file_) >= 0;
}

void TimingCsvWriter::Start() {
  if (file_ == nullptr || writer_.joinable()) return;
  stop_.store(false, std::memory_order_relaxed);
  writer_ = std::thread([this] { Run(); });
}

void TimingCsvWriter::Offer(std::int64_t tick, std::int64_t utime, std::int64_t wake_latency_ns,
                            std::int64_t compute_ns, std::int64_t overruns) {
  offered_.fetch_add(1, std::memory_order_relaxed);
  TimingRow* row = ring_.BeginPush();
  if (row == nullptr) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  *row = {tick, utime, wake_latency_ns, compute_ns, overruns};
  ring_.Push();
}

void TimingCsvWriter::Stop() {
  if (writer_.joinable()) {
    stop_.store(true, std::memory_order_release);
    writer_.join();
  }
  if (file_ != nullptr) {
    WriteWaitingRows();  // rows offered without a writer thread (Start never called)
    std::fclose(file_);
    file_ = nullptr;
  }
}

void TimingCsvWriter::Run() {
  LowerThisThreadPriority();
  for (;;) {
    // Read the flag before draining: every row offered before Stop() is then written.
    const bool stopping = stop_.load(std::memory_order_acquire);
    WriteWaitingRows();
    if (stopping) break;
    std::fflush(file_);
    std::this_thread::sleep_for(kIdleWait);
  }
  std::fflush(file_);
}

void TimingCsvWriter::WriteWaitingRows() {
  std::int64_t n = 0;
  while (const TimingRow* r = ring_.Front()) {
    std::fprintf(file_, "%" PRId64 ",%" PRId64 ",%" PRId64 ",%" PRId64 ",%" PRId64 "\n", r->tick, r->utime,
                 r->wake_latency_ns, r->compute_ns, r->overruns);
    ring_.Pop();
    ++n;
  }
  written_.fetch_add(n, std::memory_order_relaxed);
}

}  // namespace lagrange
