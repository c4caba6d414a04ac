// Where the threads meet (daemon/mailbox.hpp), with a real producer and
// consumer thread each: a LatestMailbox hands over only newer values and
// never a torn one; an SpscRing keeps first-in first-out order and refuses,
// rather than blocks, when full. Seeded, with a bounded number of values, so
// the same run is the same test on any machine; under ThreadSanitizer
// (scripts/test-tsan) it also proves the hand-over is race-free.

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <random>
#include <thread>

#include "daemon/mailbox.hpp"

namespace lagrange {
namespace {

// Every field carries the same number: a value read while it was being
// written shows two different ones.
struct Stamped {
  std::array<std::uint64_t, 16> words{};
  void Fill(std::uint64_t v) { words.fill(v); }
  bool Whole() const {
    for (const std::uint64_t w : words) {
      if (w != words[0]) return false;
    }
    return true;
  }
};

constexpr std::uint64_t kValues = 50'000;

// Now and then gives up the CPU, so the two threads interleave in many ways.
class Jitter {
 public:
  explicit Jitter(std::uint32_t seed) : rng_(seed) {}
  void operator()() {
    if (rng_() % 32 == 0) std::this_thread::yield();
  }

 private:
  std::mt19937 rng_;
};

TEST(LatestMailbox, AConsumerSeesOnlyNewerWholeValuesAndFinallyTheNewest) {
  LatestMailbox<Stamped> box(Stamped{});
  std::thread producer([&] {
    Jitter jitter(42);
    for (std::uint64_t v = 1; v <= kValues; ++v) {
      box.back().Fill(v);
      box.Publish();
      jitter();
    }
  });
  Jitter jitter(43);
  std::uint64_t last = 0, taken = 0, torn = 0, not_newer = 0;
  while (last < kValues) {
    if (const Stamped* s = box.Take()) {
      torn += !s->Whole();
      not_newer += s->words[0] <= last;
      last = s->words[0];
      ++taken;
    }
    jitter();
  }
  producer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(not_newer, 0u);
  EXPECT_EQ(last, kValues);
  EXPECT_GE(taken, 1u);
  EXPECT_EQ(box.Take(), nullptr);  // each value once
}

TEST(LatestMailbox, AValueIsTakenOnceAndTheLatestWins) {
  LatestMailbox<int> box(0);
  EXPECT_EQ(box.Take(), nullptr);
  for (int v = 1; v <= 3; ++v) {
    box.back() = v;
    box.Publish();
  }
  const int* got = box.Take();
  ASSERT_NE(got, nullptr);
  EXPECT_EQ(*got, 3);
  EXPECT_EQ(box.Take(), nullptr);
}

TEST(SpscRing, AConcurrentConsumerGetsEveryValueInOrderAndAFullRingRefuses) {
  SpscRing<Stamped> ring(16, Stamped{});
  std::uint64_t attempts = 0, refusals = 0;
  std::thread producer([&] {
    Jitter jitter(42);
    for (std::uint64_t v = 1; v <= kValues;) {
      ++attempts;
      if (Stamped* slot = ring.BeginPush()) {
        slot->Fill(v++);
        ring.Push();
      } else {
        ++refusals;  // full: the producer counts it and carries on (here: tries again)
        std::this_thread::yield();
      }
      jitter();
    }
  });
  Jitter jitter(43);
  std::uint64_t expected = 1, torn = 0, out_of_order = 0;
  while (expected <= kValues) {
    if (Stamped* s = ring.Front()) {
      torn += !s->Whole();
      out_of_order += s->words[0] != expected;
      ++expected;
      ring.Pop();
    }
    jitter();
  }
  producer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(ring.Front(), nullptr);
  EXPECT_EQ(attempts, kValues + refusals);
}

TEST(SpscRing, HoldsExactlyItsCapacityThenRefusesUntilOneIsTaken) {
  SpscRing<int> ring(4, 0);
  EXPECT_EQ(ring.capacity(), 4u);
  EXPECT_EQ(ring.Front(), nullptr);
  for (int v = 1; v <= 4; ++v) {
    int* slot = ring.BeginPush();
    ASSERT_NE(slot, nullptr) << v;
    *slot = v;
    ring.Push();
  }
  EXPECT_EQ(ring.BeginPush(), nullptr);
  ASSERT_NE(ring.Front(), nullptr);
  EXPECT_EQ(*ring.Front(), 1);
  ring.Pop();
  int* slot = ring.BeginPush();
  ASSERT_NE(slot, nullptr);
  *slot = 5;
  ring.Push();
  for (int v = 2; v <= 5; ++v) {  // first in, first out, across the wrap
    ASSERT_NE(ring.Front(), nullptr);
    EXPECT_EQ(*ring.Front(), v);
    ring.Pop();
  }
  EXPECT_EQ(ring.Front(), nullptr);
}

}  // namespace
}  // namespace lagrange
