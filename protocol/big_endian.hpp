#pragma once
// LCM's byte order (big-endian), read and written in one place for the
// datagram parser, the packet checks and the log reader. The caller has
// checked that the bytes are there.

#include <cstdint>

namespace lagrange {

inline std::uint32_t ReadBigEndian32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}

inline std::uint64_t ReadBigEndian64(const std::uint8_t* p) {
  return (std::uint64_t{ReadBigEndian32(p)} << 32) | ReadBigEndian32(p + 4);
}

inline void WriteBigEndian32(std::uint32_t v, std::uint8_t* p) {
  p[0] = static_cast<std::uint8_t>(v >> 24);
  p[1] = static_cast<std::uint8_t>(v >> 16);
  p[2] = static_cast<std::uint8_t>(v >> 8);
  p[3] = static_cast<std::uint8_t>(v);
}

inline void WriteBigEndian64(std::uint64_t v, std::uint8_t* p) {
  WriteBigEndian32(static_cast<std::uint32_t>(v >> 32), p);
  WriteBigEndian32(static_cast<std::uint32_t>(v), p + 4);
}

}  // namespace lagrange
