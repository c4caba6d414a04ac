// lagrangectl keygen: a new shared secret for signed bus traffic (protocol/signing.hpp).

#include <CLI/CLI.hpp>

#include "protocol/signing.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {
namespace {

class KeygenCommand final : public Command {
 public:
  explicit KeygenCommand(CLI::App& parent)
      : Command(parent.add_subcommand(
            "keygen",
            "Write a new bus key (32 random bytes from libsodium, mode 0600) for --bus-key; never overwrites")) {
    app_->add_option("file", file_, "Where to write the key")->required();
  }

  int Run(std::ostream& out, std::ostream&) override {
    WriteNewBusKey(file_);  // BusKeyError: one line naming the file
    out << "wrote a " << kBusKeyMinBytes << "-byte bus key to " << file_
        << " (mode 0600); give the same file to lagranged and every client (--bus-key or " << kBusKeyEnv << ")\n";
    return 0;
  }

 private:
  std::string file_;
};

}  // namespace

std::unique_ptr<Command> MakeKeygenCommand(CLI::App& parent) { return std::make_unique<KeygenCommand>(parent); }

}  // namespace lagrange::cli
