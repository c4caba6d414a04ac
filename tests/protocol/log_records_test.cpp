// lagrange's messages in an lcm-logger file as records (protocol/log_records.hpp),
// the one decoding of log2csv and lagrange.read_log: a channel's fields are
// fixed by its first message, a message that does not fit them or does not
// decode is passed with no row, a type that is not lagrange's has no fields,
// a signed message decodes without its trailer, and the channel filter holds.

#include "protocol/log_records.hpp"

#include <lagrange/mpc_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/torque_t.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "protocol/lcm_log.hpp"
#include "protocol/signing.hpp"
#include "tests/support/lcm_log_bytes.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::Bytes;

// One event as lcm-logger writes it, appended to `log` (tests/support/lcm_log_bytes.hpp).
void AddEvent(Bytes& log, std::int64_t number, std::int64_t utime, const std::string& channel, const Bytes& payload) {
  const Bytes event = testing::LogEvent(number, utime, channel, payload);
  log.insert(log.end(), event.begin(), event.end());
}

template <class Message>
Bytes Encode(const Message& m) {
  Bytes out(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

state_t State(int n, std::int64_t tick) {
  state_t s{};
  s.utime = 1000 + tick;
  s.run_id = 0x1234;
  s.tick = tick;
  s.t = 0.001 * static_cast<double>(tick);
  s.num_dofs = n;
  for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(static_cast<std::size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) s.q[static_cast<std::size_t>(i)] = 0.5 * i + static_cast<double>(tick);
  s.controller = "pd";
  s.mode = state_t::MODE_RUNNING;
  return s;
}

struct Seen {
  std::string channel;
  MessageType type;
  bool has_fields;
  bool has_row;
  std::vector<LogField> fields;
  LogRow row;
};

class LogRecords : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = fs::temp_directory_path() /
            ("lagrange_log_records_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  }
  void TearDown() override { fs::remove(path_); }
  std::vector<Seen> Read(const Bytes& log, const std::string& regex = "") {
    std::ofstream(path_, std::ios::binary)
        .write(reinterpret_cast<const char*>(log.data()), static_cast<std::streamsize>(log.size()));
    std::vector<Seen> seen;
    ReadLogRecords(path_.string(), regex, [&](const LogRecord& r) {
      seen.push_back({std::string(r.channel), r.type, r.fields != nullptr, r.row != nullptr,
                      r.fields ? *r.fields : std::vector<LogField>{}, r.row ? *r.row : LogRow{}});
    });
    return seen;
  }
  fs::path path_;
};

TEST_F(LogRecords, AStateIsARowOfItsFieldsWithArraysOneColumnPerJoint) {
  Bytes log;
  AddEvent(log, 0, 5000, "ARM_STATE", Encode(State(2, 7)));
  const std::vector<Seen> seen = Read(log);
  ASSERT_EQ(seen.size(), 1u);
  ASSERT_TRUE(seen[0].has_row);
  EXPECT_EQ(seen[0].type, MessageType::kState);
  const std::vector<LogField>& f = seen[0].fields;
  ASSERT_GE(f.size(), 8u);
  EXPECT_EQ(f[0].name, "log_utime");
  EXPECT_EQ(f[2].name, "run_id");
  EXPECT_EQ(f[2].kind, LogFieldKind::kId);
  EXPECT_EQ(f[6].name, "q");
  EXPECT_EQ(f[6].width, 2);
  EXPECT_EQ(LogColumnName(f[6], 1), "q1");
  std::size_t values = 0;
  for (const LogField& field : f) values += static_cast<std::size_t>(std::max(field.width, 1));
  ASSERT_EQ(seen[0].row.values.size(), values);
  EXPECT_EQ(std::get<std::int64_t>(seen[0].row.values[0]), 5000);          // log_utime
  EXPECT_EQ(std::get<std::int64_t>(seen[0].row.values[3]), 7);             // tick
  EXPECT_EQ(std::get<double>(seen[0].row.values[7]), 7.5);                 // q1
  EXPECT_EQ(std::get<std::string>(seen[0].row.values[values - 2]), "pd");  // controller
}

// A cart-pole's plan of `knots` knots (4 states each), knot j's state all j.
mpc_t Plan(int knots, std::int64_t sequence) {
  mpc_t m{};
  m.run_id = 0x1234;
  m.controller = "mpc";
  m.plan = sequence;
  m.status = "converged";
  m.followed = true;
  m.num_states = 4;
  m.num_knots = knots;
  for (int j = 0; j < knots; ++j) {
    m.knot_t.push_back(0.02 * j);
    m.knot_x.emplace_back(4, static_cast<double>(j));
  }
  return m;
}

TEST_F(LogRecords, APlanIsARowWithItsKnotsTimesThenEachKnotsStateAndAnotherShapeOrALyingCountHasNoRow) {
  Bytes log;
  AddEvent(log, 0, 1, "CARTPOLE_MPC", Encode(Plan(3, 1)));
  AddEvent(log, 1, 2, "CARTPOLE_MPC", Encode(Plan(2, 2)));  // another shape than the channel's first
  Bytes lying = Encode(Plan(3, 3));
  lying[lying.size() - 3 * 5 * 8 - 1] = 17;  // num_knots (its last byte) 17: over MAX_KNOTS
  AddEvent(log, 2, 3, "CARTPOLE_MPC", lying);
  AddEvent(log, 3, 4, "CARTPOLE_MPC", Encode(Plan(3, 4)));
  const std::vector<Seen> seen = Read(log);
  ASSERT_EQ(seen.size(), 4u);
  EXPECT_EQ(seen[0].type, MessageType::kMpc);
  ASSERT_TRUE(seen[0].has_row);
  EXPECT_FALSE(seen[1].has_row);
  EXPECT_FALSE(seen[2].has_row);
  EXPECT_TRUE(seen[3].has_row);
  const std::vector<LogField>& f = seen[0].fields;
  std::vector<std::string> columns;
  for (const LogField& field : f) {
    if (field.width == 0) columns.push_back(field.name);
    for (int i = 0; i < field.width; ++i) columns.push_back(LogColumnName(field, i));
  }
  ASSERT_EQ(columns.size(), seen[0].row.values.size());
  const auto at = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(columns.begin(), columns.end(), name) - columns.begin());
  };
  for (const char* name : {"plan", "age", "solve_time", "iterations", "cost_before", "cost", "status", "followed",
                           "knot_t2", "knot0_x_0", "knot2_x_3"}) {
    EXPECT_LT(at(name), columns.size()) << name;
  }
  EXPECT_EQ(at("knot_t2") + 1, at("knot0_x_0")) << "the times, then the states knot by knot";
  EXPECT_EQ(std::get<std::int64_t>(seen[3].row.values[at("plan")]), 4);
  EXPECT_EQ(std::get<std::string>(seen[0].row.values[at("status")]), "converged");
  EXPECT_EQ(std::get<double>(seen[0].row.values[at("knot_t2")]), 0.04);
  EXPECT_EQ(std::get<double>(seen[0].row.values[at("knot2_x_3")]), 2.0);
  EXPECT_EQ(std::get<double>(seen[0].row.values[at("knot1_x_0")]), 1.0);
}

TEST_F(LogRecords, AMessageOfAnotherNumDofsThanTheChannelsFirstHasNoRow) {
  Bytes log;
  AddEvent(log, 0, 1, "ARM_STATE", Encode(State(2, 1)));
  AddEvent(log, 1, 2, "ARM_STATE", Encode(State(3, 2)));
  AddEvent(log, 2, 3, "ARM_STATE", Encode(State(2, 3)));
  const std::vector<Seen> seen = Read(log);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_TRUE(seen[0].has_row);
  EXPECT_FALSE(seen[1].has_row);
  EXPECT_TRUE(seen[1].has_fields);  // the channel's fields stand (num_dofs 2)
  EXPECT_EQ(seen[1].fields[6].width, 2);
  EXPECT_TRUE(seen[2].has_row);
}

TEST_F(LogRecords, APacketWhoseLengthsLieHasNoRowAndAForeignTypeNoFields) {
  Bytes state = Encode(State(2, 1));
  state.pop_back();  // one byte short of what its lengths say
  Bytes log;
  AddEvent(log, 0, 1, "ARM_STATE", state);
  AddEvent(log, 1, 2, "OTHER", Bytes(40, 0xab));
  const std::vector<Seen> seen = Read(log);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].type, MessageType::kState);
  EXPECT_FALSE(seen[0].has_row);
  EXPECT_EQ(seen[1].type, MessageType::kUnknown);
  EXPECT_FALSE(seen[1].has_fields);
  EXPECT_FALSE(seen[1].has_row);
}

TEST_F(LogRecords, ASignedMessageDecodesWithoutItsTrailer) {
  Bytes key_bytes(kBusKeyMinBytes);
  for (std::size_t i = 0; i < key_bytes.size(); ++i) key_bytes[i] = static_cast<std::uint8_t>(7 + 31 * i);
  const BusKey key = BusKey::FromBytes(key_bytes);
  Signer signer(key, "inprocess://");
  torque_t t{};
  t.run_id = 9;
  t.sequence = 1;
  t.num_dofs = 2;
  t.tau = {1.5, -2.0};
  Bytes payload = Encode(t);
  Bytes trailer(kSignatureTrailerBytes);
  signer.Sign("ARM_TORQUE", payload.data(), payload.size(), trailer.data());
  payload.insert(payload.end(), trailer.begin(), trailer.end());
  Bytes log;
  AddEvent(log, 0, 1, "ARM_TORQUE", payload);
  const std::vector<Seen> seen = Read(log);
  ASSERT_EQ(seen.size(), 1u);
  ASSERT_TRUE(seen[0].has_row);
  const std::vector<LogValue>& v = seen[0].row.values;
  EXPECT_EQ(std::get<double>(v[v.size() - 2]), 1.5);
  EXPECT_EQ(std::get<double>(v[v.size() - 1]), -2.0);
}

TEST_F(LogRecords, OnlyChannelsMatchingTheExpressionAreVisited) {
  Bytes log;
  AddEvent(log, 0, 1, "ARM_STATE", Encode(State(2, 1)));
  AddEvent(log, 1, 2, "CARTPOLE_STATE", Encode(State(2, 1)));
  AddEvent(log, 2, 3, "ARM_STATE", Encode(State(2, 2)));
  const std::vector<Seen> seen = Read(log, "ARM_.*");
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].channel, "ARM_STATE");
  EXPECT_EQ(seen[1].channel, "ARM_STATE");
}

TEST_F(LogRecords, AFileThatIsNotALogIsRefusedInOneLine) {
  std::ofstream(path_) << "not a log\n";
  try {
    ReadLogRecords(path_.string(), "", [](const LogRecord&) {});
    FAIL() << "no error";
  } catch (const LcmLogError& e) {
    EXPECT_EQ(std::string(e.what()), path_.string() + " is not an LCM log (no LCM sync word at its start)");
  }
}

// Every whole event is visited, then a log that ends inside an event or at a
// length out of range is refused naming the byte offset where that event
// starts (issue 32: log2csv and read_log gave the events before it and said
// nothing); a log cut short as its own error, which a reader of a log still
// being written may take.
TEST_F(LogRecords, ALogCutShortOrCorruptIsRefusedNamingTheByteOffsetAfterItsWholeEvents) {
  Bytes log;
  AddEvent(log, 0, 1, "ARM_STATE", Encode(State(2, 1)));
  const std::string at = std::to_string(log.size());
  Bytes cut = log;
  AddEvent(cut, 1, 2, "ARM_STATE", Encode(State(2, 2)));
  cut.resize(cut.size() - 5);
  std::vector<std::string> visited;
  try {
    Read(cut);
    FAIL() << "no error";
  } catch (const LcmLogCutShortError& e) {
    EXPECT_EQ(std::string(e.what()), path_.string() + ": cut short inside the event at byte " + at + ": it declares a " +
                                         std::to_string(Encode(State(2, 2)).size()) +
                                         "-byte payload, of which the file holds " +
                                         std::to_string(Encode(State(2, 2)).size() - 5));
  }
  Bytes corrupt = log;
  const Bytes lie = testing::LogEvent(1, 2, "ARM_STATE", {}, 0xffffffff);
  corrupt.insert(corrupt.end(), lie.begin(), lie.end());
  std::ofstream(path_, std::ios::binary)
      .write(reinterpret_cast<const char*>(corrupt.data()), static_cast<std::streamsize>(corrupt.size()));
  try {
    ReadLogRecords(path_.string(), "", [&](const LogRecord& r) { visited.emplace_back(r.channel); });
    FAIL() << "no error";
  } catch (const LcmLogCutShortError&) {
    FAIL() << "a corrupt log is not one cut short";
  } catch (const LcmLogError& e) {
    EXPECT_EQ(std::string(e.what()), path_.string() + ": the event at byte " + at + " declares a payload of -1 bytes");
  }
  EXPECT_EQ(visited, std::vector<std::string>{"ARM_STATE"});  // the whole event before it
}

}  // namespace
}  // namespace lagrange
