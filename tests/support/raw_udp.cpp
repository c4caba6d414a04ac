#include "tests/support/raw_udp.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace lagrange::testing {

void PutBigEndian32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

void PutBigEndian16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}

std::vector<std::uint8_t> LcmFragment(std::uint32_t seqno, std::uint32_t msg_size, std::uint32_t offset,
                                      std::uint16_t fragment_no, std::uint16_t fragments, const std::string& channel,
                                      std::size_t data_size) {
  std::vector<std::uint8_t> out;
  PutBigEndian32(out, 0x4c433033);  // "LC03"
  PutBigEndian32(out, seqno);
  PutBigEndian32(out, msg_size);
  PutBigEndian32(out, offset);
  PutBigEndian16(out, fragment_no);
  PutBigEndian16(out, fragments);
  if (fragment_no == 0) {
    out.insert(out.end(), channel.begin(), channel.end());
    out.push_back(0);
  }
  out.insert(out.end(), data_size, 0xAB);
  return out;
}

RawUdpSender::RawUdpSender(const std::string& group, int port) : group_(group), port_(port) {
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("RawUdpSender: socket: ") + std::strerror(errno));
  const unsigned char ttl = 0, loop = 1;
  setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop);
}

RawUdpSender::~RawUdpSender() {
  if (fd_ >= 0) close(fd_);
}

bool RawUdpSender::Send(const std::vector<std::uint8_t>& bytes) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port_));
  if (inet_pton(AF_INET, group_.c_str(), &to.sin_addr) != 1) return false;
  const ssize_t sent = sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  return sent == static_cast<ssize_t>(bytes.size());
}

}  // namespace lagrange::testing
