#pragma once
// Shared pieces of lagrangectl's commands: usage errors, strict number lists,
// JSON and CSV number formatting.

#include <ostream>
#include <stdexcept>
#include <string>
#include <string_view>

#include "plant/types.hpp"

namespace lagrange::cli {

// A bad argument: printed as one line "lagrangectl <command>: <message>", exit 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "a,b,c" => (a, b, c): every item a finite number; `expected` > 0 checks the count.
VectorXd ParseNumberList(std::string_view option, std::string_view text, int expected);

// Shortest text that reads back to the same double.
std::string FormatDouble(double x);

void WriteJsonVector(std::ostream& out, const VectorXd& v);
void WriteJsonMatrix(std::ostream& out, const MatrixXd& m);

}  // namespace lagrange::cli
