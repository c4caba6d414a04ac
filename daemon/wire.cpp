#include "daemon/wire.hpp"

#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>

#include "plant/types.hpp"

namespace lagrange {
namespace {

std::int64_t ReadInt64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<std::int64_t>(v);
}

std::int32_t ReadInt32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v = (v << 8) | p[i];
  return static_cast<std::int32_t>(v);
}

constexpr std::size_t kHash = 8, kInt64 = 8, kInt32 = 4, kInt8 = 1, kDouble = 8;
constexpr std::int32_t kMaxString = 256;  // bytes, including the terminating NUL

}  // namespace

const char* ToString(WireCheck check) {
  switch (check) {
    case WireCheck::kOk: return "ok";
    case WireCheck::kTooShort: return "packet too short";
    case WireCheck::kFingerprint: return "fingerprint mismatch (another type?)";
    case WireCheck::kBadLength: return "declared length out of range";
    case WireCheck::kSizeMismatch: return "packet size does not match its declared lengths";
  }
  return "?";
}

WireCheck CheckSetpointPacket(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  constexpr std::size_t header = kHash + kInt64 + kInt32;
  if (size < kHash) return WireCheck::kTooShort;
  if (ReadInt64(p) != setpoint_t::getHash()) return WireCheck::kFingerprint;
  if (size < header) return WireCheck::kTooShort;
  const std::int32_t n = ReadInt32(p + kHash + kInt64);
  if (n < 0 || n > kMaxDofs) return WireCheck::kBadLength;
  if (size != header + 3 * kDouble * static_cast<std::size_t>(n)) return WireCheck::kSizeMismatch;
  return WireCheck::kOk;
}

WireCheck CheckCommandPacket(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::size_t at = kHash + kInt64 + kInt8;
  if (size < kHash) return WireCheck::kTooShort;
  if (ReadInt64(p) != command_t::getHash()) return WireCheck::kFingerprint;
  if (size < at + kInt32) return WireCheck::kTooShort;
  const std::int32_t len = ReadInt32(p + at);  // string length including its NUL
  if (len < 1 || len > kMaxString) return WireCheck::kBadLength;
  at += kInt32 + static_cast<std::size_t>(len);
  if (size < at + kInt32) return WireCheck::kTooShort;
  if (p[at - 1] != 0) return WireCheck::kBadLength;  // the string must end in its NUL
  const std::int32_t g = ReadInt32(p + at);
  if (g < 0 || g > kMaxDofs) return WireCheck::kBadLength;
  at += kInt32;
  if (size != at + 2 * kDouble * static_cast<std::size_t>(g)) return WireCheck::kSizeMismatch;
  return WireCheck::kOk;
}

}  // namespace lagrange
