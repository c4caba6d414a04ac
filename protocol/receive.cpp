#include "protocol/receive.hpp"

namespace lagrange {

const char* ToString(Drop drop) {
  switch (drop) {
    case Drop::kNone: return "ok";
    case Drop::kTooShort: return ToString(WireCheck::kTooShort);
    case Drop::kWrongType: return ToString(WireCheck::kFingerprint);
    case Drop::kBadLength: return ToString(WireCheck::kBadLength);
    case Drop::kSizeMismatch: return ToString(WireCheck::kSizeMismatch);
    case Drop::kSignedWithoutKey: return "signed message on a receiver without the bus key";
    case Drop::kUndecodable: return "decode failed";
  }
  return "?";
}

Drop DropOf(WireCheck check) {
  switch (check) {
    case WireCheck::kOk: return Drop::kNone;
    case WireCheck::kTooShort: return Drop::kTooShort;
    case WireCheck::kFingerprint: return Drop::kWrongType;
    case WireCheck::kBadLength: return Drop::kBadLength;
    case WireCheck::kSizeMismatch: return Drop::kSizeMismatch;
  }
  return Drop::kUndecodable;
}

Drop CheckFramed(PacketCheck check, Framing framing, const std::uint8_t* data, std::size_t size,
                 std::size_t& message_size) {
  message_size = size;
  const WireCheck whole = check(data, size);
  if (whole == WireCheck::kOk) return Drop::kNone;
  const std::size_t before = MessageSizeBeforeTrailer(data, size);
  if (before == size || check(data, before) != WireCheck::kOk) return DropOf(whole);
  if (framing == Framing::kLive) return Drop::kSignedWithoutKey;
  message_size = before;
  return Drop::kNone;
}

}  // namespace lagrange
