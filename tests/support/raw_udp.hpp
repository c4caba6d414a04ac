#pragma once
// A plain UDP socket that sends arbitrary bytes to a multicast group, for
// tests that put hostile datagrams on the bus (what a careless or malicious
// sender on the network could send), bypassing every encoder of ours.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lagrange::testing {

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
