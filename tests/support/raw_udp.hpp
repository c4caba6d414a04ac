#pragma once
// A plain UDP socket that sends arbitrary bytes to a multicast group, for
// tests that put hostile datagrams on the bus (what a careless or malicious
// sender on the network could send), bypassing every encoder of ours.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lagrange::testing {

// An LCM fragment datagram (LC03) laid out as LCM 1.3.1 reads it: magic,
// msg_seqno, msg_size, fragment_offset (u32 big-endian each), fragment_no,
// fragments_in_msg (u16 big-endian each): 20 bytes; the first fragment then
// carries the channel and its NUL; then `data_size` bytes of data. Any field
// may lie: that is what the attack tests need.
std::vector<std::uint8_t> LcmFragment(std::uint32_t seqno, std::uint32_t msg_size, std::uint32_t offset,
                                      std::uint16_t fragment_no, std::uint16_t fragments, const std::string& channel,
                                      std::size_t data_size);
// Appends v big-endian.
void PutBigEndian32(std::vector<std::uint8_t>& out, std::uint32_t v);
void PutBigEndian16(std::vector<std::uint8_t>& out, std::uint16_t v);

class RawUdpSender {
 public:
  // `group` a dotted IPv4 multicast address; multicast TTL 0 and loopback on.
  // Throws std::runtime_error when the socket cannot be opened.
  RawUdpSender(const std::string& group, int port);
  ~RawUdpSender();
  RawUdpSender(const RawUdpSender&) = delete;
  RawUdpSender& operator=(const RawUdpSender&) = delete;

  // Sends one datagram of exactly these bytes; false when the kernel refused it.
  bool Send(const std::vector<std::uint8_t>& bytes);

 private:
  int fd_ = -1;
  std::string group_;
  int port_ = 0;
};

}  // namespace lagrange::testing
