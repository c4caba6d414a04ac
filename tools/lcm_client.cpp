#include "tools/lcm_client.hpp"

#include <cctype>

#include "daemon/channels.hpp"
#include "lcmtypes/subscribe.hpp"
#include "tools/cli_support.hpp"

namespace lagrange::cli {

void BusOptions::AddTo(CLI::App& app) {
  app.add_option("--lcm-url", lcm_url, "LCM URL (default: $LCM_DEFAULT_URL, else " + std::string(kDefaultLcmUrl) + ")");
  app.add_option("--channel-prefix", channel_prefix, "The daemon's --channel-prefix");
  app.add_option("--wait", wait, "Seconds to wait for the daemon")->check(CLI::PositiveNumber)->capture_default_str();
}

std::string BusOptions::Url() const { return ResolveLcmUrl(lcm_url); }

std::string BusOptions::Channel(const std::string& instance, const char* suffix) const {
  std::string upper = instance;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return channel_prefix + upper + suffix;
}

std::string BusOptions::StatusChannel() const { return channel_prefix + "LAGRANGE_STATUS"; }

DaemonLink::DaemonLink(const BusOptions& bus, const std::string& instance)
    : bus_(bus), instance_(instance), lcm_(bus.Url()) {
  if (!lcm_.good()) throw std::runtime_error("cannot open LCM at " + bus.Url());
  if (!instance.empty()) Subscribe<&DaemonLink::OnState>(lcm_, bus.Channel(instance, "_STATE"), this);
  Subscribe<&DaemonLink::OnStatus>(lcm_, bus.StatusChannel(), this);
}

void DaemonLink::OnState(const lcm::ReceiveBuffer* rbuf, const std::string&) {
  state_t msg;
  if (msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
  state_ = std::move(msg);
  ++states_received_;
}

void DaemonLink::OnStatus(const lcm::ReceiveBuffer* rbuf, const std::string&) {
  status_t msg;
  if (msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
  status_ = std::move(msg);
  ++statuses_received_;
}

void DaemonLink::Pump(double seconds) {
  PumpUntil([] { return false; }, seconds);
}

const state_t& DaemonLink::AwaitState() {
  if (!PumpUntil([&] { return state_.has_value(); }, bus_.wait)) {
    throw std::runtime_error("no state from instance '" + instance_ + "' on " + bus_.Channel(instance_, "_STATE") +
                             " within " + FormatDouble(bus_.wait) + " s (unknown instance, or no lagranged on " +
                             bus_.Url() + "?)");
  }
  return *state_;
}

const status_t& DaemonLink::AwaitStatus() {
  if (!PumpUntil([&] { return status_.has_value(); }, bus_.wait)) {
    throw std::runtime_error("no " + bus_.StatusChannel() + " within " + FormatDouble(bus_.wait) +
                             " s (no lagranged on " + bus_.Url() + "?)");
  }
  return *status_;
}

std::int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace lagrange::cli
