#pragma once
// lagrangectl's options for reaching a daemon (--lcm-url, --channel-prefix,
// --bus-key, --bus-domain, --wait): the client's LinkOptions (protocol/client.hpp) as CLI11 flags. A
// malformed URL surfaces as a BusUrlError, which lagrangectl reports as a bad
// argument (exit 2).

#include "protocol/client.hpp"

namespace CLI {
class App;  // CLI/CLI.hpp in the .cpp (see tools/commands.hpp)
}  // namespace CLI

namespace lagrange::cli {

struct BusOptions : LinkOptions {
  void AddTo(CLI::App& app);
};

}  // namespace lagrange::cli
