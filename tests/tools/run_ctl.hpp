#pragma once
// Runs lagrangectl in-process with arguments, capturing its output.

#include <sstream>
#include <string>
#include <vector>

#include "tools/commands.hpp"

namespace lagrange::testing {

struct CtlResult {
  int status = -1;
  std::string out;
  std::string err;
};

inline CtlResult RunCtl(std::vector<std::string> args) {
  args.insert(args.begin(), "lagrangectl");
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  std::ostringstream out, err;
  const int status = cli::RunLagrangectl(static_cast<int>(argv.size()), argv.data(), out, err);
  return {status, out.str(), err.str()};
}

}  // namespace lagrange::testing
