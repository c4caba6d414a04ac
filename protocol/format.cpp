#include "protocol/format.hpp"

#include <charconv>

namespace lagrange {

std::string FormatDouble(double x) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, end) : std::string("nan");
}

}  // namespace lagrange
