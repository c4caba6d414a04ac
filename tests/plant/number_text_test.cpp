// FormatDouble (base/number_text.hpp): lagrange's one text of a double, the
// shortest that reads back to exactly the same bits.

#include "base/number_text.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>

namespace lagrange {
namespace {

std::uint64_t Bits(double x) { return std::bit_cast<std::uint64_t>(x); }

// The text read back by the C library, compared bit for bit (so −0 is not 0).
void ExpectRoundTrip(double x) {
  const std::string text = FormatDouble(x);
  char* end = nullptr;
  const double back = std::strtod(text.c_str(), &end);
  EXPECT_EQ(end, text.c_str() + text.size()) << text;
  EXPECT_EQ(Bits(back), Bits(x)) << text;
}

TEST(FormatDouble, WritesAwkwardDoublesShortestAndTheyReadBackBitForBit) {
  const double denorm_min = std::numeric_limits<double>::denorm_min();
  const double largest_denormal = std::numeric_limits<double>::min() - denorm_min;
  const struct {
    double x;
    const char* text;
  } cases[] = {
      {0.1, "0.1"},
      {1e-300, "1e-300"},
      {denorm_min, "5e-324"},
      {largest_denormal, "2.225073858507201e-308"},
      {-0.0, "-0"},
      {0.0, "0"},
      {1.0 / 3.0, "0.3333333333333333"},
      {2.0 / 3.0, "0.6666666666666666"},
      {9007199254740992.0, "9007199254740992"},  // 2⁵³
      {9007199254740994.0, "9007199254740994"},  // 2⁵³ + 2, the next double
      {1e22, "1e+22"},
      {std::numeric_limits<double>::max(), "1.7976931348623157e+308"},
      {-0.30000000000000004, "-0.30000000000000004"},  // 0.1 + 0.2: 17 digits are needed
      {0.002, "0.002"},
  };
  for (const auto& c : cases) {
    EXPECT_EQ(FormatDouble(c.x), c.text);
    ExpectRoundTrip(c.x);
  }
}

// Seeded random bit patterns over every exponent: each finite one reads back
// exactly, and in no more characters than printf's 17 significant digits.
TEST(FormatDouble, RandomDoublesReadBackBitForBitInAtMostSeventeenDigits) {
  std::mt19937_64 rng{42};
  int finite = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = std::bit_cast<double>(rng());
    if (!std::isfinite(x)) continue;
    ++finite;
    ExpectRoundTrip(x);
    char seventeen[40];
    std::snprintf(seventeen, sizeof seventeen, "%.17g", x);
    EXPECT_LE(FormatDouble(x).size(), std::string(seventeen).size()) << seventeen;
  }
  EXPECT_GT(finite, 19000);
}

// Not numbers: written as std::to_chars and printf write them; strtod reads
// these words back as the same kind of value.
TEST(FormatDouble, WritesInfinitiesAndNanAsWords) {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(FormatDouble(inf), "inf");
  EXPECT_EQ(FormatDouble(-inf), "-inf");
  EXPECT_EQ(FormatDouble(nan), "nan");
  EXPECT_EQ(FormatDouble(std::copysign(nan, -1.0)), "-nan");
  ExpectRoundTrip(inf);
  ExpectRoundTrip(-inf);
  EXPECT_TRUE(std::isnan(std::strtod(FormatDouble(nan).c_str(), nullptr)));
}

}  // namespace
}  // namespace lagrange
