#pragma once
// Foreign text (from the bus: controller names, reasons that quote them; from
// a file: a URDF's names) is printed to logs, statuses,
// messages and terminals only through Escape: a newline cannot forge a log
// line and an ANSI/OSC sequence cannot reach a terminal.
//
// It lives in lagrange_base, the bottom layer, because the URDF reader
// (plant/urdf.cpp), the protocol and every front-end quote foreign text; it
// is pure string work, no I/O.

#include <string>
#include <string_view>

namespace lagrange {

// `text` with every byte below 0x20, 0x7f (DEL) and '\\' written as a C
// escape (\n, \t, \\, else \xHH), and cut to at most `max_bytes` of input
// with "..." appended when longer; the cut falls on a character boundary
// (never inside a UTF-8 sequence), so valid UTF-8 stays valid. Bytes ≥ 0x80 pass unchanged (UTF-8 stays readable;
// C1 controls in UTF-8 form are two bytes that terminals do not act on).
std::string Escape(std::string_view text, std::size_t max_bytes = 200);

}  // namespace lagrange
