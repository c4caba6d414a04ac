#pragma once
// Signed traffic for a client of lagranged (README, "Signed traffic"), written
// out as a client in any language would write it. After the LCM-encoded
// message: sender id (8 bytes), stamp (8: µs since the epoch, growing), tag
// (16), "LGS2"; the tag is keyed BLAKE2b-128 (libsodium) of "LGS2" ‖ domain ‖
// NUL ‖ channel ‖ NUL ‖ message ‖ sender id ‖ stamp, integers big-endian. The
// domain (what binds a tag to one bus) is lagrange's own definition,
// <lagrange/bus_domain.hpp>: --bus-domain, else $LAGRANGE_BUS_DOMAIN, else
// "udpm://GROUP:PORT" of the URL. A message is believed when its tag
// verifies, its stamp is within 2 s of this clock and not before this client
// started, and newer than its sender's last. Only libsodium.
#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>
#include <lagrange/bus_domain.hpp>
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

inline std::int64_t WallMicros() {
  return std::chrono::system_clock::now().time_since_epoch() / std::chrono::microseconds(1);
}

// The value of option `name` in argv (the last one given), or none: an option given empty ("--bus-key ''", an
// unset variable) is then told apart from one not given.
inline std::optional<std::string> GivenOption(int argc, char** argv, const std::string& name) {
  std::optional<std::string> value;
  for (int i = 1; i + 1 < argc; i += 2)
    if (argv[i] == name) value = argv[i + 1];
  return value;
}

class BusSigning {
 public:
  // `key_file` none → $LAGRANGE_BUS_KEY_FILE → unsigned; `domain` none → $LAGRANGE_BUS_DOMAIN → "udpm://GROUP:PORT"
  // of `url` (the URL given to lcm::LCM; "" → $LCM_DEFAULT_URL or LCM's default). Throws std::invalid_argument
  // (the caller's mistake) for an empty path, a key file that is missing, a symbolic link, readable by group or
  // others, not 32 to 64 bytes or all one byte value, and for a domain that cannot be one.
  BusSigning(std::optional<std::string> key_file, std::optional<std::string> domain, std::string url) {
    const char* env = std::getenv("LAGRANGE_BUS_KEY_FILE");
    if (!key_file && env != nullptr) key_file = env;
    if (key_file && key_file->empty()) throw std::invalid_argument("bus key '': an empty path (an unset variable?)");
    try {
      domain_ = lagrange::ResolveBusDomain(domain);
    } catch (const lagrange::BusKeyError& e) {
      throw std::invalid_argument(e.what());
    }
    if (!key_file) return;
    if (url.empty()) url = std::getenv("LCM_DEFAULT_URL") != nullptr ? std::getenv("LCM_DEFAULT_URL") : "";
    if (url.empty()) url = "udpm://239.255.76.67:7667?ttl=0";  // LCM's default
    if (domain_.empty()) domain_ = lagrange::BusDomainOfUrl(url);
    if (sodium_init() < 0) throw std::runtime_error("libsodium cannot be initialised");
    const std::string& path = *key_file;
    const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);  // a symbolic link is refused (ELOOP)
    struct stat st {};
    if (fd < 0 && errno == ELOOP)
      throw std::invalid_argument("bus key " + path + ": a symbolic link; name the file itself");
    if (fd < 0 || fstat(fd, &st) != 0) throw std::invalid_argument("bus key " + path + ": " + std::strerror(errno));
    key_.resize(65);  // one more than a key can be: a longer file is seen
    const ssize_t n = S_ISREG(st.st_mode) && (st.st_mode & 077) == 0 ? read(fd, key_.data(), 65) : -1;
    close(fd);
    key_.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    if (!S_ISREG(st.st_mode) || (st.st_mode & 077) != 0)
      throw std::invalid_argument("bus key " + path + ": not a regular file readable by its owner only");
    if (key_.size() < 32 || key_.size() > 64 || std::all_of(key_.begin(), key_.end(), [&](auto b) { return b == key_[0]; }))
      throw std::invalid_argument("bus key " + path + ": not 32 to 64 random bytes");
    personal_ = lagrange::BusDomainBytes(domain_);  // "LGS2" ‖ domain ‖ NUL, absorbed after the key
    randombytes_buf(&sender_, sizeof sender_);
  }

  // Decodes a received message into `msg`; with a key, only one whose trailer verifies.
  template <class Message>
  bool Decode(const std::string& channel, const lcm::ReceiveBuffer& rbuf, Message& msg) {
    const auto* data = static_cast<const unsigned char*>(rbuf.data);
    const std::size_t size = key_.empty() ? rbuf.data_size : Check(channel, data, rbuf.data_size);
    return size > 0 && msg.decode(data, 0, static_cast<int>(size)) == static_cast<int>(size);
  }

  // Encodes `msg`, appends the trailer when there is a key, and publishes it.
  template <class Message>
  void Publish(lcm::LCM& lcm, const std::string& channel, const Message& msg) {
    std::vector<unsigned char> data(static_cast<std::size_t>(msg.getEncodedSize()));
    msg.encode(data.data(), 0, static_cast<int>(data.size()));
    if (!key_.empty()) Append(channel, data);
    lcm.publish(channel, data.data(), static_cast<unsigned>(data.size()));
  }

 private:
  static constexpr std::size_t kTrailer = 36;
  static constexpr std::int64_t kWindow = 2'000'000;  // µs

  static void Put64(std::uint64_t v, unsigned char* p) {
    for (int i = 7; i >= 0; --i, v >>= 8) p[i] = static_cast<unsigned char>(v);
  }
  static std::uint64_t Get64(const unsigned char* p) {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
    return v;
  }
  void Tag(const std::string& channel, const unsigned char* msg, std::size_t n, const unsigned char* ids,
           unsigned char* tag) const {
    crypto_generichash_state s;
    crypto_generichash_init(&s, key_.data(), key_.size(), 16);
    crypto_generichash_update(&s, reinterpret_cast<const unsigned char*>(personal_.data()), personal_.size());
    crypto_generichash_update(&s, reinterpret_cast<const unsigned char*>(channel.c_str()), channel.size() + 1);
    crypto_generichash_update(&s, msg, n);
    crypto_generichash_update(&s, ids, 16);  // sender id, stamp
    crypto_generichash_final(&s, tag, 16);
  }
  void Append(const std::string& channel, std::vector<unsigned char>& data) {
    const std::size_t n = data.size();
    const auto now = static_cast<std::uint64_t>(WallMicros());
    last_stamp_ = now > last_stamp_ ? now : last_stamp_ + 1;
    data.resize(n + kTrailer);
    Put64(sender_, &data[n]);
    Put64(last_stamp_, &data[n + 8]);
    Tag(channel, data.data(), n, &data[n], &data[n + 16]);
    std::memcpy(&data[n + 32], "LGS2", 4);
  }
  // The message's size when its trailer verifies; 0 otherwise.
  std::size_t Check(const std::string& channel, const unsigned char* data, std::size_t size) {
    if (size < kTrailer || std::memcmp(data + size - 4, "LGS2", 4) != 0) return 0;
    const std::size_t n = size - kTrailer;
    const std::uint64_t id = Get64(data + n), stamp = Get64(data + n + 8);
    const std::int64_t now = WallMicros(), at = static_cast<std::int64_t>(stamp);
    const auto last = heard_.find(id);  // find, not []: a forger's sender ids must not fill the map
    if (at < opened_ || at < now - kWindow || at > now + kWindow || (last != heard_.end() && stamp <= last->second))
      return 0;
    unsigned char tag[16];
    Tag(channel, data, n, data + n, tag);
    if (sodium_memcmp(tag, data + n + 16, 16) != 0) return 0;
    heard_[id] = stamp;
    return n;
  }

  std::vector<unsigned char> key_;  // empty: unsigned
  std::string domain_, personal_;   // what the tags are bound to, and its bytes in the MAC
  std::uint64_t sender_ = 0, last_stamp_ = 0;
  std::map<std::uint64_t, std::uint64_t> heard_;  // sender id → last stamp believed
  std::int64_t opened_ = WallMicros();
};
