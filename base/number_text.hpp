#pragma once
// Numbers as lagrange's text shows them (messages, CSV, the MJCF it writes for
// MuJoCo): the shortest text that reads back to the same double. One formatter
// for every layer: it lives in lagrange_base, the bottom layer, because the
// MuJoCo plant (plant/mujoco_plant.cpp) writes numbers too; it is pure string
// work, no I/O.

#include <string>

namespace lagrange {

// The shortest text that std::strtod (or std::from_chars) reads back as
// exactly x, as std::to_chars writes it: plain or with an exponent, whichever
// is shorter ("0.1", "1e-300", "5e-324", "-0", "0.3333333333333333",
// "9007199254740992", "1e+22"). Infinities and NaN are written "inf", "-inf",
// "nan" ("-nan" with the sign bit set).
std::string FormatDouble(double x);

}  // namespace lagrange
