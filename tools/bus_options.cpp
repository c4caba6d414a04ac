#include "tools/bus_options.hpp"

#include <CLI/CLI.hpp>
#include <limits>
#include <optional>

#include "plant/plant_factory.hpp"
#include "protocol/channels.hpp"
#include "protocol/signing.hpp"

namespace lagrange::cli {

void BusOptions::AddTo(CLI::App& app) {
  app.add_option("--lcm-url", lcm_url, "LCM URL (default: $LCM_DEFAULT_URL, else " + std::string(kDefaultLcmUrl) + ")");
  app.add_option("--channel-prefix", channel_prefix, "The daemon's --channel-prefix");
  app.add_option("--bus-key", bus_key_file,
                 "Sign what is sent and believe only what the key signed (the daemon's --bus-key FILE); default: $" +
                     std::string(kBusKeyEnv));
  app.add_option("--bus-domain", bus_domain,
                 "The domain signatures are bound to (the daemon's --bus-domain); default: $" +
                     std::string(kBusDomainEnv) + ", else the bus's own (udpm://GROUP:PORT of the URL)");
  // The client's one rule for a wait (protocol/client.hpp, CheckWait), as Python's Client refuses it too.
  app.add_option("--wait", wait, "Seconds to wait for the daemon (at most a day)")
      ->check(CLI::Validator(
          [](std::string& text) {
            // A number is shown as Python's Client shows it (1e9: 1e+09); anything else as typed.
            const std::optional<double> v = ParseFiniteNumber(text);
            return v ? CheckWait(*v) : CheckWait(std::numeric_limits<double>::quiet_NaN(), text);
          },
          "SECONDS"))
      ->capture_default_str();
}

}  // namespace lagrange::cli
