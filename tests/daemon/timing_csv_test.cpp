// TimingCsvWriter: the publisher's rows reach the file in order, a full ring
// drops and counts instead of blocking, and Stop writes everything offered.

#include "daemon/timing_csv.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;

class TimingCsv : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = fs::temp_directory_path() / ("lagrange_timing_" + std::to_string(getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".csv");
  }
  void TearDown() override { fs::remove(path_); }
  std::vector<std::string> ReadLines() const {
    std::ifstream in(path_);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
  }
  static std::string Row(std::int64_t k) {
    return std::to_string(k) + "," + std::to_string(1000 * k) + "," + std::to_string(k + 1) + "," +
           std::to_string(k + 2) + "," + std::to_string(k / 10);
  }
  static void OfferRow(TimingCsvWriter& w, std::int64_t k) { w.Offer(k, 1000 * k, k + 1, k + 2, k / 10); }
  fs::path path_;
};

TEST_F(TimingCsv, RowsArriveInTheOrderOfferedUnderTheHeader) {
  TimingCsvWriter writer(256);
  ASSERT_TRUE(writer.Open(path_.string()));
  writer.Start();
  constexpr std::int64_t kRows = 3000;  // many times the ring: the writer drains it while rows keep coming
  for (std::int64_t k = 0; k < kRows;) {
    const std::int64_t dropped = writer.rows_dropped();
    OfferRow(writer, k);
    if (writer.rows_dropped() == dropped) {
      ++k;
    } else {
      std::this_thread::yield();  // full: offered again, so every row arrives exactly once
    }
  }
  writer.Stop();
  const auto lines = ReadLines();
  ASSERT_EQ(lines.size(), static_cast<std::size_t>(kRows + 1));
  EXPECT_EQ(lines[0], "tick,utime_us,wake_latency_ns,compute_ns,overruns");
  for (std::int64_t k = 0; k < kRows; ++k) ASSERT_EQ(lines[static_cast<std::size_t>(k + 1)], Row(k));
  EXPECT_EQ(writer.rows_written(), kRows);
}

TEST_F(TimingCsv, AFullRingDropsAndCountsWithoutBlocking) {
  TimingCsvWriter writer(8);
  ASSERT_TRUE(writer.Open(path_.string()));
  // No writer thread yet: nothing drains, so rows beyond the capacity are refused.
  for (std::int64_t k = 0; k < 20; ++k) OfferRow(writer, k);
  EXPECT_EQ(writer.rows_offered(), 20);
  EXPECT_EQ(writer.rows_dropped(), 12);
  writer.Stop();
  const auto lines = ReadLines();
  ASSERT_EQ(lines.size(), 9u);  // the header and the first 8 rows
  for (std::int64_t k = 0; k < 8; ++k) EXPECT_EQ(lines[static_cast<std::size_t>(k + 1)], Row(k));
}

TEST_F(TimingCsv, OfferAllocatesNothing) {
  TimingCsvWriter writer(4);
  ASSERT_TRUE(writer.Open(path_.string()));
  testing::AllocationCounter count;
  for (std::int64_t k = 0; k < 10; ++k) OfferRow(writer, k);  // fills, then drops
  EXPECT_EQ(count.count(), 0);
  writer.Stop();
}

TEST_F(TimingCsv, StopWritesEveryRowOfferedBeforeIt) {
  TimingCsvWriter writer(4096);
  ASSERT_TRUE(writer.Open(path_.string()));
  writer.Start();
  for (std::int64_t k = 0; k < 4000; ++k) OfferRow(writer, k);
  writer.Stop();  // right away: whatever the writer had not reached yet is written now
  EXPECT_EQ(writer.rows_dropped(), 0);
  EXPECT_EQ(writer.rows_written(), 4000);
  const auto lines = ReadLines();
  ASSERT_EQ(lines.size(), 4001u);
  EXPECT_EQ(lines.back(), Row(3999));
}

TEST_F(TimingCsv, AnUnwritablePathIsRefusedAtOpen) {
  TimingCsvWriter writer;
  EXPECT_FALSE(writer.Open("/nonexistent/dir/timing.csv"));
  EXPECT_FALSE(writer.Open(fs::temp_directory_path().string()));  // a directory
}

}  // namespace
}  // namespace lagrange
