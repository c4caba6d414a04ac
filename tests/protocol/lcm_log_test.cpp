// The lcm-logger file reader (protocol/lcm_log.hpp): it reads what LCM's own
// writer wrote, ends a log cut short at its last whole event, passes over a
// payload larger than its bound without reading or allocating it, skips junk
// between events as LCM's reader does, ends at a length that lies, and
// refuses a file that is not a log with one line.

#include "protocol/lcm_log.hpp"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/support/alloc_counter.hpp"
#include "tests/support/lcm_log_bytes.hpp"
#include "tests/support/lcm_testing.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::Bytes;

// One event as lcm-logger writes it (tests/support/lcm_log_bytes.hpp).
Bytes Event(std::int64_t number, std::int64_t utime, const std::string& channel, const Bytes& payload,
            std::int64_t payload_length = -1) {
  return testing::LogEvent(number, utime, channel, payload, payload_length);
}

struct Read {
  std::vector<std::string> channels;
  std::vector<Bytes> payloads;
  std::vector<bool> oversized;
  LcmLogReader::End end = LcmLogReader::End::kNotYet;
  std::int64_t skipped = 0;
};

Read ReadAll(const fs::path& path, std::size_t max_payload = kMaxMessageSize) {
  LcmLogReader reader(path.string(), max_payload);
  Read r;
  while (const LcmLogEvent* e = reader.Next()) {
    r.channels.emplace_back(e->channel);
    r.payloads.emplace_back(e->data, e->data + e->size);
    r.oversized.push_back(e->oversized);
  }
  EXPECT_EQ(reader.Next(), nullptr);  // and stays at its end
  r.end = reader.end();
  r.skipped = reader.bytes_skipped();
  return r;
}

class LcmLog : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lagrange_lcm_log_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Write(const std::string& name, const Bytes& bytes) const {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    return path;
  }
  fs::path dir_;
};

TEST_F(LcmLog, ReadsEveryEventLcmsOwnWriterWrote) {
  const fs::path path = dir_ / "lcm.log";
  const std::vector<std::pair<std::string, Bytes>> written = {
      {"ARM_STATE", {1, 2, 3}},
      {"LAGRANGE_STATUS", {}},
      {"A_CHANNEL_OF_SIXTY_THREE_BYTES_" + std::string(32, 'X'), {9}}};
  testing::WriteLcmLog(path.string(), written);  // event k at 1000 (k + 1) µs
  LcmLogReader reader(path.string());
  for (std::size_t k = 0; k < written.size(); ++k) {
    const LcmLogEvent* e = reader.Next();
    ASSERT_NE(e, nullptr) << k;
    EXPECT_EQ(e->number, static_cast<std::int64_t>(k));
    EXPECT_EQ(e->utime, 1000 * static_cast<std::int64_t>(k + 1));
    EXPECT_EQ(e->channel, written[k].first);
    EXPECT_EQ(Bytes(e->data, e->data + e->size), written[k].second);
    EXPECT_FALSE(e->oversized);
  }
  EXPECT_EQ(reader.Next(), nullptr);
  EXPECT_EQ(reader.end(), LcmLogReader::End::kClean);
}

// A logger stopped (or still writing) leaves a partial event: every cut of
// the second event ends the log after the first, and a cut at the boundary
// is a clean end.
TEST_F(LcmLog, ALogCutShortEndsAtItsLastWholeEvent) {
  const Bytes first = Event(0, 10, "ARM_STATE", {1, 2, 3, 4});
  const Bytes second = Event(1, 20, "ARM_REPLY", {5, 6});
  Bytes both = first;
  both.insert(both.end(), second.begin(), second.end());
  for (std::size_t cut = first.size(); cut < both.size(); ++cut) {
    const Read r = ReadAll(Write("cut.log", Bytes(both.begin(), both.begin() + static_cast<std::ptrdiff_t>(cut))));
    ASSERT_EQ(r.channels, std::vector<std::string>{"ARM_STATE"}) << cut;
    EXPECT_EQ(r.end, cut == first.size() ? LcmLogReader::End::kClean : LcmLogReader::End::kTruncated) << cut;
  }
  EXPECT_EQ(ReadAll(Write("whole.log", both)).channels, (std::vector<std::string>{"ARM_STATE", "ARM_REPLY"}));
}

TEST_F(LcmLog, APayloadOverTheBoundIsPassedOverUnreadAndTheNextEventFollows) {
  Bytes log = Event(0, 1, "SMALL", Bytes(8, 1));
  const Bytes big = Event(1, 2, "BIG", Bytes(100, 2));
  const Bytes after = Event(2, 3, "AFTER", Bytes(16, 3));
  log.insert(log.end(), big.begin(), big.end());
  log.insert(log.end(), after.begin(), after.end());
  const Read r = ReadAll(Write("big.log", log), 16);
  EXPECT_EQ(r.channels, (std::vector<std::string>{"SMALL", "BIG", "AFTER"}));
  EXPECT_EQ(r.oversized, (std::vector<bool>{false, true, false}));
  EXPECT_TRUE(r.payloads[1].empty());
  EXPECT_EQ(r.payloads[2], Bytes(16, 3));
  EXPECT_EQ(r.end, LcmLogReader::End::kClean);
}

// 2^31 − 1 bytes declared in a file of a few dozen: nothing is allocated for
// it, and the log ends there, cut short.
TEST_F(LcmLog, AnEventDeclaringTwoGigabytesIsPassedOverWithoutAllocating) {
  LcmLogReader reader(Write("lying.log", Event(0, 1, "LIE", Bytes(8, 0), 0x7fffffff)).string());
  const LcmLogEvent* e = nullptr;
  {
    testing::AllocationCounter allocations;
    e = reader.Next();
    EXPECT_EQ(allocations.count(), 0);
  }
  ASSERT_EQ(e, nullptr);
  EXPECT_EQ(reader.end(), LcmLogReader::End::kTruncated);
  EXPECT_EQ(reader.events_oversized(), 1);
}

TEST_F(LcmLog, ChannelAndPayloadLengthsOutOfRangeEndTheLog) {
  for (const std::int64_t channel_length : {0LL, -1LL, 1000LL}) {
    Bytes log = Event(0, 1, "GOOD", {1});
    Bytes bad = Event(1, 2, "X", {2});
    bad[20] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(channel_length) >> 24);  // the channel length
    bad[21] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(channel_length) >> 16);
    bad[22] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(channel_length) >> 8);
    bad[23] = static_cast<std::uint8_t>(channel_length);
    log.insert(log.end(), bad.begin(), bad.end());
    const Read r = ReadAll(Write("channel.log", log));
    EXPECT_EQ(r.channels, std::vector<std::string>{"GOOD"}) << channel_length;
    EXPECT_EQ(r.end, LcmLogReader::End::kCorrupt) << channel_length;
  }
  Bytes log = Event(0, 1, "GOOD", {1});
  const Bytes negative = Event(1, 2, "X", {2}, 0xffffffff);
  log.insert(log.end(), negative.begin(), negative.end());
  const Read r = ReadAll(Write("payload.log", log));
  EXPECT_EQ(r.channels, std::vector<std::string>{"GOOD"});
  EXPECT_EQ(r.end, LcmLogReader::End::kCorrupt);
}

TEST_F(LcmLog, JunkBetweenEventsIsSkippedToTheNextSyncWord) {
  Bytes log = Event(0, 1, "ONE", {1});
  const Bytes junk = {0xED, 0xA1, 0x00, 0x42, 0xDA};  // a broken sync word among it
  log.insert(log.end(), junk.begin(), junk.end());
  const Bytes two = Event(1, 2, "TWO", {2});
  log.insert(log.end(), two.begin(), two.end());
  const Read r = ReadAll(Write("junk.log", log));
  EXPECT_EQ(r.channels, (std::vector<std::string>{"ONE", "TWO"}));
  EXPECT_EQ(r.skipped, static_cast<std::int64_t>(junk.size()));
  EXPECT_EQ(r.end, LcmLogReader::End::kClean);
}

TEST_F(LcmLog, AFileThatIsNotALogIsRefusedInOneLine) {
  const std::string missing = (dir_ / "missing.log").string();
  try {
    LcmLogReader reader(missing);
    FAIL() << "read a missing file";
  } catch (const LcmLogError& e) {
    EXPECT_EQ(std::string(e.what()), "cannot read " + missing + ": cannot be opened (No such file or directory)");
  }
  for (const Bytes& bytes : {Bytes{}, Bytes{0xED, 0xA1, 0xDA}, Bytes{'h', 'e', 'l', 'l', 'o'}}) {
    const fs::path path = Write("not.log", bytes);
    try {
      LcmLogReader reader(path.string());
      FAIL() << "read " << bytes.size() << " bytes as a log";
    } catch (const LcmLogError& e) {
      EXPECT_EQ(std::string(e.what()), path.string() + " is not an LCM log (no LCM sync word at its start)");
    }
  }
}

// Opening a FIFO for reading waits for a writer, and a device may never end:
// only a regular file is opened (issue 32: read_log of a FIFO blocked forever).
TEST_F(LcmLog, AFifoOrADirectoryIsRefusedWithoutWaiting) {
  const fs::path fifo = dir_ / "run.lcm";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    LcmLogReader reader(fifo.string());
    FAIL() << "opened a FIFO";
  } catch (const LcmLogError& e) {
    EXPECT_EQ(std::string(e.what()), "cannot read " + fifo.string() + ": not a regular file (a FIFO)");
  }
  try {
    LcmLogReader reader(dir_.string());
    FAIL() << "opened a directory";
  } catch (const LcmLogError& e) {
    EXPECT_EQ(std::string(e.what()), "cannot read " + dir_.string() + ": not a regular file (a directory)");
  }
}

// Where a log that does not end cleanly ends, and why, naming the byte
// offset of the event it ends in (issue 32: such logs read as nothing).
TEST_F(LcmLog, ALogThatEndsBadlySaysAtWhichByteAndWhy) {
  const Bytes first = Event(0, 1, "ARM_STATE", Bytes(16, 1));
  const auto at = std::to_string(first.size());
  const auto with = [&](const Bytes& second) {
    Bytes log = first;
    log.insert(log.end(), second.begin(), second.end());
    return log;
  };
  Bytes huge_channel = Event(1, 2, "X", {2});
  huge_channel[20] = 0;  // channel length 5000
  huge_channel[21] = 0;
  huge_channel[22] = 0x13;
  huge_channel[23] = 0x88;
  const Bytes header = Event(1, 2, "ARM_STATE", {});
  const Bytes cut = Event(1, 2, "CUT", Bytes(100, 0));
  const struct Case {
    Bytes log;
    LcmLogReader::End end;
    std::string reason;
  } cases[] = {
      {with(Event(1, 2, "LIE", Bytes(8, 0), 0x7fffffff)), LcmLogReader::End::kTruncated,
       "cut short inside the event at byte " + at + ": it declares a 2147483647-byte payload, of which the file holds 8"},
      {with(Bytes(cut.begin(), cut.end() - 40)), LcmLogReader::End::kTruncated,
       "cut short inside the event at byte " + at + ": it declares a 100-byte payload, of which the file holds 60"},
      {with(Bytes(header.begin(), header.begin() + 10)), LcmLogReader::End::kTruncated,
       "cut short inside the event at byte " + at + " (in its header)"},
      {with(Bytes(header.begin(), header.begin() + 30)), LcmLogReader::End::kTruncated,
       "cut short inside the event at byte " + at + " (in its 9-byte channel name)"},
      {with(huge_channel), LcmLogReader::End::kCorrupt,
       "the event at byte " + at + " declares a 5000-byte channel name (an LCM log's are 1 to 999 bytes)"},
      {with(Event(1, 2, "X", {2}, 0xffffffff)), LcmLogReader::End::kCorrupt,
       "the event at byte " + at + " declares a payload of -1 bytes"},
      {with({0x00, 0x42, 0xED}), LcmLogReader::End::kTruncated,
       "cut short: the 3 bytes from byte " + at + " to the end hold no whole event"},
  };
  for (const Case& c : cases) {
    LcmLogReader reader(Write("bad.log", c.log).string());
    ASSERT_NE(reader.Next(), nullptr);
    EXPECT_EQ(reader.Next(), nullptr);
    EXPECT_EQ(reader.end(), c.end) << c.reason;
    EXPECT_EQ(reader.end_offset(), static_cast<std::int64_t>(first.size())) << c.reason;
    EXPECT_EQ(reader.EndReason(), c.reason);
  }
  LcmLogReader whole(Write("whole.log", first).string());
  ASSERT_NE(whole.Next(), nullptr);
  EXPECT_EQ(whole.Next(), nullptr);
  EXPECT_EQ(whole.end_offset(), static_cast<std::int64_t>(first.size()));
  EXPECT_EQ(whole.EndReason(), "");
}

}  // namespace
}  // namespace lagrange
