#include <algorithm>
#include <vector>

#include "protocol/bus.hpp"
#include "protocol/format.hpp"
#include "protocol/signing.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {
namespace {

// "unknown command 'evl'; did you mean 'eval'?" when the first argument names
// no subcommand (empty when it does, or is an option).
std::string UnknownCommand(const CLI::App& app, int argc, const char* const* argv) {
  if (argc < 2 || argv[1][0] == '-') return "";
  const std::string word = argv[1];
  std::string best, names;
  std::size_t best_distance = 3;  // suggest only a name within two edits
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    const std::string& name = sub->get_name();
    if (name == word) return "";
    names += (names.empty() ? "" : ", ") + name;
    const std::size_t d = EditDistance(word, name);
    if (d < best_distance && d < word.size()) {
      best = name;
      best_distance = d;
    }
  }
  const std::string shown = word.size() > 40 ? word.substr(0, 40) + "..." : word;
  return "unknown command '" + shown + "'" +
         (best.empty() ? " (expected one of " + names + ")" : "; did you mean '" + best + "'?");
}

}  // namespace

int RunLagrangectl(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CLI::App app{
      "lagrangectl: evaluate and simulate plants; send, command, watch and view lagranged; turn logs into CSV and plots"};
  app.name("lagrangectl");
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("lagrangectl ") + LAGRANGE_VERSION);
  std::vector<std::unique_ptr<Command>> commands;
  commands.push_back(MakeEvalCommand(app));
  commands.push_back(MakeSimulateCommand(app));
  commands.push_back(MakeSendCommand(app));
  commands.push_back(MakeCommandCommand(app));
  commands.push_back(MakeWatchCommand(app));
  commands.push_back(MakeLog2CsvCommand(app));
  commands.push_back(MakePlotCommand(app));
  commands.push_back(MakeKeygenCommand(app));
  commands.push_back(MakeViewCommand(app));

  std::string where = "lagrangectl";
  if (const std::string unknown = UnknownCommand(app, argc, argv); !unknown.empty()) {
    err << where << ": " << unknown << "\n";
    return 2;
  }
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
  } catch (const CLI::CallForVersion& e) {
    out << e.what() << "\n";
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
  } catch (const BusUrlError& e) {  // a malformed --lcm-url or $LCM_DEFAULT_URL is a bad argument
    err << where << ": " << e.what() << "\n";
    return 2;
  } catch (const BusKeyError& e) {  // --bus-key: missing, readable by others, the wrong size; keygen: exists
    err << where << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    err << where << ": " << e.what() << "\n";
    return 1;
  }
}

}  // namespace lagrange::cli
