#pragma once
// The message bus lagranged and lagrangectl receive and send through.
//
// Why not lcm::LCM: LCM 1.3.1's UDP-multicast provider (Debian's liblcm1, and
// upstream still) reassembles fragmented messages with 32-bit bounds checks
// that wrap: a crafted fragment (after a first fragment from the same sender)
// makes it write 4 GiB past a buffer or copy 4 GiB (SIGSEGV), and a first
// fragment may declare a 256 MiB message that it allocates and keeps. See
// docs/lcm-fragment-bug.md. UdpmBus speaks LCM's wire format itself for the
// short, unfragmented messages lagrange uses (LC02, all well under
// kMaxMessageSize) into one fixed buffer, and drops and counts every
// fragment (LC03), so lcm-logger, lcm-spy and lcm-logplayer still
// interoperate with it on the same group and port.
//
// URLs: udpm://GROUP:PORT?ttl=N (GROUP an IPv4 multicast address, PORT
// 1-65535, N 0-255; recv_buf_size=BYTES optional) and, for deterministic
// tests in one process, inprocess:// (an InProcessBus). Anything else is
// refused with a BusError naming the URL and what was expected.
//
// Signing (protocol/signing.hpp): a bus opened with a BusKey appends a
// signature trailer to every message it publishes, and hands a subscriber
// only messages whose trailer verifies (the trailer stripped); the others are
// dropped and counted, in total (BusStats) and per channel
// (unauthenticated_on). Without a key a bus neither signs nor checks. The
// tags are bound to a domain: the one given, else the bus's own (BusDomainOf
// its URL), so what was signed on one bus is refused on another.
//
// Threads: subscribe before the bus is shared. After that one thread may
// Publish while another receives (Handle/Drain); neither may be called from
// two threads at once.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/signing.hpp"

namespace lagrange {

// The largest message lagrange sends or accepts, bytes of payload. Larger
// ones are refused before any allocation and counted.
inline constexpr std::size_t kMaxMessageSize = 16 * 1024;
// The most a signed bus accepts after the channel: a message and its
// signature trailer (protocol/signing.hpp).
inline constexpr std::size_t kMaxSignedPayload = kMaxMessageSize + kSignatureTrailerBytes;

struct BusError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// A URL that is not one this bus takes (its syntax, or another provider's):
// the caller's mistake rather than the system's, so lagrangectl treats it as
// a bad argument (exit 2).
struct BusUrlError : BusError {
  using BusError::BusError;
};

// A parsed udpm:// URL.
struct UdpmUrl {
  std::string group;  // dotted IPv4 multicast address
  std::uint16_t port = 0;
  int ttl = 0;            // 0: this host only
  // SO_RCVBUF request, bytes; 0: the system default. Asked with SO_RCVBUFFORCE
  // first (beyond net.core.rmem_max, with CAP_NET_ADMIN), else SO_RCVBUF
  // (capped by the kernel at net.core.rmem_max).
  int recv_buf_size = 0;
};
// Parses `url`; throws BusUrlError ("LCM URL 'X': <what is wrong>; expected udpm://GROUP:PORT?ttl=0..255...").
// Strict: decimal digits only, no default port; a missing ttl is 0 (LCM's default);
// unknown or repeated query keys are refused.
UdpmUrl ParseUdpmUrl(const std::string& url);

// `url` asking for a receive buffer of `bytes` when it is a udpm:// URL that
// names none; any other URL unchanged (a recv_buf_size it gives wins).
std::string WithDefaultReceiveBuffer(const std::string& url, int bytes);

// What a bus dropped or could not do, totals since it opened.
struct BusStats {
  std::int64_t received = 0;           // datagrams read
  std::int64_t delivered = 0;          // messages handed to a handler
  std::int64_t fragments_dropped = 0;  // LC03 fragments (never reassembled)
  std::int64_t malformed = 0;          // not an LCM datagram: short, bad magic, channel not terminated or too long
  std::int64_t oversized = 0;          // datagrams over kMaxMessageSize (truncated by the kernel into our buffer)
  std::int64_t kernel_drops = 0;       // datagrams the kernel dropped for a full receive buffer (SO_RXQ_OVFL)
  std::int64_t send_failures = 0;      // Publish calls that sent nothing (too large, would block, error)
  // With a key, messages on subscribed channels refused (SignatureVerdict), each counted once:
  std::int64_t unsigned_dropped = 0;  // no signature trailer
  std::int64_t old_format = 0;        // an LGS1 trailer: signed by a sender from before bus domains
  std::int64_t stale =
      0;  // stamp outside the window of this host's clock or before the bus opened (a replayed recording)
  std::int64_t replayed = 0;  // stamp not above its sender's last
  std::int64_t bad_tags = 0;  // forged or altered
  std::int64_t unauthenticated() const { return unsigned_dropped + old_format + stale + replayed + bad_tags; }
};

// Subscribe's channel for every message, whatever its channel (a client
// listening for what is on the bus; no LCM channel is empty).
inline constexpr const char* kEveryChannel = "";

class Bus {
 public:
  // One message: channel name and payload (an LCM-encoded type). The views
  // are valid only during the call.
  using Handler = std::function<void(std::string_view channel, const std::uint8_t* data, std::size_t size)>;

  virtual ~Bus() = default;

  // Sends one message without blocking. False (and counted) when it is larger
  // than kMaxMessageSize, the channel is longer than 63 bytes, or the send failed.
  virtual bool Publish(std::string_view channel, const void* data, std::size_t size) = 0;

  // Calls `handler` for every message on exactly `channel` (kEveryChannel: on
  // every channel). Before sharing the bus.
  // UdpmBus opens its receive socket at the first Subscribe (a publish-only bus
  // has none) and throws BusError there if bind or the group membership fails.
  virtual void Subscribe(const std::string& channel, Handler handler) = 0;

  // A file descriptor that polls readable when Drain has work; -1 when none
  // (InProcessBus: Drain whenever).
  virtual int fd() const = 0;
  // Handles every message already waiting, at most `max` datagrams; never blocks.
  // Returns the number of datagrams read.
  virtual int Drain(int max = 1024) = 0;
  // Waits up to `timeout_ms` for messages, then drains. Returns datagrams read.
  virtual int Handle(int timeout_ms) = 0;

  virtual BusStats stats() const = 0;
  // Messages on `channel` (a subscribed one) refused for their signature;
  // 0 for any other channel or without a key. Safe from any thread.
  virtual std::int64_t unauthenticated_on(std::string_view channel) const = 0;
  // Whether this bus signs what it sends and checks what it receives.
  virtual bool signs() const = 0;
  // The domain its tags are bound to; "" when it does not sign.
  virtual const std::string& domain() const = 0;
  // The receive socket's buffer as the kernel granted it (SO_RCVBUF, which the
  // kernel reports doubled for its bookkeeping), bytes; 0 without one (nothing
  // subscribed, or an InProcessBus).
  virtual int receive_buffer_bytes() const = 0;

  // Encodes an LCM type into a reusable buffer and publishes it.
  template <class Message>
  bool PublishMessage(std::string_view channel, const Message& message) {
    const int size = message.getEncodedSize();
    if (size < 0 || static_cast<std::size_t>(size) > kMaxMessageSize)
      return Publish(channel, nullptr, kMaxMessageSize + 1);
    encode_buffer_.resize(static_cast<std::size_t>(size));
    if (message.encode(encode_buffer_.data(), 0, size) != size) return Publish(channel, nullptr, kMaxMessageSize + 1);
    return Publish(channel, encode_buffer_.data(), encode_buffer_.size());
  }

 private:
  std::vector<std::uint8_t> encode_buffer_;
};

// What a bus keeps of one subscription, and the refusals counted on one
// channel (a deque of these: the counter never moves once a thread reads it).
struct Subscription {
  std::string channel;
  Bus::Handler handler;
  std::size_t drops = 0;  // index of its channel's ChannelDrops
};
struct ChannelDrops {
  explicit ChannelDrops(std::string c) : channel(std::move(c)) {}
  std::string channel;
  std::atomic<std::int64_t> count{0};
};

// The URL of the in-process bus.
inline constexpr const char* kInProcessUrl = "inprocess://";

// The domain a signed bus on `url` has unless it is given one: the bus
// itself, "udpm://GROUP:PORT" (not its ttl or receive buffer, which hosts on
// one bus may set differently); "inprocess://" for that bus. BusUrlError for
// a malformed URL.
std::string BusDomainOf(const std::string& url);

// Opens a bus for `url` (see above); throws BusError with one line naming the
// URL and the reason (socket, bind or multicast membership failed), a
// BusUrlError for a bad URL.
// With `key`, the bus signs and verifies (see above) for `domain` ("":
// BusDomainOf(url)); it keeps its own copy. BusKeyError for a domain that
// cannot be one (BusDomainProblem).
std::unique_ptr<Bus> OpenBus(const std::string& url, const BusKey* key = nullptr, const std::string& domain = "");

// A bus inside one process: Publish queues, Drain delivers in order to the
// subscribers of this same object. Every count is exact; for tests.
class InProcessBus final : public Bus {
 public:
  // With `key`: signed for `domain` ("": "inprocess://").
  explicit InProcessBus(const BusKey* key = nullptr, WallClockMicros clock = SystemWallMicros,
                        const std::string& domain = "");
  ~InProcessBus() override;
  bool Publish(std::string_view channel, const void* data, std::size_t size) override;
  void Subscribe(const std::string& channel, Handler handler) override;
  int fd() const override { return -1; }
  int Drain(int max = 1024) override;
  int Handle(int timeout_ms) override;
  BusStats stats() const override { return stats_; }
  std::int64_t unauthenticated_on(std::string_view channel) const override;
  bool signs() const override { return signer_ != nullptr; }
  const std::string& domain() const override { return domain_; }
  int receive_buffer_bytes() const override { return 0; }

  // Queues a raw datagram as UdpmBus would read it from the wire (LC02/LC03
  // header included), to test the datagram parser without sockets.
  void InjectDatagram(const void* data, std::size_t size);

 private:
  struct Datagram {
    std::vector<std::uint8_t> bytes;
  };
  std::deque<Datagram> queue_;
  std::vector<Subscription> subscriptions_;
  std::deque<ChannelDrops> drops_;  // one per distinct subscribed channel
  BusStats stats_;
  std::uint32_t seqno_ = 0;
  std::string domain_;  // "" unsigned
  std::unique_ptr<Signer> signer_;
  std::unique_ptr<Verifier> verifier_;
};

// LCM's datagram format, written once for UdpmBus and InProcessBus.
//   short message:  "LC02" (u32 BE 0x4c433032), seqno u32 BE, channel NUL-terminated, payload
//   fragment:       "LC03" (0x4c433033), ... (dropped and counted, never parsed further)
// A signed bus's trailer (protocol/signing.hpp) is allowed beyond kMaxMessageSize.
struct Datagram {
  enum class Kind : std::uint8_t { kMessage, kFragment, kMalformed, kOversized };
  Kind kind = Kind::kMalformed;
  std::string_view channel;
  const std::uint8_t* payload = nullptr;
  std::size_t payload_size = 0;
};
// Classifies `size` bytes read from the wire: a payload over `max_payload` is
// kOversized. Never reads outside [data, data + size).
Datagram ParseDatagram(const std::uint8_t* data, std::size_t size, std::size_t max_payload = kMaxMessageSize);
// Writes an LC02 datagram for (seqno, channel, payload) into `out`; false (nothing written) when it
// would exceed `capacity` or the channel is longer than 63 bytes or holds a NUL.
bool FormatDatagram(std::uint32_t seqno, std::string_view channel, const void* payload, std::size_t size,
                    std::uint8_t* out, std::size_t capacity, std::size_t& written);

}  // namespace lagrange
