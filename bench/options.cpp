#include "bench/options.hpp"

#include <iostream>

#include "bench/harness.hpp"

namespace lagrange::bench {

namespace fs = std::filesystem;

std::string SourceConfigDir() { return std::string(LAGRANGE_SOURCE_DIR) + "/config"; }

void AddDaemonOptions(CLI::App& app, DaemonOptions& o, ConfigOption config, const std::string& config_help) {
  const fs::path sibling = fs::read_symlink("/proc/self/exe").parent_path().parent_path() / "daemon" / "lagranged";
  if (fs::exists(sibling)) o.lagranged = sibling.string();
  app.add_option("--lagranged", o.lagranged, "The daemon to run (default: ../daemon/lagranged beside this program)")
      ->check(CLI::ExistingFile);
  app.add_option(config == ConfigOption::kSceneFile ? "--config" : "--config-dir", o.config, config_help)
      ->capture_default_str();
  app.add_option("--out", o.out, "Folder for the results")->capture_default_str();
  app.add_option("--port", o.port, "Private LCM port on udpm://239.255.76.67")
      ->check(CLI::Range(1, 65535))
      ->capture_default_str();
}

void AddQuickFlag(CLI::App& app, bool& quick, const std::string& help, std::function<void()> shorten) {
  app.add_flag("--quick", quick, help);
  app.final_callback([&quick, shorten = std::move(shorten)] {
    if (quick) shorten();
  });
}

int PrepareRun(std::string_view program, const DaemonOptions& o, const std::vector<int>& ports) {
  if (!ports.empty() && o.lagranged.empty()) {
    std::cerr << program << ": no lagranged beside this program; give --lagranged\n";
    return 2;
  }
  fs::create_directories(o.out);
  for (int port : ports) {
    if (const std::string problem = PrepareLoopback(Url(port)); !problem.empty()) {
      std::cerr << program << ": " << problem << "\n";
      return 1;
    }
  }
  return 0;
}

}  // namespace lagrange::bench
