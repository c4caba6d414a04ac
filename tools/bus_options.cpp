#include "tools/bus_options.hpp"

#include <CLI/CLI.hpp>

#include "protocol/channels.hpp"
#include "protocol/signing.hpp"

namespace lagrange::cli {

void BusOptions::AddTo(CLI::App& app) {
  app.add_option("--lcm-url", lcm_url, "LCM URL (default: $LCM_DEFAULT_URL, else " + std::string(kDefaultLcmUrl) + ")");
  app.add_option("--channel-prefix", channel_prefix, "The daemon's --channel-prefix");
  app.add_option("--bus-key", bus_key_file,
                 "Sign what is sent and believe only what the key signed (the daemon's --bus-key FILE); default: $" +
                     std::string(kBusKeyEnv));
  app.add_option("--wait", wait, "Seconds to wait for the daemon")->check(CLI::PositiveNumber)->capture_default_str();
}

}  // namespace lagrange::cli
