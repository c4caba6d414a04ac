// lagrangectl plot: a PNG of a run from a CSV or an LCM log.

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <optional>
#include <sstream>

#include "controllers/factory.hpp"
#include "protocol/channels.hpp"
#include "protocol/lcm_log.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/log_csv.hpp"
#include "tools/plot_script.hpp"
#include "tools/spawn.hpp"

namespace lagrange::cli {
namespace {

namespace fs = std::filesystem;

// What to draw: the state CSV, and "" or the instance's telemetry and forces CSVs.
struct PlotInputs {
  std::string state, telemetry, forces;
  std::string status;  // the daemon's status CSV: joint names, integrator and method switches
  std::string joints;  // a simulate CSV's joint names (JointNamesPath)
  std::string task;    // its task-space frame: simulate's TaskCsvPath or log2csv's <NAME>_TASK.csv
  std::string mpc;     // an mpc controller's plans: log2csv's <NAME>_MPC.csv
  std::string base;    // a floating base: log2csv's <NAME>_BASE.csv (a simulate CSV holds its own base columns)
};

// The task-space controllers' names, comma-separated: a state row under one follows a task target, not q_des.
std::string TaskSpaceControllerNames() {
  std::string names, all = ControllerTypeNames();
  std::istringstream in(all);
  for (std::string name; std::getline(in, name, '|');) {
    const std::optional<ControllerType> type = ParseControllerType(name);
    if (type && IsTaskSpace(*type)) names += (names.empty() ? "" : ",") + name;
  }
  return names;
}

// Runs python3 -c kPlotScript CSV PNG TITLE TELEMETRY FORCES STATUS JOINTS TASK TASK_SPACE MPC BASE; returns (status,
// its stdout and stderr together).
std::pair<int, std::string> RunPlotScript(const PlotInputs& in, const std::string& png, const std::string& title) {
  int out_pipe[2];
  if (pipe2(out_pipe, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  SpawnOptions options;
  // Debian's interpreter first: python3-matplotlib is installed for it, not for others on PATH.
  options.file = access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
  options.search_path = true;
  options.stdout_fd = out_pipe[1];
  options.stderr_fd = out_pipe[1];
  const pid_t pid = Spawn({"python3", "-c", kPlotScript, in.state, png, title, in.telemetry, in.forces, in.status,
                           in.joints, in.task, TaskSpaceControllerNames(), in.mpc, in.base},
                          options);
  close(out_pipe[1]);
  if (pid < 0) {
    close(out_pipe[0]);
    throw std::runtime_error("fork failed");
  }
  std::string output;
  char buf[1024];
  for (ssize_t n; (n = read(out_pipe[0], buf, sizeof buf)) > 0;) output.append(buf, static_cast<std::size_t>(n));
  close(out_pipe[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 1, output};
}

std::string LastLine(const std::string& text) {
  std::string s = text;
  while (!s.empty() && s.back() == '\n') s.pop_back();
  const std::size_t nl = s.find_last_of('\n');
  return nl == std::string::npos ? s : s.substr(nl + 1);
}

// The script's summary, "N rows in K segments" (the last line that says so;
// matplotlib may warn before it), then "; joints: NAME, .." when it labelled
// the joints by name, "; tracking: .." for what its tracking panels measured (joints to q_des, a frame to
// its task target, or none), and "; task: .. of FRAME", "; telemetry: ..", "; base: .." and "; forces: .." for the panels
// it drew from those. The names come escaped from their CSV; a line with a
// control character is not printed.
std::string Summary(const std::string& output) {
  static const std::regex kSummary(R"(^\d+ rows in \d+ segments?$)");
  static const std::regex kExtra(
      R"(^(joints: [^\x00-\x1f\x7f]+|tracking: [^\x00-\x1f\x7f]+|task: \d+ rows of [^\x00-\x1f\x7f]+|)"
      R"(telemetry: \d+ rows|mpc: \d+ plans \(\d+ followed\), \d+ drawn|base: \d+ rows, height [-+.e0-9]+ to [-+.e0-9]+ m|)"
      R"(forces: \d+ rows of [a-z_, ]*)$)");
  std::string found, extra;
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    if (std::regex_match(line, kSummary)) {
      found = line;
      extra.clear();
    } else if (!found.empty() && std::regex_match(line, kExtra)) {
      extra += "; " + line;
    }
  }
  return found.empty() ? found : found + extra;
}

// A channel name as a regular expression that matches it alone.
std::string RegexQuote(const std::string& text) {
  std::string quoted;
  for (char c : text) {
    if (std::strchr(R"(\^$.|?*+()[]{})", c)) quoted += '\\';
    quoted += c;
  }
  return quoted;
}

// "ARM" for "ARM_STATE" (the instance's channels share it); "" for another name.
std::string InstanceBase(const std::string& state_channel) {
  const std::string suffix = kStateSuffix;
  if (state_channel.size() <= suffix.size() ||
      state_channel.compare(state_channel.size() - suffix.size(), suffix.size(), suffix) != 0) {
    return "";
  }
  return state_channel.substr(0, state_channel.size() - suffix.size());
}

class PlotCommand final : public Command {
 public:
  explicit PlotCommand(CLI::App& parent)
      : Command(parent.add_subcommand(
            "plot",
            "Plot q against q_des, torques, energy and tracking error (PNG), and the "
            "instance's end effector (a task-space controller's frame), energy residual, cost per "
            "tick, forces, an mpc controller's predicted paths and a floating base when recorded; "
            "lines break at a reset, a restart or a lost message")) {
    app_->add_option("input", input_, "A CSV (lagrangectl simulate or log2csv) or an LCM log")->required();
    app_->add_option("-o,--output", output_, "PNG to write (default: INPUT with .png)");
    app_->add_option("--channel", channel_, "For a log: the *_STATE channel to plot (default: the first one)");
  }

  int Run(std::ostream& out, std::ostream&) override {
    if (!fs::exists(input_)) throw std::runtime_error("cannot read " + input_);
    const std::string png = output_.empty() ? fs::path(input_).replace_extension(".png").string() : output_;
    PlotInputs in;
    in.state = input_;
    std::string title = fs::path(input_).filename().string();
    fs::path scratch;
    if (IsLcmLog(input_)) {
      scratch = fs::temp_directory_path() / ("lagrangectl_plot_" + std::to_string(getpid()));
      try {
        title += " : " + FromLog(scratch, in);
      } catch (...) {
        fs::remove_all(scratch);
        throw;
      }
    } else if (!channel_.empty()) {
      throw UsageError("--channel: only for an LCM log");
    } else {
      Siblings(in);
    }
    const auto [status, err] = RunPlotScript(in, png, title);
    if (!scratch.empty()) fs::remove_all(scratch);
    if (status == 127)
      throw std::runtime_error("plot needs python3 with matplotlib (scripts/setup-deps installs them)");
    if (status != 0) {
      std::string why = LastLine(err);
      if (why.rfind("plot: ", 0) == 0) why = why.substr(6);
      if (why.find("No module named") != std::string::npos) why = "plot needs python3-matplotlib: " + why;
      throw std::runtime_error(why.empty() ? "the plot script failed" : why);
    }
    const std::string summary = Summary(err);
    out << png << (summary.empty() ? "" : ": " + summary) << "\n";
    return 0;
  }

 private:
  // Decodes the log's state channel (the first *_STATE, or --channel) and
  // that instance's task state, telemetry, forces, plans and base into `scratch`; returns the state channel.
  std::string FromLog(const fs::path& scratch, PlotInputs& in) const {
    const LogToCsvResult r = LogToCsv(input_, scratch.string(), channel_.empty() ? ".*_STATE" : channel_);
    const auto state =
        std::find_if(r.written.begin(), r.written.end(), [](const auto& e) { return e.second.type == "state_t"; });
    if (state == r.written.end())
      throw std::runtime_error("no state channel" + (channel_.empty() ? "" : " '" + channel_ + "'") + " in " + input_);
    in.state = state->second.path;
    const std::string base = InstanceBase(state->first);
    if (base.empty()) return state->first;
    const LogToCsvResult extra = LogToCsv(input_, scratch.string(),
                                          RegexQuote(base) + "(" + kTaskSuffix + "|" + kTelemetrySuffix + "|" +
                                              kForcesSuffix + "|" + kMpcSuffix + "|" + kBaseSuffix + ")");
    for (const auto& [channel, csv] : extra.written) {
      if (csv.rows == 0) continue;
      if (channel == base + kTelemetrySuffix && csv.type == "telemetry_t") in.telemetry = csv.path;
      if (channel == base + kForcesSuffix && csv.type == "forces_t") in.forces = csv.path;
      if (channel == base + kTaskSuffix && csv.type == "task_state_t") in.task = csv.path;
      if (channel == base + kMpcSuffix && csv.type == "mpc_t") in.mpc = csv.path;
      if (channel == base + kBaseSuffix && csv.type == "base_state_t") in.base = csv.path;
    }
    // The status of the daemon that published it: the longest prefix of the base.
    const LogToCsvResult status = LogToCsv(input_, scratch.string(), std::string(".*") + kStatusChannel);
    std::size_t best = 0;
    for (const auto& [channel, csv] : status.written) {
      const std::string prefix = channel.substr(0, channel.size() - std::string(kStatusChannel).size());
      if (csv.rows == 0 || csv.type != "status_t" || base.rfind(prefix, 0) != 0) continue;
      if (in.status.empty() || prefix.size() > best) {
        in.status = csv.path;
        best = prefix.size();
      }
    }
    return state->first;
  }

  // For a simulate CSV: its joint names (JointNamesPath) and task CSV (TaskCsvPath), where they exist.
  // For a log2csv CSV DIR/NAME_STATE.csv: DIR/NAME_TASK.csv, DIR/NAME_TELEMETRY.csv, DIR/NAME_FORCES.csv,
  // DIR/NAME_MPC.csv and DIR/NAME_BASE.csv, where they exist.
  static void Siblings(PlotInputs& in) {
    if (const std::string joints = JointNamesPath(in.state); fs::exists(joints)) in.joints = joints;
    if (const std::string task = TaskCsvPath(in.state); fs::exists(task)) in.task = task;
    const fs::path state(in.state);
    const std::string base = InstanceBase(state.stem().string());
    if (base.empty() || state.extension() != ".csv") return;
    const fs::path telemetry = state.parent_path() / (base + kTelemetrySuffix + ".csv");
    const fs::path forces = state.parent_path() / (base + kForcesSuffix + ".csv");
    if (fs::exists(telemetry)) in.telemetry = telemetry.string();
    if (fs::exists(forces)) in.forces = forces.string();
    if (const fs::path mpc = state.parent_path() / (base + kMpcSuffix + ".csv"); fs::exists(mpc)) in.mpc = mpc.string();
    if (const fs::path b = state.parent_path() / (base + kBaseSuffix + ".csv"); fs::exists(b)) in.base = b.string();
    if (const fs::path task = state.parent_path() / (base + kTaskSuffix + ".csv"); fs::exists(task)) {
      in.task = task.string();
    }
    // DIR/PLAGRANGE_STATUS.csv for the longest prefix P of the base.
    for (std::size_t n = base.size() + 1; n-- > 0;) {
      const fs::path status = state.parent_path() / (base.substr(0, n) + kStatusChannel + ".csv");
      if (fs::exists(status)) {
        in.status = status.string();
        break;
      }
    }
  }

  static bool IsLcmLog(const std::string& path) {
    try {
      LcmLogReader{path};  // checks the sync word at its start
      return true;
    } catch (const std::exception&) {
      return false;
    }
  }

  std::string input_, output_, channel_;
};

}  // namespace

std::unique_ptr<Command> MakePlotCommand(CLI::App& parent) { return std::make_unique<PlotCommand>(parent); }

}  // namespace lagrange::cli
