#include "protocol/ids.hpp"

#include <sys/random.h>

#include <cstdio>
#include <stdexcept>

namespace lagrange {
namespace {

std::int64_t NonZeroRandom(const char* what) {
  std::int64_t id = 0;
  while (id == 0) {
    if (getrandom(&id, sizeof id, 0) != static_cast<ssize_t>(sizeof id)) {
      throw std::runtime_error(std::string("getrandom failed: cannot make a ") + what);
    }
  }
  return id;
}

}  // namespace

std::int64_t NewRunId() { return NonZeroRandom("run id"); }

std::int64_t NewRequestId() { return NonZeroRandom("request id"); }

std::string RunIdText(std::int64_t id) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(static_cast<std::uint64_t>(id)));
  return buf;
}

}  // namespace lagrange
