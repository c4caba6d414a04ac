#include "tests/support/raw_udp.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace lagrange::testing {

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
