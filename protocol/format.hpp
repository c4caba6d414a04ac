#pragma once
// Numbers as lagrange's text shows them (messages, CSV): the shortest text
// that reads back to the same double; and how far apart two words are, for
// "did you mean" hints.

#include <cstddef>
#include <string>

namespace lagrange {

// Shortest text that reads back to the same double ("nan" when it cannot be written).
std::string FormatDouble(double x);

// Levenshtein distance: insertions, deletions and substitutions.
std::size_t EditDistance(const std::string& a, const std::string& b);

}  // namespace lagrange
