#pragma once
// An lcm-logger file as CSV: one file per channel of lagrange messages,
// read through protocol/lcm_log.hpp and identified by their fingerprints
// (protocol/wire.hpp).

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace lagrange::cli {

// Column names, written once for log2csv and simulate (and read by plot):
// a joint array field's columns ",q0,q1,.." (",gravity_0,gravity_1,.." with
// separator "_"; state_t's fields by their own names: q, qd, qdd, tau, q_des,
// qd_des), and the energies'.
std::string JointColumns(const char* field, int n, const char* separator = "");
inline constexpr const char* kKineticEnergyColumn = "kinetic_energy";      // T, J
inline constexpr const char* kPotentialEnergyColumn = "potential_energy";  // V, J

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
