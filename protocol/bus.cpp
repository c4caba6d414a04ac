#include "protocol/bus.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <limits>

#include "protocol/big_endian.hpp"

namespace lagrange {
namespace {

constexpr std::uint32_t kShortMagic = 0x4c433032;     // "LC02": one whole message
constexpr std::uint32_t kFragmentMagic = 0x4c433033;  // "LC03": one fragment of a long message
constexpr std::size_t kHeaderSize = 8;                // magic + seqno
constexpr std::size_t kMaxChannelLength = 63;         // LCM_MAX_CHANNEL_NAME_LENGTH
// The longest LC02 datagram for a payload of at most `max_payload`: header, channel, NUL, payload.
constexpr std::size_t MaxDatagramSize(std::size_t max_payload) {
  return kHeaderSize + kMaxChannelLength + 1 + max_payload;
}
// One receive slot: a byte more than the longest datagram a signed bus takes,
// so that any longer one comes back with MSG_TRUNC and is counted as oversized.
constexpr std::size_t kReceiveSlotSize = MaxDatagramSize(kMaxSignedPayload) + 1;
// Datagrams read per recvmmsg: under a flood, one system call (and one pass
// through the kernel's socket lock) per batch rather than per datagram.
// bench/flood_bench measures what it buys.
constexpr unsigned kReceiveBatch = 16;
constexpr const char* kExpected = "expected udpm://GROUP:PORT?ttl=0..255[&recv_buf_size=BYTES]";

[[noreturn]] void ThrowUrlError(const std::string& url, const std::string& what) {
  throw BusUrlError("LCM URL '" + url + "': " + what + "; " + kExpected);
}

// A decimal integer of digits only (no sign, no spaces) in [min, max]; false otherwise.
bool ParseDecimal(std::string_view text, long long min, long long max, long long& out) {
  if (text.empty() || text.size() > 12) return false;
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
  }
  long long v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || end != text.data() + text.size() || v < min || v > max) return false;
  out = v;
  return true;
}

// Dotted-quad IPv4, four decimal octets 0-255.
bool ParseIpv4(std::string_view text, std::uint8_t (&octets)[4]) {
  for (int i = 0; i < 4; ++i) {
    const std::size_t dot = i < 3 ? text.find('.') : text.size();
    if (dot == std::string_view::npos) return false;
    long long v = 0;
    if (dot > 3 || !ParseDecimal(text.substr(0, dot), 0, 255, v)) return false;
    octets[i] = static_cast<std::uint8_t>(v);
    text.remove_prefix(i < 3 ? dot + 1 : dot);
  }
  return text.empty();
}

bool ChannelFits(std::string_view channel) {
  return channel.size() <= kMaxChannelLength && channel.find('\0') == std::string_view::npos;
}

using Subscriptions = std::vector<Subscription>;

void Bump(std::int64_t& counter) { ++counter; }
void Bump(std::atomic<std::int64_t>& counter) { counter.fetch_add(1, std::memory_order_relaxed); }

// Adds a subscription, and a drop counter for its channel if it is new.
void AddSubscription(Subscriptions& subscriptions, std::deque<ChannelDrops>& drops, const std::string& channel,
                     Bus::Handler handler) {
  std::size_t k = 0;
  while (k < drops.size() && drops[k].channel != channel) ++k;
  if (k == drops.size()) drops.emplace_back(channel);
  subscriptions.push_back({channel, std::move(handler), k});
}

std::int64_t DropsOn(const std::deque<ChannelDrops>& drops, std::string_view channel) {
  for (const ChannelDrops& d : drops) {
    if (d.channel == channel) return d.count.load(std::memory_order_relaxed);
  }
  return 0;
}

// A refusal by the verifier, counted by its reason and on its channel.
template <class Counters>
void CountRefusal(SignatureVerdict verdict, Counters& counters, std::atomic<std::int64_t>& on_channel) {
  switch (verdict) {
    case SignatureVerdict::kOk: return;
    case SignatureVerdict::kUnsigned: Bump(counters.unsigned_dropped); break;
    case SignatureVerdict::kOldFormat: Bump(counters.old_format); break;
    case SignatureVerdict::kStale: Bump(counters.stale); break;
    case SignatureVerdict::kReplayed: Bump(counters.replayed); break;
    case SignatureVerdict::kBadTag: Bump(counters.bad_tags); break;
  }
  Bump(on_channel);
}

// One datagram read from the wire => counted, and handed to the subscribers of
// its channel when it is a whole message (with a `verifier`: a whole message
// whose signature verifies, its trailer stripped). `Counters` is BusStats or
// UdpmBus's atomic counters (the same field names). Allocates nothing.
template <class Counters>
void Dispatch(const Subscriptions& subscriptions, std::deque<ChannelDrops>& drops, Verifier* verifier,
              const std::uint8_t* data, std::size_t size, Counters& counters) {
  Bump(counters.received);
  const Datagram d = ParseDatagram(data, size, verifier != nullptr ? kMaxSignedPayload : kMaxMessageSize);
  switch (d.kind) {
    case Datagram::Kind::kMessage: {
      // "" (kEveryChannel) hears every channel; the others only their own.
      const auto hears = [&](const Subscription& s) { return s.channel.empty() || std::string_view(s.channel) == d.channel; };
      const auto first = std::find_if(subscriptions.begin(), subscriptions.end(), hears);
      if (first == subscriptions.end()) return;  // not ours: neither checked nor counted
      std::size_t message_size = d.payload_size;
      if (verifier != nullptr) {
        const SignatureVerdict verdict = verifier->Verify(d.channel, d.payload, d.payload_size, message_size);
        if (verdict != SignatureVerdict::kOk) {
          // Counted on its own channel when that is subscribed, even after an every-channel subscription.
          const auto own = std::find_if(first, subscriptions.end(),
                                        [&](const Subscription& s) { return std::string_view(s.channel) == d.channel; });
          CountRefusal(verdict, counters, drops[(own != subscriptions.end() ? own : first)->drops].count);
          return;
        }
      }
      for (auto it = first; it != subscriptions.end(); ++it) {
        if (hears(*it)) it->handler(d.channel, d.payload, message_size);
      }
      Bump(counters.delivered);
      return;
    }
    case Datagram::Kind::kFragment: Bump(counters.fragments_dropped); return;
    case Datagram::Kind::kOversized: Bump(counters.oversized); return;
    case Datagram::Kind::kMalformed: Bump(counters.malformed); return;
  }
}

// LCM's UDP multicast transport for unfragmented messages (see bus.hpp).
class UdpmBus final : public Bus {
 public:
  UdpmBus(const std::string& url_text, const UdpmUrl& url, const BusKey* key, const std::string& domain);
  ~UdpmBus() override;
  UdpmBus(const UdpmBus&) = delete;
  UdpmBus& operator=(const UdpmBus&) = delete;

  bool Publish(std::string_view channel, const void* data, std::size_t size) override;
  void Subscribe(const std::string& channel, Handler handler) override;
  int fd() const override { return recv_fd_; }
  int Drain(int max) override;
  int Handle(int timeout_ms) override;
  BusStats stats() const override;
  std::int64_t unauthenticated_on(std::string_view channel) const override { return DropsOn(drops_, channel); }
  bool signs() const override { return signer_ != nullptr; }
  const std::string& domain() const override { return domain_; }
  int receive_buffer_bytes() const override;

 private:
  struct Counters {
    std::atomic<std::int64_t> received{0}, delivered{0}, fragments_dropped{0}, malformed{0}, oversized{0},
        kernel_drops{0}, send_failures{0}, unsigned_dropped{0}, old_format{0}, stale{0}, replayed{0}, bad_tags{0};
  };
  [[noreturn]] void ThrowSocketError(const char* what) const;
  void OpenReceiveSocket();

  std::string url_text_;
  UdpmUrl url_;
  sockaddr_in group_{};
  int send_fd_ = -1;
  int recv_fd_ = -1;
  std::uint32_t seqno_ = 0;
  std::vector<std::uint8_t> send_buffer_;
  // kReceiveBatch slots of kReceiveSlotSize bytes, and recvmmsg's headers for them.
  std::vector<std::uint8_t> receive_buffer_;
  std::array<iovec, kReceiveBatch> receive_iov_{};
  std::array<mmsghdr, kReceiveBatch> receive_headers_{};
  std::array<std::array<char, CMSG_SPACE(sizeof(std::uint32_t))>, kReceiveBatch> receive_control_{};
  Subscriptions subscriptions_;
  std::deque<ChannelDrops> drops_;
  Counters counters_;
  std::string domain_;                  // "" unsigned
  std::unique_ptr<Signer> signer_;      // publishing thread only
  std::unique_ptr<Verifier> verifier_;  // receiving thread only
};

UdpmBus::UdpmBus(const std::string& url_text, const UdpmUrl& url, const BusKey* key, const std::string& domain)
    : url_text_(url_text),
      url_(url),
      send_buffer_(MaxDatagramSize(kMaxSignedPayload)),
      receive_buffer_(kReceiveSlotSize * kReceiveBatch),
      domain_(key != nullptr ? domain : ""),
      signer_(key != nullptr ? std::make_unique<Signer>(*key, domain) : nullptr),
      verifier_(key != nullptr ? std::make_unique<Verifier>(*key, domain) : nullptr) {
  group_.sin_family = AF_INET;
  group_.sin_port = htons(url_.port);
  if (inet_pton(AF_INET, url_.group.c_str(), &group_.sin_addr) != 1) ThrowUrlError(url_text_, "bad group address");

  send_fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (send_fd_ < 0) ThrowSocketError("cannot open a UDP socket");
  const unsigned char ttl = static_cast<unsigned char>(url_.ttl);
  const unsigned char loop = 1;
  if (setsockopt(send_fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl) != 0 ||
      setsockopt(send_fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop) != 0) {
    const int saved = errno;
    close(send_fd_);
    errno = saved;
    ThrowSocketError("cannot set the multicast TTL or loopback");
  }
}

UdpmBus::~UdpmBus() {
  if (send_fd_ >= 0) close(send_fd_);
  if (recv_fd_ >= 0) close(recv_fd_);
}

void UdpmBus::ThrowSocketError(const char* what) const {
  throw BusError("LCM URL '" + url_text_ + "': " + what + ": " + std::strerror(errno));
}

void UdpmBus::OpenReceiveSocket() {
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) ThrowSocketError("cannot open a UDP socket");
  auto fail = [&](const char* what) {
    const int saved = errno;
    close(fd);
    errno = saved;
    ThrowSocketError(what);
  };
  const int one = 1;
  // Shared with lcm-logger, lcm-spy and other lagrange processes on this port.
  if (setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) fail("SO_REUSEADDR");
  if (setsockopt(fd, SOL_SOCKET, SO_REUSEPORT, &one, sizeof one) != 0) fail("SO_REUSEPORT");
  // Beyond net.core.rmem_max only with CAP_NET_ADMIN; without it SO_RCVBUF, which the kernel caps there.
  if (url_.recv_buf_size > 0 &&
      setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &url_.recv_buf_size, sizeof url_.recv_buf_size) != 0 &&
      setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &url_.recv_buf_size, sizeof url_.recv_buf_size) != 0) {
    fail("SO_RCVBUF");
  }
  // The kernel's count of datagrams dropped for a full buffer comes with each one read.
  if (setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one) != 0) fail("SO_RXQ_OVFL");
  sockaddr_in any{};
  any.sin_family = AF_INET;
  any.sin_port = htons(url_.port);
  any.sin_addr.s_addr = htonl(INADDR_ANY);
  if (bind(fd, reinterpret_cast<const sockaddr*>(&any), sizeof any) != 0) fail("cannot bind the port");
  ip_mreq membership{};
  membership.imr_multiaddr = group_.sin_addr;
  membership.imr_interface.s_addr = htonl(INADDR_ANY);
  if (setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &membership, sizeof membership) != 0) {
    fail("cannot join the multicast group");
  }
  // Only our group's datagrams, not those of groups other sockets on this host joined (best effort).
  const int zero = 0;
  setsockopt(fd, IPPROTO_IP, IP_MULTICAST_ALL, &zero, sizeof zero);
  recv_fd_ = fd;
}

bool UdpmBus::Publish(std::string_view channel, const void* data, std::size_t size) {
  std::size_t written = 0;
  if (size > kMaxMessageSize || !ChannelFits(channel) ||
      !FormatDatagram(seqno_, channel, data, size, send_buffer_.data(), send_buffer_.size(), written)) {
    Bump(counters_.send_failures);
    return false;
  }
  if (signer_) {  // the buffer has room for the trailer after any message it took
    signer_->Sign(channel, send_buffer_.data() + written - size, size, send_buffer_.data() + written);
    written += kSignatureTrailerBytes;
  }
  ++seqno_;
  const ssize_t sent = sendto(send_fd_, send_buffer_.data(), written, MSG_DONTWAIT,
                              reinterpret_cast<const sockaddr*>(&group_), sizeof group_);
  if (sent != static_cast<ssize_t>(written)) {
    Bump(counters_.send_failures);
    return false;
  }
  return true;
}

void UdpmBus::Subscribe(const std::string& channel, Handler handler) {
  if (recv_fd_ < 0) OpenReceiveSocket();
  AddSubscription(subscriptions_, drops_, channel, std::move(handler));
}

int UdpmBus::Drain(int max) {
  if (recv_fd_ < 0) return 0;
  int read = 0;
  while (read < max) {
    const unsigned batch = std::min<unsigned>(kReceiveBatch, static_cast<unsigned>(max - read));
    for (unsigned k = 0; k < batch; ++k) {
      receive_iov_[k] = {receive_buffer_.data() + k * kReceiveSlotSize, kReceiveSlotSize};
      msghdr& msg = receive_headers_[k].msg_hdr;
      msg = msghdr{};
      msg.msg_iov = &receive_iov_[k];
      msg.msg_iovlen = 1;
      msg.msg_control = receive_control_[k].data();
      msg.msg_controllen = receive_control_[k].size();
    }
    const int got = recvmmsg(recv_fd_, receive_headers_.data(), batch, MSG_DONTWAIT, nullptr);
    if (got < 0) {
      if (errno == EINTR) continue;
      break;  // EAGAIN: nothing more waiting; anything else: try again at the next Drain
    }
    if (got == 0) break;
    for (int k = 0; k < got; ++k) {
      msghdr& msg = receive_headers_[static_cast<std::size_t>(k)].msg_hdr;
      const std::size_t n = receive_headers_[static_cast<std::size_t>(k)].msg_len;
      for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL &&
            c->cmsg_len >= CMSG_LEN(sizeof(std::uint32_t))) {
          std::uint32_t drops = 0;  // cumulative for this socket
          std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
          counters_.kernel_drops.store(drops, std::memory_order_relaxed);
        }
      }
      if ((msg.msg_flags & MSG_TRUNC) != 0 || n >= kReceiveSlotSize) {
        Bump(counters_.received);
        Bump(counters_.oversized);
        continue;
      }
      Dispatch(subscriptions_, drops_, verifier_.get(), receive_buffer_.data() + static_cast<std::size_t>(k) * kReceiveSlotSize,
               n, counters_);
    }
    read += got;
    if (static_cast<unsigned>(got) < batch) break;  // the socket is empty
  }
  return read;
}

int UdpmBus::receive_buffer_bytes() const {
  int bytes = 0;
  socklen_t size = sizeof bytes;
  if (recv_fd_ < 0 || getsockopt(recv_fd_, SOL_SOCKET, SO_RCVBUF, &bytes, &size) != 0) return 0;
  return bytes;
}

int UdpmBus::Handle(int timeout_ms) {
  if (recv_fd_ < 0) {
    poll(nullptr, 0, timeout_ms);  // nothing subscribed: just the wait
    return 0;
  }
  pollfd p{recv_fd_, POLLIN, 0};
  if (poll(&p, 1, timeout_ms) <= 0) return 0;
  return Drain(1024);
}

BusStats UdpmBus::stats() const {
  constexpr auto kRelaxed = std::memory_order_relaxed;
  BusStats s;
  s.received = counters_.received.load(kRelaxed);
  s.delivered = counters_.delivered.load(kRelaxed);
  s.fragments_dropped = counters_.fragments_dropped.load(kRelaxed);
  s.malformed = counters_.malformed.load(kRelaxed);
  s.oversized = counters_.oversized.load(kRelaxed);
  s.kernel_drops = counters_.kernel_drops.load(kRelaxed);
  s.send_failures = counters_.send_failures.load(kRelaxed);
  s.unsigned_dropped = counters_.unsigned_dropped.load(kRelaxed);
  s.old_format = counters_.old_format.load(kRelaxed);
  s.stale = counters_.stale.load(kRelaxed);
  s.replayed = counters_.replayed.load(kRelaxed);
  s.bad_tags = counters_.bad_tags.load(kRelaxed);
  return s;
}

}  // namespace

UdpmUrl ParseUdpmUrl(const std::string& url) {
  constexpr std::string_view kScheme = "udpm://";
  std::string_view rest(url);
  if (rest.substr(0, kScheme.size()) != kScheme) ThrowUrlError(url, "not a udpm:// URL");
  rest.remove_prefix(kScheme.size());

  const std::size_t question = rest.find('?');
  const std::string_view address = rest.substr(0, question);
  const std::string_view query = question == std::string_view::npos ? std::string_view{} : rest.substr(question + 1);

  const std::size_t colon = address.find(':');
  if (colon == std::string_view::npos) ThrowUrlError(url, "no port");
  const std::string_view group = address.substr(0, colon);
  std::uint8_t octets[4];
  if (!ParseIpv4(group, octets)) ThrowUrlError(url, "group '" + std::string(group) + "' is not a dotted IPv4 address");
  if (octets[0] < 224 || octets[0] > 239) {
    ThrowUrlError(url, "group '" + std::string(group) + "' is not an IPv4 multicast address (224.0.0.0/4)");
  }
  long long port = 0;
  if (!ParseDecimal(address.substr(colon + 1), 1, 65535, port)) ThrowUrlError(url, "port is not 1-65535");

  UdpmUrl out;
  out.group = std::string(group);
  out.port = static_cast<std::uint16_t>(port);
  if (question == std::string_view::npos) return out;
  if (query.empty()) ThrowUrlError(url, "empty query");

  bool have_ttl = false, have_buf = false;
  std::string_view pairs = query;
  while (true) {
    const std::size_t amp = pairs.find('&');
    const std::string_view pair = pairs.substr(0, amp);
    const std::size_t eq = pair.find('=');
    if (eq == std::string_view::npos) ThrowUrlError(url, "query item '" + std::string(pair) + "' is not KEY=VALUE");
    const std::string_view key = pair.substr(0, eq), value = pair.substr(eq + 1);
    long long v = 0;
    if (key == "ttl") {
      if (have_ttl) ThrowUrlError(url, "ttl given twice");
      if (!ParseDecimal(value, 0, 255, v)) ThrowUrlError(url, "ttl '" + std::string(value) + "' is not 0-255");
      out.ttl = static_cast<int>(v);
      have_ttl = true;
    } else if (key == "recv_buf_size") {
      if (have_buf) ThrowUrlError(url, "recv_buf_size given twice");
      if (!ParseDecimal(value, 1, std::numeric_limits<int>::max(), v)) {
        ThrowUrlError(url, "recv_buf_size '" + std::string(value) + "' is not a positive byte count");
      }
      out.recv_buf_size = static_cast<int>(v);
      have_buf = true;
    } else {
      ThrowUrlError(url, "unknown option '" + std::string(key) + "'");
    }
    if (amp == std::string_view::npos) break;
    pairs.remove_prefix(amp + 1);
  }
  return out;
}

std::string WithDefaultReceiveBuffer(const std::string& url, int bytes) {
  // Not udpm, a buffer named, or an empty query (refused as it stands when the bus opens).
  if (url.rfind("udpm://", 0) != 0 || url.find("recv_buf_size=") != std::string::npos || url.back() == '?') return url;
  return url + (url.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=" + std::to_string(bytes);
}

Datagram ParseDatagram(const std::uint8_t* data, std::size_t size, std::size_t max_payload) {
  Datagram d;  // kMalformed
  if (data == nullptr || size < 4) return d;
  const std::uint32_t magic = ReadBigEndian32(data);
  if (magic == kFragmentMagic) {
    d.kind = Datagram::Kind::kFragment;  // never reassembled: nothing past the magic is read
    return d;
  }
  if (magic != kShortMagic || size < kHeaderSize) return d;
  if (size > MaxDatagramSize(max_payload)) {
    d.kind = Datagram::Kind::kOversized;
    return d;
  }
  const std::uint8_t* channel = data + kHeaderSize;
  const std::size_t searchable = std::min(size - kHeaderSize, kMaxChannelLength + 1);
  const void* nul = std::memchr(channel, '\0', searchable);
  if (nul == nullptr) return d;  // not terminated within LCM's 63-byte limit
  const std::size_t channel_size = static_cast<std::size_t>(static_cast<const std::uint8_t*>(nul) - channel);
  const std::size_t payload_offset = kHeaderSize + channel_size + 1;
  d.payload_size = size - payload_offset;
  if (d.payload_size > max_payload) {
    d.payload_size = 0;
    d.kind = Datagram::Kind::kOversized;
    return d;
  }
  d.kind = Datagram::Kind::kMessage;
  d.channel = std::string_view(reinterpret_cast<const char*>(channel), channel_size);
  d.payload = data + payload_offset;
  return d;
}

bool FormatDatagram(std::uint32_t seqno, std::string_view channel, const void* payload, std::size_t size,
                    std::uint8_t* out, std::size_t capacity, std::size_t& written) {
  written = 0;
  if (!ChannelFits(channel) || (payload == nullptr && size > 0)) return false;
  if (out == nullptr || size > capacity || capacity - size < kHeaderSize + channel.size() + 1) return false;
  WriteBigEndian32(kShortMagic, out);
  WriteBigEndian32(seqno, out + 4);
  std::memcpy(out + kHeaderSize, channel.data(), channel.size());
  out[kHeaderSize + channel.size()] = 0;
  if (size > 0) std::memcpy(out + kHeaderSize + channel.size() + 1, payload, size);
  written = kHeaderSize + channel.size() + 1 + size;
  return true;
}

InProcessBus::InProcessBus(const BusKey* key, WallClockMicros clock, const std::string& domain)
    : domain_(key != nullptr ? (domain.empty() ? BusDomainOf(kInProcessUrl) : domain) : ""),
      signer_(key != nullptr ? std::make_unique<Signer>(*key, domain_, 0, clock) : nullptr),
      verifier_(key != nullptr ? std::make_unique<Verifier>(*key, domain_, clock) : nullptr) {}

InProcessBus::~InProcessBus() = default;

bool InProcessBus::Publish(std::string_view channel, const void* data, std::size_t size) {
  if (size > kMaxMessageSize || !ChannelFits(channel) || (data == nullptr && size > 0)) {
    ++stats_.send_failures;
    return false;
  }
  const std::size_t trailer = signer_ ? kSignatureTrailerBytes : 0;
  std::vector<std::uint8_t> bytes(kHeaderSize + channel.size() + 1 + size + trailer);
  std::size_t written = 0;
  FormatDatagram(seqno_++, channel, data, size, bytes.data(), bytes.size(), written);
  if (signer_) signer_->Sign(channel, bytes.data() + written - size, size, bytes.data() + written);
  queue_.push_back({std::move(bytes)});
  return true;
}

void InProcessBus::Subscribe(const std::string& channel, Handler handler) {
  AddSubscription(subscriptions_, drops_, channel, std::move(handler));
}

std::int64_t InProcessBus::unauthenticated_on(std::string_view channel) const { return DropsOn(drops_, channel); }

void InProcessBus::InjectDatagram(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  queue_.push_back({size > 0 ? std::vector<std::uint8_t>(p, p + size) : std::vector<std::uint8_t>{}});
}

int InProcessBus::Drain(int max) {
  int read = 0;
  while (read < max && !queue_.empty()) {
    // Moved out first: a handler may publish into this same bus.
    const std::vector<std::uint8_t> bytes = std::move(queue_.front().bytes);
    queue_.pop_front();
    ++read;
    Dispatch(subscriptions_, drops_, verifier_.get(), bytes.data(), bytes.size(), stats_);
  }
  return read;
}

int InProcessBus::Handle(int /*timeout_ms*/) { return Drain(1024); }

std::string BusDomainOf(const std::string& url) {
  if (url != kInProcessUrl) ParseUdpmUrl(url);  // BusUrlError for a malformed one
  return BusDomainOfUrl(url);
}

std::unique_ptr<Bus> OpenBus(const std::string& url, const BusKey* key, const std::string& domain) {
  if (url.rfind("udpm://", 0) == 0) {
    const UdpmUrl parsed = ParseUdpmUrl(url);
    return std::make_unique<UdpmBus>(url, parsed, key, domain.empty() ? BusDomainOf(url) : domain);
  }
  if (url == kInProcessUrl) return std::make_unique<InProcessBus>(key, SystemWallMicros, domain);
  throw BusUrlError("LCM URL '" + url +
                    "': lagrange speaks only udpm://GROUP:PORT?ttl=N (and inprocess:// in tests); see "
                    "docs/lcm-fragment-bug.md, 'Why lagrange has its own LCM transport'");
}

}  // namespace lagrange
