#include "tools/view/live.hpp"

#include <algorithm>

#include "base/escape.hpp"
#include "protocol/channels.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "protocol/status.hpp"
#include "tools/interrupt.hpp"

namespace lagrange::cli::view {
namespace {

using nlohmann::json;

constexpr double kStale = 0.5;                  // s without a state: STALE (states come every tick)
constexpr std::size_t kMaxExtraInstances = 64;  // per daemon, instances a status names that the scene lacks (text)
constexpr std::size_t kMaxRunsKept = 8;         // run ids remembered per instance

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
    const auto d =
        static_cast<std::size_t>(std::find(prefixes_.begin(), prefixes_.end(), i.prefix) - prefixes_.begin());
    index_[{d, i.name}] = tracked_.size();
    tracked_.push_back({i, d, {}});
  }
}

LinkOptions LiveView::Link(const std::string& prefix) const {
  LinkOptions link = bus_;
  link.channel_prefix = prefix;
  return link;
}

void LiveView::Run(double rate, FrameHub& hub) {
  auto bus = bus_.Open();  // signed when a key is given: states must verify, as watch's do
  Observe(*bus);
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(1.0 / rate));
  auto next = SteadyClock::now();
  while (!Interrupted()) {
    next += period;
    for (auto now = SteadyClock::now(); now < next; now = SteadyClock::now()) {
      bus->Handle(static_cast<int>(
          std::max<std::int64_t>(1, std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count())));
    }
    if (SteadyClock::now() > next + 10 * period) next = SteadyClock::now();  // fell behind: skip, never catch up
    TrackNamedInStatus();
    hub.Publish(Dump(Frame()));
  }
}

// One observer per daemon, following the scenes' instances under its prefix and those its status names.
void LiveView::Observe(Bus& bus) {
  for (std::size_t d = 0; d < prefixes_.size(); ++d) {
    const auto in_scene = static_cast<std::size_t>(
        std::count_if(tracked_.begin(), tracked_.end(), [&](const Tracked& t) { return t.daemon == d; }));
    BusObserver::Hooks hooks;
    hooks.on_state = [this, d](const std::string& name, const state_t& s) { OnState(d, name, s); };
    observers_.push_back(std::make_unique<BusObserver>(
        bus, prefixes_[d], ObserverLimits{kMaxRunsKept, in_scene + kMaxExtraInstances, true}, std::move(hooks)));
  }
  for (const Tracked& t : tracked_) observers_[t.daemon]->Follow(t.instance.name);
}

// Every state, not only the frames sent: the moment an instance entered fault, estop or stopped is kept.
// Called before the observer keeps `s`: the instance's newest state is still the one before it.
void LiveView::OnState(std::size_t d, const std::string& name, const state_t& s) {
  const auto it = index_.find({d, name});
  if (it == index_.end()) return;  // named in a status this very frame: tracked after the handlers
  Tracked& t = tracked_[it->second];
  const ObservedInstance* seen = observers_[d]->Find(name);
  const auto* last = seen != nullptr ? seen->states.Newest() : nullptr;
  const bool stopped =
      s.mode == state_t::MODE_FAULT || s.mode == state_t::MODE_ESTOP || s.mode == state_t::MODE_STOPPED;
  if (stopped && (last == nullptr || last->message.mode != s.mode || last->message.run_id != s.run_id))
    t.event = {{"mode", ModeName(s.mode)}, {"t", s.t}, {"tick", s.tick}, {"run", RunIdText(s.run_id)}};
}

// Instances a daemon's status names that the scene has not: shown as text (no model to draw them by).
void LiveView::TrackNamedInStatus() {
  for (std::size_t d = 0; d < observers_.size(); ++d) {
    observers_[d]->Discover();
    for (const std::string& name : observers_[d]->followed()) {
      if (index_.count({d, name}) != 0) continue;
      index_[{d, name}] = tracked_.size();
      tracked_.push_back({{prefixes_[d], name, -1}, d, {}});
    }
  }
}

json LiveView::Frame() {
  const auto now = SteadyClock::now();
  json instances = json::array();
  for (const Tracked& t : tracked_) {
    const ObservedInstance* seen = observers_[t.daemon]->Find(t.instance.name);
    if (seen != nullptr && !seen->states.empty()) instances.push_back(TrackedJson(t, *seen, now));
  }
  return {{"instances", instances}, {"daemons", DaemonsJson(now)}};
}

// An instance as its latest state shows it, with what else the bus said of it.
json LiveView::TrackedJson(const Tracked& t, const ObservedInstance& seen, SteadyClock::time_point now) const {
  const auto& newest = *seen.states.Newest();
  const state_t& s = newest.message;
  const double age = Seconds(now - newest.received);
  const auto* task = seen.tasks.Newest();
  const auto* plan = seen.plans.Find(s.run_id);
  const auto* base = seen.bases.Find(s.run_id);  // a floating base's: its newest, the state's tick or the one before
  json j = InstanceJson(t.instance, models_, s, age, task != nullptr ? &task->message : nullptr,
                        plan != nullptr ? &plan->message : nullptr, base != nullptr ? &base->message : nullptr);
  if (age > kStale) j["stale"] = true;
  if (!t.event.is_null()) j["event"] = t.event;
  const auto& runs = seen.states.entries();
  const auto live_runs = std::count_if(runs.begin(), runs.end(),
                                       [&](const auto& run) { return Seconds(now - run.second.received) <= kStale; });
  if (live_runs > 1)
    j["warning"] = std::to_string(live_runs) + " lagranged runs publish this instance: which is which cannot be told";
  if (const auto* status = observers_[t.daemon]->statuses().Find(s.run_id))
    j["reason"] = ModeReasonIn(status->message, t.instance.name, s.mode);
  if (const auto* telemetry = seen.telemetry.Find(s.run_id)) {
    j["eps"] = telemetry->message.energy_residual;
    j["eps_bound"] = telemetry->message.quadrature_bound;
  }
  return j;
}

json LiveView::DaemonsJson(SteadyClock::time_point now) const {
  json daemons = json::array();
  for (std::size_t d = 0; d < observers_.size(); ++d) {
    const auto* newest = observers_[d]->statuses().Newest();
    if (newest == nullptr) continue;
    const status_t& s = newest->message;
    daemons.push_back({{"prefix", Escape(prefixes_[d])},
                       {"run", RunIdText(s.run_id)},
                       {"ticks", s.ticks},
                       {"overruns", s.overruns},
                       {"period", s.period},
                       {"stale", Seconds(now - newest->received) > kStale}});
  }
  return daemons;
}

}  // namespace lagrange::cli::view
