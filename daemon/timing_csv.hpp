#pragma once
// --timing-csv off the publish path: the publisher offers one row per tick
// into a bounded ring without blocking or allocating; a writer thread of its
// own, at the lowest ordinary priority, drains the ring to the file. A full
// ring drops the row and counts it, so a slow disk costs rows, never ticks
// or published states.
//
// File: "tick,utime_us,wake_latency_ns,compute_ns,overruns", then one line per
// row in the order offered.
//
// Threads: Offer from one thread (the publisher) while the writer runs; Open,
// Start and Stop from the owner, with Offer not running concurrently with Stop.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>

#include "daemon/mailbox.hpp"

namespace lagrange {

struct TimingRow {
  std::int64_t tick = 0;
  std::int64_t utime = 0;  // wall clock, µs
  std::int64_t wake_latency_ns = 0;
  std::int64_t compute_ns = 0;
  std::int64_t overruns = 0;  // total so far
};

class TimingCsvWriter {
 public:
  // `capacity` rows may wait for the writer (8192: 8 s at 1 kHz).
  explicit TimingCsvWriter(std::size_t capacity = 8192);
  ~TimingCsvWriter();  // Stop()
  TimingCsvWriter(const TimingCsvWriter&) = delete;
  TimingCsvWriter& operator=(const TimingCsvWriter&) = delete;

  // Creates (truncates) `path` and writes the header. False when it cannot; before Start.
  bool Open(const std::string& path);
  // Starts the writer thread (SCHED_OTHER, nice +10). Needs Open.
  void Start();
  // Queues one row; never blocks, locks or allocates. A full ring drops it (counted).
  void Offer(std::int64_t tick, std::int64_t utime, std::int64_t wake_latency_ns, std::int64_t compute_ns,
             std::int64_t overruns);
  // Writes every row offered before the call, closes the file and joins the writer.
  void Stop();

  std::int64_t rows_offered() const { return offered_.load(std::memory_order_relaxed); }
  std::int64_t rows_dropped() const { return dropped_.load(std::memory_order_relaxed); }
  std::int64_t rows_written() const { return written_.load(std::memory_order_relaxed); }

 private:
  void Run();
  void WriteWaitingRows();

  SpscRing<TimingRow> ring_;
  std::FILE* file_ = nullptr;
  std::thread writer_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> offered_{0}, dropped_{0}, written_{0};
};

}  // namespace lagrange
