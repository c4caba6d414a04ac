#pragma once
// The options and set-up every process-level benchmark shares: which
// lagranged to run, on which scenes, where the results go and on which
// private LCM port; and the checks before anything starts.

#include <CLI/CLI.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace lagrange::bench {

struct DaemonOptions {
  std::string lagranged;  // the daemon to run; "" when none was found or given
  std::string config;     // a scene file ("": the daemon's default) or the folder of the scenes (ConfigOption)
  std::string out = "bench/results";
  int port = 0;  // private LCM port on udpm://239.255.76.67

  // out/<name>
  std::filesystem::path File(const std::string& name) const { return std::filesystem::path(out) / name; }
  // config/<file>, when config is the folder of the scenes.
  std::string Scene(const std::string& file) const { return (std::filesystem::path(config) / file).string(); }
};

// What --config names: one scene (--config FILE) or the folder the benchmark's scenes are in (--config-dir DIR).
enum class ConfigOption : std::uint8_t { kSceneFile, kSceneFolder };

// config/ of the source tree these programs were built from: where the shipped scenes are.
std::string SourceConfigDir();

// --lagranged (default: ../daemon/lagranged beside this program, when
// there), --config or --config-dir (`config_help` says what it must be),
// --out and --port, into `o`.
void AddDaemonOptions(CLI::App& app, DaemonOptions& o, ConfigOption config, const std::string& config_help);

// --quick, a smoke run: once the command line has been parsed with it,
// `shorten` sets the quick values (QuickDefault) of the options it did not give.
void AddQuickFlag(CLI::App& app, bool& quick, const std::string& help, std::function<void()> shorten);

// `value` = `quick` unless the command line gave `option`.
template <class T>
void QuickDefault(const CLI::Option* option, T& value, T quick) {
  if (option->count() == 0) value = quick;
}

// Before a run starts anything: a lagranged to run (else exit status 2), the
// results folder made, and LCM multicast looping back on every port in
// `ports` (PrepareLoopback; else 1). No ports: an offline run, which needs neither daemon nor
// bus. What is wrong goes to stderr as "<program>: ..."; 0 when ready.
int PrepareRun(std::string_view program, const DaemonOptions& o, const std::vector<int>& ports);

}  // namespace lagrange::bench
