#include "protocol/signing.hpp"

#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "protocol/big_endian.hpp"

namespace lagrange {
namespace {

constexpr std::uint8_t kTrailerMagic[4] = {'L', 'G', 'S', '2'};
constexpr std::uint8_t kOldTrailerMagic[4] = {'L', 'G', 'S', '1'};  // before domains: refused as kOldFormat
static_assert(sizeof(crypto_generichash_state) <= 384 && alignof(crypto_generichash_state) <= 64);
static_assert(kSignatureTagBytes >= crypto_generichash_BYTES_MIN && kBusKeyMaxBytes <= crypto_generichash_KEYBYTES_MAX);

// libsodium must be initialised once before use (it picks the fastest BLAKE2b
// for this CPU and opens the random source); thread-safe and idempotent.
void InitSodium() {
  if (sodium_init() < 0) throw BusKeyError("libsodium cannot be initialised");
}

[[noreturn]] void Refuse(const std::string& path, const std::string& why) {
  throw BusKeyError("bus key " + path + ": " + why);
}

// Why a key of these bytes is no key: every byte one value (a file of zeros
// left as a placeholder), or "".
std::string PlaceholderProblem(std::span<const std::uint8_t> bytes) {
  if (bytes.empty() || std::any_of(bytes.begin(), bytes.end(), [&](std::uint8_t b) { return b != bytes[0]; })) return "";
  char value[8];
  std::snprintf(value, sizeof value, "0x%02x", bytes[0]);
  return std::string("every byte is ") + value + ": a placeholder, not a random key (lagrangectl keygen FILE makes one)";
}

// The refusal of a key path that is a symbolic link: where it points, and the
// file it resolves to, which is what to name instead.
std::string SymlinkProblem(const std::string& path) {
  std::string why = "a symbolic link";
  std::array<char, 4096> target{};
  const ssize_t n = readlink(path.c_str(), target.data(), target.size() - 1);
  if (n > 0) why += " (to " + std::string(target.data(), static_cast<std::size_t>(n)) + ")";
  why += ", refused: whoever can write the link's directory could point it at another key; name the key file itself";
  if (char* resolved = realpath(path.c_str(), nullptr)) {
    why += std::string(" (") + resolved + ")";
    std::free(resolved);
  }
  return why;
}


}  // namespace

BusKey BusKey::FromBytes(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kBusKeyMinBytes || bytes.size() > kBusKeyMaxBytes) {
    throw BusKeyError("a bus key is " + std::to_string(kBusKeyMinBytes) + " to " + std::to_string(kBusKeyMaxBytes) +
                      " bytes, got " + std::to_string(bytes.size()));
  }
  if (const std::string why = PlaceholderProblem(bytes); !why.empty()) throw BusKeyError("bus key: " + why);
  BusKey key;
  std::memcpy(key.bytes_.data(), bytes.data(), bytes.size());
  key.size_ = bytes.size();
  return key;
}

BusKey BusKey::FromFile(const std::string& path) {
  // Opened first and checked through the descriptor, so what is checked is what is read.
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (fd < 0) {
    const int saved = errno;
    struct stat link {};
    if (saved == ELOOP && lstat(path.c_str(), &link) == 0 && S_ISLNK(link.st_mode)) Refuse(path, SymlinkProblem(path));
    Refuse(path, std::strerror(saved));
  }
  struct stat st {};
  if (fstat(fd, &st) != 0) {
    const int saved = errno;
    close(fd);
    Refuse(path, std::strerror(saved));
  }
  auto fail = [&](const std::string& why) {
    close(fd);
    Refuse(path, why);
  };
  if (!S_ISREG(st.st_mode)) fail("not a regular file");
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    fail(std::string("readable by group or others (mode ") + mode + "): chmod 600 " + path);
  }
  if (st.st_size < static_cast<off_t>(kBusKeyMinBytes) || st.st_size > static_cast<off_t>(kBusKeyMaxBytes)) {
    fail(std::to_string(st.st_size) + " bytes; a key is " + std::to_string(kBusKeyMinBytes) + " to " +
         std::to_string(kBusKeyMaxBytes) + " random bytes (lagrangectl keygen FILE makes one)");
  }
  std::array<std::uint8_t, kBusKeyMaxBytes> bytes{};
  std::size_t got = 0;
  const auto want = static_cast<std::size_t>(st.st_size);
  while (got < want) {
    const ssize_t n = read(fd, bytes.data() + got, want - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail(n < 0 ? std::strerror(errno) : "shorter than its size");
    got += static_cast<std::size_t>(n);
  }
  close(fd);
  if (const std::string why = PlaceholderProblem({bytes.data(), got}); !why.empty()) Refuse(path, why);
  BusKey key = FromBytes({bytes.data(), got});
  sodium_memzero(bytes.data(), bytes.size());
  return key;
}

std::string ResolveBusKeyFile(const std::optional<std::string>& option) {
  if (option) {
    if (option->empty()) {
      throw BusKeyError(
          "bus key '': an empty path (an unset variable in a unit or script?); name the key file, or give no key "
          "to run unsigned");
    }
    return *option;
  }
  const char* env = std::getenv(kBusKeyEnv);
  if (env == nullptr) return "";
  if (*env == '\0') {
    throw BusKeyError(std::string("bus key: $") + kBusKeyEnv +
                      " is set but empty (an unset variable in a unit or script?); name the key file, or unset it "
                      "to run unsigned");
  }
  return env;
}

void WriteNewBusKey(const std::string& path) {
  InitSodium();
  std::array<std::uint8_t, kBusKeyMinBytes> bytes{};
  randombytes_buf(bytes.data(), bytes.size());
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0) Refuse(path, errno == EEXIST ? "exists; not overwritten" : std::strerror(errno));
  // The mode is set whatever the umask, and checked as a reader will check it.
  bool ok = fchmod(fd, 0600) == 0;
  std::size_t put = 0;
  while (ok && put < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + put, bytes.size() - put);
    if (n < 0 && errno == EINTR) continue;
    ok = n > 0;
    if (ok) put += static_cast<std::size_t>(n);
  }
  ok = ok && fsync(fd) == 0;
  const int saved = errno;
  sodium_memzero(bytes.data(), bytes.size());
  close(fd);
  if (!ok) {
    unlink(path.c_str());
    Refuse(path, std::string("cannot write: ") + std::strerror(saved));
  }
}

std::int64_t SystemWallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

KeyedMac::KeyedMac(const BusKey& key, std::string_view domain) {
  const std::string personal = BusDomainBytes(domain);  // "LGS2" ‖ domain ‖ NUL; BusKeyError for a bad domain
  InitSodium();
  auto* state = reinterpret_cast<crypto_generichash_state*>(state_.data());
  crypto_generichash_init(state, key.bytes().data(), key.bytes().size(), kSignatureTagBytes);
  crypto_generichash_update(state, reinterpret_cast<const unsigned char*>(personal.data()), personal.size());
}

void KeyedMac::Tag(std::string_view channel, const std::uint8_t* message, std::size_t size, std::uint64_t sender_id,
                   std::uint64_t stamp, std::uint8_t* tag) const {
  crypto_generichash_state state;
  std::memcpy(&state, state_.data(), sizeof state);
  static constexpr std::uint8_t kNul = 0;
  std::uint8_t nonce[16];
  WriteBigEndian64(sender_id, nonce);
  WriteBigEndian64(stamp, nonce + 8);
  crypto_generichash_update(&state, reinterpret_cast<const unsigned char*>(channel.data()), channel.size());
  crypto_generichash_update(&state, &kNul, 1);
  if (size > 0) crypto_generichash_update(&state, message, size);
  crypto_generichash_update(&state, nonce, sizeof nonce);
  crypto_generichash_final(&state, tag, kSignatureTagBytes);
}

Signer::Signer(const BusKey& key, std::string_view domain, std::uint64_t sender_id, WallClockMicros clock)
    : mac_(key, domain), sender_id_(sender_id), clock_(std::move(clock)) {
  while (sender_id_ == 0) randombytes_buf(&sender_id_, sizeof sender_id_);
}

void Signer::Sign(std::string_view channel, const std::uint8_t* message, std::size_t size, std::uint8_t* trailer) {
  const auto now = static_cast<std::uint64_t>(clock_());
  // Strictly increasing even when the wall clock steps back or two sends share a microsecond.
  last_stamp_ = now > last_stamp_ ? now : last_stamp_ + 1;
  WriteBigEndian64(sender_id_, trailer);
  WriteBigEndian64(last_stamp_, trailer + 8);
  mac_.Tag(channel, message, size, sender_id_, last_stamp_, trailer + 16);
  std::memcpy(trailer + 32, kTrailerMagic, sizeof kTrailerMagic);
}

std::size_t MessageSizeBeforeTrailer(const std::uint8_t* wire, std::size_t size) {
  if (wire == nullptr || size < kSignatureTrailerBytes) return size;
  const std::uint8_t* magic = wire + size - sizeof kTrailerMagic;
  const bool marked = std::memcmp(magic, kTrailerMagic, sizeof kTrailerMagic) == 0 ||
                      std::memcmp(magic, kOldTrailerMagic, sizeof kOldTrailerMagic) == 0;
  return marked ? size - kSignatureTrailerBytes : size;
}

Verifier::Verifier(const BusKey& key, std::string_view domain, WallClockMicros clock)
    : mac_(key, domain), clock_(std::move(clock)), opened_(clock_()) {}

Verifier::Sender* Verifier::Find(std::uint64_t id) {
  for (Sender& s : senders_) {
    if (s.used && s.id == id) return &s;
  }
  return nullptr;
}

Verifier::Sender& Verifier::Admit(std::uint64_t id) {
  Sender* oldest = &senders_[0];
  for (Sender& s : senders_) {
    if (!s.used) {
      oldest = &s;
      break;
    }
    if (s.heard < oldest->heard) oldest = &s;
  }
  *oldest = Sender{id, 0, 0, true};
  return *oldest;
}

SignatureVerdict Verifier::Verify(std::string_view channel, const std::uint8_t* wire, std::size_t wire_size,
                                  std::size_t& message_size) {
  message_size = 0;
  if (wire == nullptr || wire_size < kSignatureTrailerBytes) return SignatureVerdict::kUnsigned;
  const std::size_t size = wire_size - kSignatureTrailerBytes;
  const std::uint8_t* trailer = wire + size;
  if (std::memcmp(trailer + 32, kTrailerMagic, sizeof kTrailerMagic) != 0) {
    const bool old = std::memcmp(trailer + 32, kOldTrailerMagic, sizeof kOldTrailerMagic) == 0;
    return old ? SignatureVerdict::kOldFormat : SignatureVerdict::kUnsigned;
  }
  const std::uint64_t sender_id = ReadBigEndian64(trailer);
  const std::uint64_t stamp = ReadBigEndian64(trailer + 8);
  // The cheap checks first: a forger's datagram costs a MAC only when it could pass them.
  const std::int64_t now = clock_();
  const auto signed_stamp = static_cast<std::int64_t>(stamp);
  if (stamp > static_cast<std::uint64_t>(INT64_MAX) || signed_stamp < now - kStampWindowMicros ||
      signed_stamp > now + kStampWindowMicros || signed_stamp < opened_) {
    return SignatureVerdict::kStale;
  }
  Sender* known = Find(sender_id);
  if (known != nullptr && stamp <= known->last_stamp) return SignatureVerdict::kReplayed;
  std::uint8_t expected[kSignatureTagBytes];
  mac_.Tag(channel, wire, size, sender_id, stamp, expected);
  if (sodium_memcmp(expected, trailer + 16, kSignatureTagBytes) != 0) return SignatureVerdict::kBadTag;
  // Only a verified sender is remembered, so a forger cannot push the real ones out.
  Sender& s = known != nullptr ? *known : Admit(sender_id);
  s.last_stamp = stamp;
  s.heard = ++calls_;
  message_size = size;
  return SignatureVerdict::kOk;
}

}  // namespace lagrange
