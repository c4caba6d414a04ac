#pragma once
// Building and encoding lagrange messages in tests.

#include <lagrange/setpoint_t.hpp>

#include <cstdint>
#include <utility>
#include <vector>

namespace lagrange::testing {

// The message as its bytes on the wire.
template <class T>
std::vector<std::uint8_t> Encode(const T& msg) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

// A setpoint for q sent at `utime` (µs); qd and qdd default to zeros.
inline setpoint_t MakeSetpoint(std::vector<double> q, std::int64_t utime, std::vector<double> qd = {},
                               std::vector<double> qdd = {}) {
  setpoint_t s;
  s.utime = utime;
  s.num_dofs = static_cast<int32_t>(q.size());
  s.qd = qd.empty() ? std::vector<double>(q.size(), 0.0) : std::move(qd);
  s.qdd = qdd.empty() ? std::vector<double>(q.size(), 0.0) : std::move(qdd);
  s.q = std::move(q);
  return s;
}

}  // namespace lagrange::testing
