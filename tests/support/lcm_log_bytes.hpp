#pragma once
// lcm-logger's file format written by hand, for tests of the log reader and
// its records: big-endian words and one event as lcm-logger writes it.

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/lcm_log.hpp"

namespace lagrange::testing {

using Bytes = std::vector<std::uint8_t>;

inline void Put32(Bytes& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

inline void Put64(Bytes& out, std::uint64_t v) {
  Put32(out, static_cast<std::uint32_t>(v >> 32));
  Put32(out, static_cast<std::uint32_t>(v));
}

// One event as lcm-logger writes it; `payload_length` as declared (-1: the payload's own).
inline Bytes LogEvent(std::int64_t number, std::int64_t utime, const std::string& channel, const Bytes& payload,
                      std::int64_t payload_length = -1) {
  Bytes out;
  Put32(out, kLcmLogSyncWord);
  Put64(out, static_cast<std::uint64_t>(number));
  Put64(out, static_cast<std::uint64_t>(utime));
  Put32(out, static_cast<std::uint32_t>(channel.size()));
  Put32(out,
        static_cast<std::uint32_t>(payload_length < 0 ? static_cast<std::int64_t>(payload.size()) : payload_length));
  out.insert(out.end(), channel.begin(), channel.end());
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

}  // namespace lagrange::testing
