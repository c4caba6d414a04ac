#pragma once
// lagrange's messages in an lcm-logger file as records of named fields: the
// one decoding behind log2csv (tools/log_csv.cpp, which writes each field as
// CSV columns) and lagrange.read_log (python/bus.cpp, numpy columns).
//
// Every event is read through protocol/lcm_log.hpp, its type told by its
// fingerprint and its layout checked before it is decoded (protocol/wire.hpp):
// a recorded packet is as untrusted as a live one. A signed bus's message is
// decoded without its signature trailer (protocol/signing.hpp), which is not
// checked: a log is read after the fact, without the key.
//
// A channel's fields are fixed by its first message that decodes: a later
// message with another num_dofs does not fit them and is skipped, as is one
// that does not decode.

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "protocol/wire.hpp"

namespace lagrange {

enum class LogFieldKind : std::uint8_t {
  kInt,   // an integer: µs stamps, ticks, counters, num_dofs, mode, flags (0 or 1)
  kId,    // a run or request id (protocol/ids.hpp); CSV: 16 hex digits (RunIdText)
  kReal,  // a double; CSV: the shortest text that reads back to it (FormatDouble)
  kText,  // text, already escaped (base/escape.hpp: it cannot break a line or reach a terminal)
};

// One field of a message type: one value, or `width` values of an array.
struct LogField {
  std::string name;
  LogFieldKind kind = LogFieldKind::kReal;
  int width = 0;               // 0: a scalar; k > 0: k values, columns NAME<separator>0 .. NAME<separator>k-1
  const char* separator = "";  // "" (q0, q1, ..) or "_" (forces_t's gravity_0, ..)
};

// The column name of value i of an array field.
std::string LogColumnName(const LogField& field, int i);

// base_state_t's arrays after its utime, run_id, tick and t, in order, with
// their widths: the columns log2csv writes for <NAME>_BASE and simulate for a
// floating base (their names and order written once).
struct BaseStateArray {
  const char* name;
  int width;
};
inline constexpr BaseStateArray kBaseStateArrays[] = {
    {"position", 3}, {"orientation", 4},     {"linear_velocity", 3},  {"angular_velocity", 3},
    {"com", 3},      {"linear_momentum", 3}, {"angular_momentum", 3}};
// Their values in all: one row of a floating base (sim/offline.hpp's BaseRow).
inline constexpr int kBaseStateWidth = [] {
  int n = 0;
  for (const BaseStateArray& a : kBaseStateArrays) n += a.width;
  return n;
}();

class base_state_t;  // <lagrange/base_state_t.hpp>
// A base_state_t's arrays, one after another in kBaseStateArrays' order.
std::array<double, kBaseStateWidth> BaseStateValues(const base_state_t& message);

// One value (kInt and kId: std::int64_t; kReal: double; kText: std::string).
using LogValue = std::variant<std::int64_t, double, std::string>;

// One message: its values in field order, arrays flattened; log_utime first
// (when the logger received it, µs since the epoch).
struct LogRow {
  std::vector<LogValue> values;
};

// One event of the log as read: its channel and type, the channel's fields
// (null for a type that is not lagrange's), and the row (null when the
// message did not decode or does not fit the fields).
struct LogRecord {
  std::string_view channel;
  MessageType type = MessageType::kUnknown;
  const std::vector<LogField>* fields = nullptr;
  const LogRow* row = nullptr;
};

// Calls `visit` for every event whose channel matches `channel_regex` (every
// one when empty), in the log's order. Throws LcmLogError (one line) when
// `log_path` cannot be read or is not an LCM log, and, after visiting every
// whole event, when the log is corrupt or cut short (LcmLogCutShortError: a
// logger stopped or still writing), naming the byte offset ("run.lcm: cut
// short inside the event at byte 1234: ..."; LcmLogReader's EndReason);
// std::regex_error for a bad expression.
void ReadLogRecords(const std::string& log_path, const std::string& channel_regex,
                    const std::function<void(const LogRecord&)>& visit);

}  // namespace lagrange
