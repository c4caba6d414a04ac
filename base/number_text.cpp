#include "base/number_text.hpp"

#include <charconv>

namespace lagrange {

std::string FormatDouble(double x) {
  char buf[32];  // the longest shortest text of a double is 24 characters ("-2.2250738585072014e-308")
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, end) : std::string("nan");
}

}  // namespace lagrange
