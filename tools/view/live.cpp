#include "tools/view/live.hpp"

#include <algorithm>

#include "plant/escape.hpp"
#include "protocol/channels.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "protocol/receive.hpp"
#include "protocol/status.hpp"
#include "tools/interrupt.hpp"

namespace lagrange::cli::view {
namespace {

using nlohmann::json;

constexpr double kStale = 0.5;                  // s without a state: STALE (states come every tick)
constexpr std::size_t kMaxExtraInstances = 64;  // instances a status names that the scene lacks (shown as text)
constexpr std::size_t kMaxRunsKept = 8;         // run ids remembered per instance

// A name a status gives that may become a channel: what lagranged accepts as an instance name.
bool PlausibleInstanceName(const std::string& name) {
  return !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
  });
}

double Seconds(std::chrono::steady_clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

// ---- FrameHub ----

void FrameHub::Publish(std::string frame) {
  {
    std::lock_guard lock(mutex_);
    frame_ = std::make_shared<const std::string>(std::move(frame));
    ++seq_;
  }
  cv_.notify_all();
}

std::shared_ptr<const std::string> FrameHub::Next(std::uint64_t& seq, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, timeout, [&] { return stopped_ || seq_ != seq; });
  if (stopped_ || seq_ == seq) return nullptr;
  seq = seq_;
  return frame_;
}

void FrameHub::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopped_ = true;
  }
  cv_.notify_all();
}

bool FrameHub::stopped() {
  std::lock_guard lock(mutex_);
  return stopped_;
}

// ---- LiveView ----

LiveView::LiveView(const ViewModels& models, const std::vector<ViewInstance>& instances,
                   std::vector<std::string> prefixes, LinkOptions bus)
    : models_(models), prefixes_(std::move(prefixes)), bus_(std::move(bus)) {
  for (const ViewInstance& i : instances) {
    Tracked t;
    t.instance = i;
    tracked_.push_back(std::move(t));
  }
}

LinkOptions LiveView::Link(const std::string& prefix) const {
  LinkOptions link = bus_;
  link.channel_prefix = prefix;
  return link;
}

void LiveView::Run(double rate, FrameHub& hub) {
  auto bus = bus_.Open();  // signed when a key is given: states must verify, as watch's do
  SubscribeStatuses(*bus);
  for (std::size_t i = 0; i < tracked_.size(); ++i) SubscribeTracked(*bus, i);
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(1.0 / rate));
  auto next = SteadyClock::now();
  while (!Interrupted()) {
    next += period;
    for (auto now = SteadyClock::now(); now < next; now = SteadyClock::now()) {
      bus->Handle(static_cast<int>(
          std::max<std::int64_t>(1, std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count())));
    }
    if (SteadyClock::now() > next + 10 * period) next = SteadyClock::now();  // fell behind: skip, never catch up
    SubscribeNamedInStatus(*bus);
    hub.Publish(Dump(Frame()));
  }
}

void LiveView::SubscribeStatuses(Bus& bus) {
  for (std::size_t d = 0; d < prefixes_.size(); ++d) {
    SubscribeMessages<status_t>(bus, Link(prefixes_[d]).StatusChannel(), [this, d](status_t&& s) {
      statuses_[d] = {std::move(s), SteadyClock::now()};
    });
  }
}

void LiveView::SubscribeTracked(Bus& bus, std::size_t i) {
  const LinkOptions link = Link(tracked_[i].instance.prefix);
  const std::string& name = tracked_[i].instance.name;
  SubscribeMessages<state_t>(bus, link.Channel(name, kStateSuffix),
                             [this, i](state_t&& s) { OnState(i, std::move(s)); });
  SubscribeMessages<telemetry_t>(bus, link.Channel(name, kTelemetrySuffix),
                                 [this, i](telemetry_t&& m) { tracked_[i].telemetry = std::move(m); });
  SubscribeMessages<task_state_t>(bus, link.Channel(name, kTaskSuffix),
                                  [this, i](task_state_t&& m) { tracked_[i].task = std::move(m); });
}

// Every state, not only the frames sent: the moment an instance entered fault, estop or stopped is kept.
void LiveView::OnState(std::size_t i, state_t s) {
  Tracked& t = tracked_[i];
  const bool stopped =
      s.mode == state_t::MODE_FAULT || s.mode == state_t::MODE_ESTOP || s.mode == state_t::MODE_STOPPED;
  if (stopped && (!t.state || t.state->mode != s.mode || t.state->run_id != s.run_id))
    t.event = {{"mode", ModeName(s.mode)}, {"t", s.t}, {"tick", s.tick}, {"run", RunIdText(s.run_id)}};
  t.received = SteadyClock::now();
  t.run_heard[s.run_id] = t.received;
  if (t.run_heard.size() > kMaxRunsKept) t.run_heard.erase(t.run_heard.begin());
  t.state = std::move(s);
}

// Instances a daemon's status names that the scene has not: shown as text (no model to draw them by).
void LiveView::SubscribeNamedInStatus(Bus& bus) {
  for (const auto& [d, entry] : statuses_) {
    for (const std::string& name : entry.first.instance_names) {
      if (extra_instances_ >= kMaxExtraInstances) return;
      const bool known = std::any_of(tracked_.begin(), tracked_.end(), [&](const Tracked& t) {
        return t.instance.prefix == prefixes_[d] && t.instance.name == name;
      });
      if (known || !PlausibleInstanceName(name)) continue;
      Tracked t;
      t.instance = {prefixes_[d], name, -1};
      tracked_.push_back(std::move(t));
      ++extra_instances_;
      SubscribeTracked(bus, tracked_.size() - 1);
    }
  }
}

json LiveView::Frame() {
  const auto now = SteadyClock::now();
  json instances = json::array();
  for (const Tracked& t : tracked_) {
    if (t.state) instances.push_back(TrackedJson(t, now));
  }
  return {{"instances", instances}, {"daemons", DaemonsJson(now)}};
}

// An instance as its latest state shows it, with what else the bus said of it.
json LiveView::TrackedJson(const Tracked& t, SteadyClock::time_point now) const {
  const state_t& s = *t.state;
  const double age = Seconds(now - t.received);
  json j = InstanceJson(t.instance, models_, s, age, t.task ? &*t.task : nullptr);
  if (age > kStale) j["stale"] = true;
  if (!t.event.is_null()) j["event"] = t.event;
  const auto live_runs = std::count_if(t.run_heard.begin(), t.run_heard.end(),
                                       [&](const auto& run) { return Seconds(now - run.second) <= kStale; });
  if (live_runs > 1)
    j["warning"] = std::to_string(live_runs) + " lagranged runs publish this instance: which is which cannot be told";
  for (const auto& [d, entry] : statuses_) {
    if (prefixes_[d] == t.instance.prefix && entry.first.run_id == s.run_id)
      j["reason"] = ModeReasonIn(entry.first, t.instance.name, s.mode);
  }
  if (t.telemetry && t.telemetry->run_id == s.run_id) {
    j["eps"] = t.telemetry->energy_residual;
    j["eps_bound"] = t.telemetry->quadrature_bound;
  }
  return j;
}

json LiveView::DaemonsJson(SteadyClock::time_point now) const {
  json daemons = json::array();
  for (const auto& [d, entry] : statuses_) {
    const status_t& s = entry.first;
    daemons.push_back({{"prefix", Escape(prefixes_[d])},
                       {"run", RunIdText(s.run_id)},
                       {"ticks", s.ticks},
                       {"overruns", s.overruns},
                       {"period", s.period},
                       {"stale", Seconds(now - entry.second) > kStale}});
  }
  return daemons;
}

}  // namespace lagrange::cli::view
