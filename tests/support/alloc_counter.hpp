#pragma once
// Counts heap allocations made by the current thread inside a scope. Linking
// alloc_counter.cpp interposes malloc and its relatives (or, under a
// sanitizer, installs the sanitizer's allocation hook), so Eigen's and the
// standard library's allocations are all seen.

#include <cstdint>

namespace lagrange::testing {

class AllocationCounter {
 public:
  AllocationCounter();
  ~AllocationCounter();
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;

  // Allocations on this thread since construction.
  std::int64_t count() const;

 private:
  std::int64_t start_;
  bool was_enabled_;
};

}  // namespace lagrange::testing
