// lagrangectl log2csv: an lcm-logger file into one CSV per channel.

#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/log_csv.hpp"

namespace lagrange::cli {
namespace {

class Log2CsvCommand final : public Command {
 public:
  explicit Log2CsvCommand(CLI::App& parent)
      : Command(parent.add_subcommand("log2csv", "Decode an lcm-logger file into one CSV per channel")) {
    app_->add_option("log", log_, "LCM log file (from lcm-logger)")->required();
    app_->add_option("--channel", channel_, "Only channels matching this regular expression");
    app_->add_option("-o,--output", dir_, "Directory for the CSV files")->capture_default_str();
  }

  int Run(std::ostream& out, std::ostream& err) override {
    const LogToCsvResult r = LogToCsv(log_, dir_, channel_);
    for (const auto& [channel, count] : r.unknown) {
      err << "lagrangectl log2csv: skipped " << channel << ": " << count << " message" << (count == 1 ? "" : "s")
          << " of a type that is not lagrange's\n";
    }
    if (r.written.empty()) {
      throw std::runtime_error("no lagrange messages" +
                               (channel_.empty() ? "" : " on channels matching '" + channel_ + "'") + " in " + log_);
    }
    for (const auto& [channel, c] : r.written) {
      out << c.path << ": " << c.rows << (c.rows == 1 ? " row of " : " rows of ") << c.type;
      if (c.skipped) out << " (" << c.skipped << " skipped: undecodable or a different num_dofs)";
      out << "\n";
    }
    return 0;
  }

 private:
  std::string log_;
  std::string channel_;
  std::string dir_ = ".";
};

}  // namespace

std::unique_ptr<Command> MakeLog2CsvCommand(CLI::App& parent) { return std::make_unique<Log2CsvCommand>(parent); }

}  // namespace lagrange::cli
