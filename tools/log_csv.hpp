#pragma once
// An lcm-logger file as CSV: one file per channel of lagrange messages,
// read through protocol/lcm_log.hpp and identified by their fingerprints
// (protocol/wire.hpp).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace lagrange::cli {

// Column names, written once for log2csv and simulate (and read by plot):
// a joint array field's columns ",q0,q1,.." (",gravity_0,gravity_1,.." with
// separator "_"; state_t's fields by their own names: q, qd, qdd, tau, q_des,
// qd_des), and the energies'.
std::string JointColumns(const char* field, int n, const char* separator = "");
inline constexpr const char* kKineticEnergyColumn = "kinetic_energy";      // T, J
inline constexpr const char* kPotentialEnergyColumn = "potential_energy";  // V, J

// Foreign text (from the bus, from a URDF) as one CSV field: escaped
// (base/escape.hpp: it cannot break a line or reach a terminal), quoted,
// quotes doubled.
std::string CsvText(const std::string& text);

// A simulate CSV's joint names, beside it as log2csv's are in the status CSV:
// FILE.joints.csv for FILE.csv (".joints.csv" appended to any other name),
// columns joint (i of the CSV's q<i>, qd<i>, ..) and name (CsvText), one row
// per joint in q order. Plot labels the joints by it.
std::string JointNamesPath(const std::string& csv_path);
// Writes `names` to JointNamesPath(csv_path); returns that path. Throws "cannot write PATH".
std::string WriteJointNames(const std::string& csv_path, const std::vector<std::string>& names);
// A simulate CSV's commanded frame under a task-space controller, beside it:
// FILE.task.csv for FILE.csv (".task.csv" appended to any other name), with
// log2csv's task_state_t column names (TaskStateWriter) for what it holds:
// t, frame (CsvText), position0..2, position_des0..2, error0..5. Plot draws it.
std::string TaskCsvPath(const std::string& csv_path);

struct ChannelCsv {
  std::string type;  // "state_t", ...
  std::string path;  // the CSV written
  std::int64_t rows = 0;
  std::int64_t skipped = 0;  // messages that did not decode or changed num_dofs
};

struct LogToCsvResult {
  std::map<std::string, ChannelCsv> written;    // by channel
  std::map<std::string, std::int64_t> unknown;  // channel → messages of an unknown type
};

// Decodes every event whose channel matches `channel_regex` (all when empty)
// into `dir`/<CHANNEL>.csv. Throws a one-line error when `log_path` cannot be
// read or is not an LCM log (LcmLogError). Columns: log_utime (when the logger received it,
// µs), then the message's fields, arrays one column per element (q0, q1, ..;
// forces_t's rows as gravity_0, gravity_1, .., tau_applied_0, ..).
LogToCsvResult LogToCsv(const std::string& log_path, const std::string& dir, const std::string& channel_regex);

}  // namespace lagrange::cli
