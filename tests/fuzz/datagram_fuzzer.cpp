// libFuzzer target: what the bus does with one datagram from the wire
// (protocol/bus.hpp): ParseDatagram's classification, reformatting a parsed
// message byte for byte, and InProcessBus delivering it only to the
// subscribers of exactly its channel. Run with --write-seeds DIR to write a
// valid LC02 datagram and the LC03 fragments that crash LCM 1.3.1 as a
// starting corpus.

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "protocol/bus.hpp"

namespace {

using Bytes = std::vector<std::uint8_t>;

void Put32(Bytes& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

void WriteSeed(const std::string& path, const Bytes& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

void WriteSeeds(const std::string& dir) {
  Bytes message;
  Put32(message, 0x4c433032);
  Put32(message, 1);
  for (const char c : std::string("ARM_SETPOINT")) message.push_back(static_cast<std::uint8_t>(c));
  message.push_back(0);
  message.insert(message.end(), 40, 0x11);
  WriteSeed(dir + "/lc02", message);
  // LC03: magic, msg_seqno, msg_size, fragment_offset, fragment_no (u16), fragments_in_msg (u16).
  Bytes wrapping;
  for (const std::uint32_t v : {0x4c433033u, 1u, 4096u, 0xFFFFFFF0u}) Put32(wrapping, v);
  Put32(wrapping, 0x00010002);
  wrapping.insert(wrapping.end(), 64, 0xAB);
  WriteSeed(dir + "/lc03_wrap", wrapping);
  WriteSeed(dir + "/lc03_short", Bytes(wrapping.begin(), wrapping.begin() + 18));  // shorter than its header
  Bytes huge;
  for (const std::uint32_t v : {0x4c433033u, 1u, 256u << 20, 0u}) Put32(huge, v);
  Put32(huge, 0x00000002);
  huge.insert(huge.end(), {'A', 0, 1, 2, 3});
  WriteSeed(dir + "/lc03_huge", huge);
}

// The channels the target subscribes; a 63-byte name is an edge case, and
// lagrange::kEveryChannel ("") hears every message; the others only their own.
const std::string kChannels[] = {"ARM_SETPOINT", "A", lagrange::kEveryChannel, std::string(63, 'Z')};

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i) {
    if (std::strcmp((*argv)[i], "--write-seeds") == 0) {
      WriteSeeds((*argv)[i + 1]);
      std::exit(0);
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace lagrange;
  // A copy of exactly `size` bytes, so AddressSanitizer catches a read past the end.
  const Bytes input(data, data + size);
  const std::uint8_t* begin = input.data();
  const Datagram d = ParseDatagram(begin, input.size());
  if (d.kind == Datagram::Kind::kMessage) {
    const auto* channel = reinterpret_cast<const std::uint8_t*>(d.channel.data());
    if (d.channel.size() > 63 || d.payload_size > kMaxMessageSize) __builtin_trap();
    if (channel != begin + 8 || d.payload != channel + d.channel.size() + 1) __builtin_trap();
    if (d.payload + d.payload_size != begin + input.size()) __builtin_trap();
    if (std::memchr(channel, 0, d.channel.size()) != nullptr) __builtin_trap();
    // Reformatting gives the same bytes (the seqno is carried, not checked).
    Bytes again(input.size());
    std::size_t written = 0;
    const std::uint32_t seqno =
        (std::uint32_t{begin[4]} << 24) | (std::uint32_t{begin[5]} << 16) | (std::uint32_t{begin[6]} << 8) | begin[7];
    if (!FormatDatagram(seqno, d.channel, d.payload, d.payload_size, again.data(), again.size(), written) ||
        written != input.size() || again != input) {
      __builtin_trap();
    }
  } else if (d.payload != nullptr || d.payload_size != 0 || !d.channel.empty()) {
    __builtin_trap();
  }

  InProcessBus bus;
  int delivered = 0;
  for (const std::string& name : kChannels) {
    bus.Subscribe(name, [&, name](std::string_view channel, const std::uint8_t* payload, std::size_t payload_size) {
      if ((name != kEveryChannel && channel != name) || payload_size > kMaxMessageSize || (payload_size > 0 && payload == nullptr)) {
        __builtin_trap();
      }
      ++delivered;
    });
  }
  bus.InjectDatagram(input.data(), input.size());
  if (bus.Drain() != 1) __builtin_trap();
  const BusStats s = bus.stats();
  if (s.received != 1 || s.malformed + s.fragments_dropped + s.oversized + (d.kind == Datagram::Kind::kMessage) != 1) {
    __builtin_trap();
  }
  if (s.delivered != (delivered > 0 ? 1 : 0)) __builtin_trap();
  return 0;
}
