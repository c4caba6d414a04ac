#pragma once
// Where threads meet: single-producer single-consumer, lock-free, non-blocking.
// Every slot is built from a prototype before the loop starts, so neither
// side allocates (for Eigen members, assignment between equal sizes does not).

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace lagrange {

// Latest wins (a triple buffer): the producer may publish faster than the
// consumer takes; the consumer always gets the newest value, once.
template <class T>
class LatestMailbox {
 public:
  explicit LatestMailbox(const T& prototype) : slots_{prototype, prototype, prototype} {}

  // Producer: fill back(), then Publish().
  T& back() { return slots_[back_]; }
  void Publish() {
    back_ = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) & kIndex;
  }

  // Consumer: the newest published value if there is one not taken yet, else null.
  // The pointer stays valid until the next Take().
  const T* Take() {
    if ((middle_.load(std::memory_order_acquire) & kFresh) == 0) return nullptr;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    return &slots_[front_];
  }

 private:
  static constexpr std::uint8_t kIndex = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;
  std::array<T, 3> slots_;
  std::uint8_t back_ = 0;                // producer's
  std::atomic<std::uint8_t> middle_{1};  // shared
  std::uint8_t front_ = 2;               // consumer's
};

// A bounded first-in first-out ring. A full ring refuses a push (the producer
// counts the drop) instead of blocking.
template <class T>
class SpscRing {
 public:
  SpscRing(std::size_t capacity, const T& prototype) : slots_(capacity + 1, prototype) {}

  std::size_t capacity() const { return slots_.size() - 1; }

  // Producer: a slot to fill, or null when full; then Push().
  T* BeginPush() {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    const std::size_t next = head + 1 == slots_.size() ? 0 : head + 1;
    if (next == tail_.load(std::memory_order_acquire)) return nullptr;
    return &slots_[head];
  }
  void Push() {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    head_.store(head + 1 == slots_.size() ? 0 : head + 1, std::memory_order_release);
  }

  // Consumer: the oldest slot, or null when empty; then Pop().
  T* Front() {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return nullptr;
    return &slots_[tail];
  }
  void Pop() {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    tail_.store(tail + 1 == slots_.size() ? 0 : tail + 1, std::memory_order_release);
  }

 private:
  std::vector<T> slots_;
  alignas(64) std::atomic<std::size_t> head_{0};  // next slot to write
  alignas(64) std::atomic<std::size_t> tail_{0};  // next slot to read
};

}  // namespace lagrange
