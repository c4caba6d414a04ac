#pragma once
// lagrangectl's commands. Each registers its options as a CLI11 subcommand and
// runs after parsing; RunLagrangectl is main() without the process, so tests
// drive it in-process.

#include <memory>
#include <ostream>

// CLI11 is header-only and costly to compile (its validators are built in every file that
// includes it): this header names CLI::App only by reference, so the files that merely run
// lagrangectl (main.cpp, the tests) never include it.
namespace CLI {
class App;
}  // namespace CLI

namespace lagrange::cli {

class Command {
 public:
  virtual ~Command() = default;
  CLI::App* app() const { return app_; }
  // Runs the command after parsing. Throws UsageError for bad arguments.
  virtual int Run(std::ostream& out, std::ostream& err) = 0;

 protected:
  explicit Command(CLI::App* app) : app_(app) {}
  CLI::App* app_;
};

std::unique_ptr<Command> MakeEvalCommand(CLI::App& parent);
std::unique_ptr<Command> MakeSimulateCommand(CLI::App& parent);
std::unique_ptr<Command> MakeSendCommand(CLI::App& parent);
std::unique_ptr<Command> MakeCommandCommand(CLI::App& parent);
std::unique_ptr<Command> MakeWatchCommand(CLI::App& parent);
std::unique_ptr<Command> MakeLog2CsvCommand(CLI::App& parent);
std::unique_ptr<Command> MakePlotCommand(CLI::App& parent);
std::unique_ptr<Command> MakeKeygenCommand(CLI::App& parent);
std::unique_ptr<Command> MakeViewCommand(CLI::App& parent);

// Exit status: 0 success, 2 bad argument, 1 any other failure; an error is
// one line on `err`: "lagrangectl <command>: <what is wrong>".
int RunLagrangectl(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace lagrange::cli
