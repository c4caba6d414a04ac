#pragma once
// The bus domain of signed traffic (protocol/signing.hpp): the one definition
// of what a domain is, where a program finds it and the bytes the MAC absorbs
// for it, shared by lagrange's own signing and by the example clients
// (examples/cpp/bus_signing.hpp). Header-only, the standard library alone:
// installed beside the message types as <lagrange/bus_domain.hpp>, so a copy
// of an example builds against an installed lagrange.
//
// Why a domain: every program on a signed bus shares one key, and a tag
// without a domain is valid on any bus with that key: a datagram captured on
// one bus and resent to another within the 2 s stamp window (a relay) would
// be taken there, a clear_estop meant for one robot clearing another's stop.
// With the domain in the tag, what was signed for one bus does not verify on
// another. By default the domain is the bus itself, "udpm://GROUP:PORT" of its
// URL (its ttl and receive buffer left out: hosts on one bus may set those
// differently); a deployment names its own (--bus-domain, $LAGRANGE_BUS_DOMAIN,
// a scene's bus.domain) when one bus is bridged to another (lcm-tunnel), or
// when separate networks use the same group and port with one key.

#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace lagrange {

// A key or domain that cannot be used: one line naming it and why.
struct BusKeyError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Where a program finds the domain when none is given.
inline constexpr const char* kBusDomainEnv = "LAGRANGE_BUS_DOMAIN";
// A domain is 1 to this many printable ASCII characters.
inline constexpr std::size_t kMaxBusDomainBytes = 64;

// The domain of a bus on `url` when none is given: "udpm://GROUP:PORT" (what
// precedes the query), any other URL as it is. Checks nothing (the bus checks its URL).
inline std::string BusDomainOfUrl(std::string_view url) {
  if (url.rfind("udpm://", 0) != 0) return std::string(url);
  return std::string(url.substr(0, url.find('?')));
}

// Why `domain` cannot be one ("" when it can); `what` names where it came from.
inline std::string BusDomainProblem(const std::string& what, std::string_view domain) {
  bool printable = true;
  for (const char c : domain) printable = printable && c >= 0x20 && c < 0x7f;
  if (domain.empty()) {
    return what + ": an empty bus domain (an unset variable?); name one, or give none for the bus's own "
                  "(udpm://GROUP:PORT of its URL)";
  }
  if (domain.size() > kMaxBusDomainBytes || !printable) {
    return what + ": a bus domain is 1 to " + std::to_string(kMaxBusDomainBytes) +
           " printable ASCII characters, got " + std::to_string(domain.size()) + " bytes" +
           (printable ? "" : " with control or non-ASCII bytes");
  }
  return "";
}

// The domain given: `option` when given (--bus-domain), else $LAGRANGE_BUS_DOMAIN
// when set, else "" (the bus's own: BusDomainOfUrl). Throws BusKeyError for one
// that is empty, too long or not printable ASCII, naming where it came from.
inline std::string ResolveBusDomain(const std::optional<std::string>& option) {
  std::string what = "--bus-domain";
  std::string domain;
  if (option) {
    domain = *option;
  } else if (const char* env = std::getenv(kBusDomainEnv)) {
    what = std::string("$") + kBusDomainEnv;
    domain = env;
  } else {
    return "";
  }
  if (const std::string why = BusDomainProblem(what, domain); !why.empty()) throw BusKeyError(why);
  return domain;
}

// What the MAC absorbs after the key, before every message: the trailer's
// mark "LGS2", the domain, a NUL (a domain holds none, so no two domains
// give the same bytes). Throws BusKeyError for a domain that cannot be one.
inline std::string BusDomainBytes(std::string_view domain) {
  if (const std::string why = BusDomainProblem("bus domain", domain); !why.empty()) throw BusKeyError(why);
  std::string bytes = "LGS2";
  bytes += domain;
  bytes += '\0';
  return bytes;
}

}  // namespace lagrange
