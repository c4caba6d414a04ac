// lagrangectl plot: a PNG of a run from a CSV or an LCM log.

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "daemon/spawn.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/lcm_log.hpp"
#include "tools/plot_script.hpp"

namespace lagrange::cli {
namespace {

namespace fs = std::filesystem;

// Runs python3 -c kPlotScript CSV PNG TITLE; returns (status, its stdout and stderr together).
std::pair<int, std::string> RunPlotScript(const std::string& csv, const std::string& png, const std::string& title) {
  int out_pipe[2];
  if (pipe2(out_pipe, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  SpawnOptions options;
  // Debian's interpreter first: python3-matplotlib is installed for it, not for others on PATH.
  options.file = access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
  options.search_path = true;
  options.stdout_fd = out_pipe[1];
  options.stderr_fd = out_pipe[1];
  const pid_t pid = Spawn({"python3", "-c", kPlotScript, csv, png, title}, options);
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
// matplotlib may warn before it).
std::string Summary(const std::string& output) {
  static const std::regex kSummary(R"(^\d+ rows in \d+ segments?$)");
  std::string found;
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    if (std::regex_match(line, kSummary)) found = line;
  }
  return found;
}

class PlotCommand final : public Command {
 public:
  explicit PlotCommand(CLI::App& parent)
      : Command(parent.add_subcommand("plot",
                                      "Plot q against q_des, torques, energy and tracking error (PNG); "
                                      "lines break at a reset, a restart or a lost message")) {
    app_->add_option("input", input_, "A CSV (lagrangectl simulate or log2csv) or an LCM log")->required();
    app_->add_option("-o,--output", output_, "PNG to write (default: INPUT with .png)");
    app_->add_option("--channel", channel_, "For a log: the *_STATE channel to plot (default: the first one)");
  }

  int Run(std::ostream& out, std::ostream&) override {
    if (!fs::exists(input_)) throw std::runtime_error("cannot read " + input_);
    const std::string png = output_.empty() ? fs::path(input_).replace_extension(".png").string() : output_;
    std::string csv = input_;
    std::string title = fs::path(input_).filename().string();
    fs::path scratch;
    if (IsLcmLog(input_)) {
      scratch = fs::temp_directory_path() / ("lagrangectl_plot_" + std::to_string(getpid()));
      const LogToCsvResult r = LogToCsv(input_, scratch.string(), channel_.empty() ? ".*_STATE" : channel_);
      const auto it =
          std::find_if(r.written.begin(), r.written.end(), [](const auto& e) { return e.second.type == "state_t"; });
      if (it == r.written.end()) {
        fs::remove_all(scratch);
        throw std::runtime_error("no state channel" + (channel_.empty() ? "" : " '" + channel_ + "'") + " in " +
                                 input_);
      }
      csv = it->second.path;
      title += " : " + it->first;
    } else if (!channel_.empty()) {
      throw UsageError("--channel: only for an LCM log");
    }
    const auto [status, err] = RunPlotScript(csv, png, title);
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
  static bool IsLcmLog(const std::string& path) {
    try {
      RequireLcmLog(path);
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
