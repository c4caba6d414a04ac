#include "protocol/client.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>

#include "base/escape.hpp"
#include "protocol/channels.hpp"
#include "protocol/clock.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "protocol/receive.hpp"

namespace lagrange {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string Lower(std::string s) {
  for (char& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return s;
}

std::string List(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& n : names) text += (text.empty() ? "" : ", ") + Escape(n, 64);
  return text;
}

}  // namespace

std::string HeardHint(const std::string& prefix, const std::string& instance, const std::set<std::string>& channels) {
  // Status channels name the prefixes in use; state channels, the instances.
  std::set<std::string> prefixes;
  std::vector<std::string> states;
  for (const std::string& c : channels) {
    if (EndsWith(c, kStatusChannel)) prefixes.insert(c.substr(0, c.size() - std::string(kStatusChannel).size()));
    if (EndsWith(c, kStateSuffix)) states.push_back(c);
  }
  auto use_prefix = [](const std::string& p) {
    return p.empty() ? std::string(": without --channel-prefix?") : ": --channel-prefix " + Escape(p, 64) + "?";
  };
  if (instance.empty()) {  // waiting for the status: a daemon under another prefix
    for (const std::string& p : prefixes)
      if (p != prefix) return "a lagranged publishes " + Escape(p + kStatusChannel, 64) + use_prefix(p);
  }
  if (states.empty()) {
    return prefixes.empty() ? "heard no lagranged there (is one running, on this LCM URL?)"
                            : "heard a status but no state channel (" + List({channels.begin(), channels.end()}) + ")";
  }
  if (instance.empty()) return "state channels heard: " + List(states);
  const std::string bare = InstanceChannel("", instance, kStateSuffix);
  if (channels.contains(prefix + bare))
    return "heard " + Escape(prefix + bare, 64) + ", but no valid state_t on it (not a lagranged?)";
  // The instance under another prefix (one a status confirms, when any came).
  std::string elsewhere;
  for (const std::string& c : states) {
    if (!EndsWith(c, bare) || c == prefix + bare) continue;
    const std::string other = c.substr(0, c.size() - bare.size());
    if (!prefixes.empty() && !prefixes.contains(other)) continue;
    elsewhere = "a lagranged publishes " + Escape(c, 64) + use_prefix(other);
    break;
  }
  // A lagranged runs under this very prefix: the name is what is wrong there
  // (--channel-prefix CTRL_ and instance arm, where arm_controller runs),
  // whatever another daemon publishes without it.
  const bool prefix_in_use = !prefix.empty() && prefixes.contains(prefix);
  if (!elsewhere.empty() && !prefix_in_use) return elsewhere;
  // Another instance under this prefix: the nearest name.
  std::string best;
  std::size_t best_distance = std::string::npos;
  for (const std::string& c : states) {
    if (c.rfind(prefix, 0) != 0) continue;
    const std::string name = Lower(c.substr(prefix.size(), c.size() - prefix.size() - std::string(kStateSuffix).size()));
    const std::size_t d = EditDistance(Lower(instance), name);
    if (d < best_distance) {
      best = name;
      best_distance = d;
    }
  }
  const std::string heard = "state channels heard: " + List(states);
  if (!best.empty()) {
    return heard + "; did you mean '" + Escape(best, 64) + "'?" + (elsewhere.empty() ? "" : " (or " + elsewhere + ")");
  }
  if (!elsewhere.empty()) return elsewhere;
  std::string shown;
  for (const std::string& p : prefixes) shown += (shown.empty() ? "" : ", ") + (p.empty() ? "none" : Escape(p, 64));
  return heard + (prefixes.empty() ? "" : " (channel prefixes: " + shown + ")");
}

std::string SigningHint(const SigningHeard& heard) {
  const std::string give_key = std::string("give the daemon's key (--bus-key FILE or ") + kBusKeyEnv + ")";
  const auto messages = [](std::int64_t n, const char* what) {
    return "heard " + std::to_string(n) + " " + what + (n == 1 ? " message" : " messages");
  };
  std::string hint;
  const auto add = [&](std::int64_t n, const std::string& clause) {
    if (n > 0) hint += (hint.empty() ? "" : "; ") + clause;
  };
  const std::string domain = heard.domain.empty() ? "" : "this client's is " + Escape(heard.domain, 80) + "; ";
  add(heard.other_key, "heard " + std::to_string(heard.other_key) + (heard.other_key == 1 ? " message" : " messages") +
                           " signed with another key or for another bus domain (" + domain +
                           "their tags do not verify with this client's): " + give_key +
                           ", and its --bus-domain if it has one (or " + kBusDomainEnv + ")");
  add(heard.old_format, messages(heard.old_format, "signed") +
                            " in lagrange's old format (LGS1, before bus domains), refused: update that lagranged");
  add(heard.unsigned_refused, messages(heard.unsigned_refused, "unsigned") +
                                  ", which a client with a key refuses: the daemon runs without one (give it "
                                  "--bus-key FILE too, or run this client without a key)");
  add(heard.out_of_window, messages(heard.out_of_window, "signed") +
                               " stamped more than 2 s from this host's clock, or replayed: keep the hosts' clocks "
                               "in step (chrony or NTP)");
  add(heard.signed_unreadable, messages(heard.signed_unreadable, "signed") +
                                   ", which a client without a key cannot check: its states are signed; " + give_key);
  return hint;
}

std::string WhatWasHeard(const SigningHeard& signing, const std::string& prefix, const std::string& instance,
                         const std::set<std::string>& channels) {
  if (std::string hint = SigningHint(signing); !hint.empty()) return hint;
  return HeardHint(prefix, instance, channels);
}

SigningCensus::SigningCensus(Bus& bus) : bus_(bus), at_start_(bus.stats()) {
  if (bus_.signs()) return;  // the bus itself counts what it refuses, by reason
  bus_.Subscribe(kEveryChannel, [this](std::string_view, const std::uint8_t* data, std::size_t size) {
    if (MessageSizeBeforeTrailer(data, size) != size) ++signed_unreadable_;
  });
}

SigningHeard SigningCensus::heard() const {
  const BusStats now = bus_.stats();
  return {.other_key = now.bad_tags - at_start_.bad_tags,
          .unsigned_refused = now.unsigned_dropped - at_start_.unsigned_dropped,
          .out_of_window = (now.stale - at_start_.stale) + (now.replayed - at_start_.replayed),
          .signed_unreadable = signed_unreadable_,
          .old_format = now.old_format - at_start_.old_format,
          .domain = bus_.domain()};
}

std::string LinkOptions::Url() const { return ResolveLcmUrl(lcm_url); }

std::string LinkOptions::Channel(const std::string& instance, const char* suffix) const {
  return InstanceChannel(channel_prefix, instance, suffix);
}

std::string LinkOptions::StatusChannel() const { return channel_prefix + kStatusChannel; }

std::unique_ptr<Bus> LinkOptions::Open() const {
  const std::string url = Url();
  // ParseUdpmUrl first: it names what is wrong with any URL that is not a
  // udpm:// one (OpenBus only says which providers it speaks).
  if (url != kInProcessUrl) ParseUdpmUrl(url);
  const std::string key_file = ResolveBusKeyFile(bus_key_file);
  const std::string domain = ResolveBusDomain(bus_domain);  // refused even when unsigned: a mistake either way
  if (key_file.empty()) return OpenBus(url);  // BusError when the socket cannot be set up
  const BusKey key = BusKey::FromFile(key_file);
  return OpenBus(url, &key, domain);
}

DaemonLink::DaemonLink(const LinkOptions& options, const std::string& instance)
    : options_(options),
      instance_(instance),
      state_channel_(options.Channel(instance, kStateSuffix)),
      bus_(options.Open()),
      signing_(*bus_),
      observer_(*bus_, options.channel_prefix,
                ObserverLimits{.runs = kMaxLinkRuns, .instances = 1, .discover = false, .telemetry = false},
                BusObserver::Hooks{.on_state = [this](const std::string&, const state_t& s) { OnState(s); }}) {
  if (const std::string why = CheckWait(options.wait); !why.empty()) throw std::invalid_argument("wait: " + why);
  observer_.Follow(instance);
  seen_ = observer_.Find(instance);
  SubscribeMessages<reply_t>(*bus_, options.Channel(instance, kReplySuffix),
                             [this](reply_t&& r) { OnReply(std::move(r)); });
  bus_->Subscribe(kEveryChannel, [this](std::string_view channel, const std::uint8_t*, std::size_t) { OnAny(channel); });
}

void DaemonLink::OnAny(std::string_view channel) {
  if (!states().empty() || heard_.size() >= kMaxHeardChannels) return;  // only while no state came, bounded
  heard_.emplace(channel);
}

void DaemonLink::OnState(const state_t& s) {
  if (state_observer_ && have_run_ && s.run_id == run_id_) state_observer_(s, std::chrono::steady_clock::now());
  if (s.run_id == estop_watch_run_ && !estop_left_ && !KeepsEstop(s.mode)) estop_left_ = s;
}

void DaemonLink::OnReply(reply_t&& msg) {
  if (!have_run_ || request_id_ == 0) return;
  // Only a run we saw (the chosen one, or any after AwaitRuns), answering our
  // own request, and only its first answer: anything else proves nothing.
  if (msg.request_id != request_id_ || (!every_run_ && msg.run_id != run_id_)) return;
  if (states().Find(msg.run_id) == nullptr) return;
  std::erase_if(replies_, [&](const auto& r) { return states().Find(r.first) == nullptr; });  // runs forgotten since
  std::optional<reply_t>& reply = replies_[msg.run_id];
  if (!reply) reply = std::move(msg);
}

void DaemonLink::ExpectReply(std::int64_t request_id) {
  request_id_ = request_id;
  replies_.clear();
}

const std::optional<reply_t>& DaemonLink::reply(std::int64_t run) const {
  static const std::optional<reply_t> kNone;
  const auto it = replies_.find(run);
  return it == replies_.end() ? kNone : it->second;
}

std::vector<std::int64_t> DaemonLink::runs() const {
  std::vector<std::int64_t> ids;
  for (const auto& [id, seen] : states().entries()) ids.push_back(id);
  return ids;
}

const LatestByRun<state_t>::Entry& DaemonLink::Kept(std::int64_t run) const {
  const auto* kept = states().Find(run);
  if (kept == nullptr) throw std::out_of_range("no state kept of run " + RunIdText(run));
  return *kept;
}

std::string DaemonLink::TwoRunsMessage(const std::string& doing) const {
  std::string ids;
  std::size_t k = 0;
  const std::vector<std::int64_t> seen = runs();
  for (const std::int64_t id : seen) {
    ids += (k == 0 ? "" : k + 1 == seen.size() ? " and " : ", ") + RunIdText(id);
    ++k;
  }
  const std::string count = seen.size() == 2 ? "two" : seen.size() == 3 ? "three" : "several";
  return count + " lagranged runs publish " + state_channel_ + " (ids " + ids + "): " + doing;
}

std::int64_t DaemonLink::AwaitOneRun() {
  AwaitFirstState();
  RequireOneRun("refusing to act");
  Choose(runs());
  return run_id_;
}

std::vector<std::int64_t> DaemonLink::AwaitRuns() {
  AwaitFirstState();
  const std::vector<std::int64_t> all = runs();
  Choose(all);
  every_run_ = true;
  return all;
}

void DaemonLink::Choose(const std::vector<std::int64_t>& runs) {
  for (const std::int64_t run : runs) observer_.Pin(run);  // at most kMaxLinkRuns: all kept now
  run_id_ = runs.front();
  have_run_ = true;
  const auto* status = observer_.statuses().Find(run_id_);
  const auto* task = seen_->tasks.Find(run_id_);
  statuses_before_ = status == nullptr ? 0 : status->count;
  task_states_before_ = task == nullptr ? 0 : task->count;
}

void DaemonLink::AwaitFirstState() {
  const auto start = std::chrono::steady_clock::now();
  // A daemon is heard (a status, under any prefix) but not this instance's state: it is not coming.
  const auto daemon_without_it = [&] {
    return std::chrono::steady_clock::now() - start >= std::chrono::duration<double>(kNoStateGrace) &&
           std::any_of(heard_.begin(), heard_.end(), [](const std::string& c) { return EndsWith(c, kStatusChannel); });
  };
  PumpUntil([&] { return !states().empty() || daemon_without_it(); }, options_.wait);
  if (states().empty()) {
    // Said as soon as a daemon is heard without it, else when --wait ends.
    const bool early = daemon_without_it();
    const std::string missing = "no state from instance '" + instance_ + "' on " + state_channel_ +
                                (early ? "" : " within " + FormatDouble(options_.wait) + " s");
    throw std::runtime_error(missing + " on " + options_.Url() +
                             (early ? ", though a lagranged is publishing there" : "") + "; " +
                             WhatWasHeard(signing_.heard(), options_.channel_prefix, instance_, heard_));
  }
  Pump(kRunWindow);
}

void DaemonLink::RequireOneRun(const std::string& doing) const {
  if (states().entries().size() > 1) throw std::runtime_error(TwoRunsMessage(doing));
}

const state_t& DaemonLink::state() const { return state(run_id_); }

std::int64_t DaemonLink::states_received() const { return Kept(run_id_).count; }

std::chrono::steady_clock::time_point DaemonLink::state_received_at() const { return state_received_at(run_id_); }

std::int64_t DaemonLink::statuses_received() const {
  const auto* status = have_run_ ? observer_.statuses().Find(run_id_) : nullptr;
  return status == nullptr ? 0 : status->count - statuses_before_;
}

const status_t* DaemonLink::status() const {
  return statuses_received() > 0 ? &observer_.statuses().Find(run_id_)->message : nullptr;
}

std::int64_t DaemonLink::task_states_received() const {
  const auto* task = have_run_ ? seen_->tasks.Find(run_id_) : nullptr;
  return task == nullptr ? 0 : task->count - task_states_before_;
}

const task_state_t* DaemonLink::task_state() const {
  return task_states_received() > 0 ? &seen_->tasks.Find(run_id_)->message : nullptr;
}

const base_state_t* DaemonLink::base_state() const {
  const auto* base = have_run_ ? seen_->bases.Find(run_id_) : nullptr;
  return base == nullptr ? nullptr : &base->message;
}

const status_t& DaemonLink::AwaitStatus() {
  if (!PumpUntil([&] { return status() != nullptr; }, options_.wait)) {
    throw std::runtime_error("no " + options_.StatusChannel() + " from lagranged (run " + RunIdText(run_id_) +
                             ") within " + FormatDouble(options_.wait) + " s");
  }
  return *status();
}

void DaemonLink::SendCommand(command_t& c) {
  const std::string channel = options_.Channel(instance_, kCommandSuffix);
  c.utime = MonotonicClock().WallMicros();
  if (!bus_->PublishMessage(channel, c)) throw std::runtime_error("could not send the command on " + channel);
}

reply_t DaemonLink::Command(command_t& c) {
  c.request_id = NewRequestId();
  ExpectReply(c.request_id);
  SendCommand(c);
  if (!PumpUntil([&] { return reply().has_value(); }, options_.wait)) {
    throw std::runtime_error("no verdict from lagranged (run " + RunIdText(run_id_) + ") within " +
                             FormatDouble(options_.wait) + " s");
  }
  RequireOneRun("refusing to trust the verdict");
  return *reply();
}

std::map<std::int64_t, std::optional<reply_t>> DaemonLink::Estop(command_t& c) {
  c.request_id = NewRequestId();
  ExpectReply(c.request_id);
  SendCommand(c);
  auto next_send = std::chrono::steady_clock::now() + kEstopResend;
  const auto all_answered = [&] {
    for (const std::int64_t id : runs())
      if (!reply(id)) return false;
    return true;
  };
  PumpUntil(
      [&] {
        if (std::chrono::steady_clock::now() >= next_send) {
          SendCommand(c);
          next_send += kEstopResend;
        }
        return all_answered();
      },
      options_.wait);
  std::map<std::int64_t, std::optional<reply_t>> verdicts;
  for (const std::int64_t id : runs()) verdicts[id] = reply(id);
  return verdicts;
}

std::string DaemonLink::ModeAfterReply(std::int64_t run) {
  const auto replied = std::chrono::steady_clock::now();
  PumpUntil([&] { return state_received_at(run) > replied; }, 0.5);
  const state_t& s = state(run);
  return std::string(ModeName(s.mode)) + " with " + Escape(s.controller);
}

bool KeepsEstop(std::int8_t mode) {
  return mode == state_t::MODE_ESTOP || mode == state_t::MODE_STOPPED || mode == state_t::MODE_WAITING ||
         mode == state_t::MODE_FAULT;
}

std::string DaemonLink::EstopDidNotStay(std::int64_t run) {
  if (states().Find(run) == nullptr) return "";
  const state_t applied = state(run);  // the latest state when the verdict came
  estop_watch_run_ = run;
  estop_left_.reset();
  Pump(kEstopWatch);
  estop_watch_run_ = 0;
  if (!estop_left_) return "";
  const double after = static_cast<double>(estop_left_->utime - applied.utime) * 1e-6;
  return "the estop did not stay: " + std::string(ModeName(estop_left_->mode)) + " with " +
         Escape(estop_left_->controller) + " " + FormatDouble(std::round(std::max(after, 0.0) * 1e3) / 1e3) +
         " s after it was applied (a clear_estop from another sender? an estop lasts the scene's estop_dwell on a "
         "lagranged that has it)";
}

void DaemonLink::Pump(double seconds) {
  PumpUntil([] { return false; }, seconds);
}

std::string CheckWait(double seconds, std::string_view shown) {
  if (seconds > 0.0 && seconds <= kMaxWaitSeconds) return "";  // false for nan
  return "expected a positive number of seconds up to " + FormatDouble(kMaxWaitSeconds) + " (a day), got " +
         (shown.empty() ? FormatDouble(seconds) : std::string(shown));
}

}  // namespace lagrange
