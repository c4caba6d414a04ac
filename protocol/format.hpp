#pragma once
// Numbers as lagrange's text shows them (messages, CSV): the shortest text
// that reads back to the same double.

#include <string>

namespace lagrange {

// Shortest text that reads back to the same double ("nan" when it cannot be written).
std::string FormatDouble(double x);

}  // namespace lagrange
