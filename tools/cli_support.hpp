#pragma once
// Shared pieces of lagrangectl's commands: usage errors, number validators,
// per-joint values.

#include <CLI/CLI.hpp>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "plant/types.hpp"

namespace lagrange::cli {

// A bad argument: printed as one line "lagrangectl <command>: <message>", exit 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// CLI11 validators, each with a message that names what was expected. Used
// on every item of a ->delimiter(',') list.
CLI::Validator FiniteNumber();                      // any finite number
CLI::Validator NonNegativeNumber();                 // finite, >= 0
CLI::Validator PositiveNumber(double max = 1e300);  // finite, in (0, max]

// --NAME a,b,..: a comma list, every item a FiniteNumber(), in one argument.
CLI::Option* AddNumberList(CLI::App& app, const std::string& name, std::vector<double>& values,
                           const std::string& help);

// `values` (already validated finite) as one per joint: exactly `n`, or one
// value for every joint when `scalar_ok`; `task_axes`: n = 6 gains of a
// task-space controller, one per task axis (x, y, z, rx, ry, rz), for the message.
VectorXd JointValues(std::string_view option, const std::vector<double>& values, int n, bool scalar_ok = false,
                     bool task_axes = false);

}  // namespace lagrange::cli
