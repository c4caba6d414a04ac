// Run and request ids (protocol/ids.hpp): random, never 0 (0 means "none" on
// the wire), printed as 16 hex digits whatever their sign.

#include "protocol/ids.hpp"

#include <gtest/gtest.h>

#include <set>

namespace lagrange {
namespace {

TEST(Ids, FreshIdsAreNonZeroAndDistinct) {
  std::set<std::int64_t> ids;
  for (int i = 0; i < 100; ++i) {
    ids.insert(NewRunId());
    ids.insert(NewRequestId());
  }
  EXPECT_EQ(ids.count(0), 0u);
  EXPECT_EQ(ids.size(), 200u);  // 2^-57 odds of a collision
}

TEST(Ids, AnIdIsPrintedAsSixteenHexDigits) {
  EXPECT_EQ(RunIdText(0x1234), "0000000000001234");
  EXPECT_EQ(RunIdText(-1), "ffffffffffffffff");
  EXPECT_EQ(RunIdText(0), "0000000000000000");
}

}  // namespace
}  // namespace lagrange
