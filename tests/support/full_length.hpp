#pragma once
// Long hard cases run scaled down in CI; LAGRANGE_FULL_LENGTH=1 runs them at
// the full length the README states.

#include <cstdlib>
#include <string>

namespace lagrange::testing {

inline bool FullLength() {
  const char* v = std::getenv("LAGRANGE_FULL_LENGTH");
  return v != nullptr && std::string(v) == "1";
}

// `full` at full length, `ci` otherwise.
template <class T>
T Length(T ci, T full) {
  return FullLength() ? full : ci;
}

}  // namespace lagrange::testing
