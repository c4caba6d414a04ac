#include <vector>

#include "tools/cli_support.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {

int RunLagrangectl(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CLI::App app{"lagrangectl: evaluate and simulate plants; send, command and watch lagranged; turn logs into CSV and plots"};
  app.name("lagrangectl");
  app.require_subcommand(1);
  std::vector<std::unique_ptr<Command>> commands;
  commands.push_back(MakeEvalCommand(app));
  commands.push_back(MakeSimulateCommand(app));
  commands.push_back(MakeSendCommand(app));
  commands.push_back(MakeCommandCommand(app));
  commands.push_back(MakeWatchCommand(app));
  commands.push_back(MakeLog2CsvCommand(app));
  commands.push_back(MakePlotCommand(app));

  std::string where = "lagrangectl";
  try {
    app.parse(argc, argv);
    for (const auto& command : commands) {
      if (!command->app()->parsed()) continue;
      where += " " + command->app()->get_name();
      return command->Run(out, err);
    }
    return 2;
  } catch (const CLI::CallForHelp&) {
    out << app.help();
    return 0;
  } catch (const CLI::ParseError& e) {
    for (const auto& command : commands) {
      if (command->app()->parsed()) where += " " + command->app()->get_name();
    }
    err << where << ": " << e.what() << "\n";
    return 2;
  } catch (const UsageError& e) {
    err << where << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    err << where << ": " << e.what() << "\n";
    return 1;
  }
}

}  // namespace lagrange::cli
