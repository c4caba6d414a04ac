#include "protocol/client.hpp"

#include <algorithm>

#include "plant/escape.hpp"
#include "protocol/channels.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/wire.hpp"

namespace lagrange {
namespace {

// Distinct run ids remembered per channel: enough to name two in an error,
// bounded so a spoofer cycling ids costs nothing.
constexpr std::size_t kMaxRuns = 4;

}  // namespace

std::string LinkOptions::Url() const { return ResolveLcmUrl(lcm_url); }

std::string LinkOptions::Channel(const std::string& instance, const char* suffix) const {
  return InstanceChannel(channel_prefix, instance, suffix);
}

std::string LinkOptions::StatusChannel() const { return channel_prefix + kStatusChannel; }

std::unique_ptr<Bus> LinkOptions::Open() const {
  const std::string url = Url();
  // ParseUdpmUrl first: it names what is wrong with any URL that is not a
  // udpm:// one (OpenBus only says which providers it speaks).
  if (url.rfind("inprocess://", 0) != 0) ParseUdpmUrl(url);
  const std::string key_file = ResolveBusKeyFile(bus_key_file);
  if (key_file.empty()) return OpenBus(url);  // BusError when the socket cannot be set up
  const BusKey key = BusKey::FromFile(key_file);
  return OpenBus(url, &key);
}

DaemonLink::DaemonLink(const LinkOptions& options, const std::string& instance)
    : options_(options),
      instance_(instance),
      state_channel_(options.Channel(instance, kStateSuffix)),
      bus_(options.Open()) {
  bus_->Subscribe(state_channel_, [this](std::string_view, const std::uint8_t* d, std::size_t n) { OnState(d, n); });
  bus_->Subscribe(options.Channel(instance, kReplySuffix),
                  [this](std::string_view, const std::uint8_t* d, std::size_t n) { OnReply(d, n); });
  bus_->Subscribe(options.StatusChannel(),
                  [this](std::string_view, const std::uint8_t* d, std::size_t n) { OnStatus(d, n); });
}

void DaemonLink::OnState(const std::uint8_t* data, std::size_t size) {
  if (CheckStatePacket(data, size) != WireCheck::kOk) {
    // A signed daemon's state, seen without the key: worth a hint if nothing else comes.
    if (!bus_->signs() && MessageSizeBeforeTrailer(data, size) != size) signed_states_seen_ = true;
    return;
  }
  state_t msg;
  if (msg.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) return;
  auto it = runs_.find(msg.run_id);
  if (it == runs_.end()) {
    if (runs_.size() >= kMaxRuns) return;
    it = runs_.emplace(msg.run_id, Seen{}).first;
  }
  it->second.state = std::move(msg);
  it->second.received = std::chrono::steady_clock::now();
  ++it->second.count;
}

void DaemonLink::OnStatus(const std::uint8_t* data, std::size_t size) {
  if (!have_run_ || CheckStatusPacket(data, size) != WireCheck::kOk) return;
  status_t msg;
  if (msg.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size) || msg.run_id != run_id_) return;
  status_ = std::move(msg);
  ++statuses_received_;
}

void DaemonLink::OnReply(const std::uint8_t* data, std::size_t size) {
  if (!have_run_ || request_id_ == 0 || CheckReplyPacket(data, size) != WireCheck::kOk) return;
  reply_t msg;
  if (msg.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) return;
  // Only the run we saw, answering our own request: anything else proves nothing.
  if (msg.run_id != run_id_ || msg.request_id != request_id_ || reply_) return;
  reply_ = std::move(msg);
}

std::string DaemonLink::TwoRunsMessage(const std::string& doing) const {
  std::string ids;
  std::size_t k = 0;
  for (const auto& [id, seen] : runs_) {
    ids += (k == 0 ? "" : k + 1 == runs_.size() ? " and " : ", ") + RunIdText(id);
    ++k;
  }
  const std::string count = runs_.size() == 2 ? "two" : runs_.size() == 3 ? "three" : "several";
  return count + " lagranged runs publish " + state_channel_ + " (ids " + ids + "): " + doing;
}

std::int64_t DaemonLink::AwaitOneRun() {
  if (!PumpUntil([&] { return !runs_.empty(); }, options_.wait)) {
    if (signed_states_seen_) {
      throw std::runtime_error("no state from instance '" + instance_ + "' on " + state_channel_ + " within " +
                               FormatDouble(options_.wait) + " s that this unsigned client can read: its states " +
                               "are signed; give the daemon's key (--bus-key FILE or " + kBusKeyEnv + ")");
    }
    throw std::runtime_error("no state from instance '" + instance_ + "' on " + state_channel_ + " within " +
                             FormatDouble(options_.wait) + " s (unknown instance, or no lagranged on " +
                             options_.Url() + "?)");
  }
  Pump(kRunWindow);
  RequireOneRun("refusing to act");
  run_id_ = runs_.begin()->first;
  have_run_ = true;
  return run_id_;
}

void DaemonLink::RequireOneRun(const std::string& doing) const {
  if (runs_.size() > 1) throw std::runtime_error(TwoRunsMessage(doing));
}

const state_t& DaemonLink::state() const { return runs_.at(run_id_).state; }

std::int64_t DaemonLink::states_received() const { return runs_.at(run_id_).count; }

std::chrono::steady_clock::time_point DaemonLink::state_received_at() const { return runs_.at(run_id_).received; }

const status_t& DaemonLink::AwaitStatus() {
  if (!PumpUntil([&] { return status_.has_value(); }, options_.wait)) {
    throw std::runtime_error("no " + options_.StatusChannel() + " from lagranged (run " + RunIdText(run_id_) +
                             ") within " + FormatDouble(options_.wait) + " s");
  }
  return *status_;
}

void DaemonLink::Pump(double seconds) {
  PumpUntil([] { return false; }, seconds);
}

}  // namespace lagrange
