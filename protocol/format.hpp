#pragma once
// Numbers as lagrange's text shows them (FormatDouble: base/number_text.hpp,
// the one formatter, included here for the protocol's callers); and how far
// apart two words are, for "did you mean" hints.

#include <cstddef>
#include <string>

#include "base/number_text.hpp"

namespace lagrange {

// Levenshtein distance: insertions, deletions and substitutions.
std::size_t EditDistance(const std::string& a, const std::string& b);

}  // namespace lagrange
