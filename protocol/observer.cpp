#include "protocol/observer.hpp"

#include "protocol/channels.hpp"
#include "protocol/receive.hpp"

namespace lagrange {
namespace {

void PinIn(ObservedInstance& seen, std::int64_t run_id) {
  seen.states.Pin(run_id);
  seen.telemetry.Pin(run_id);
  seen.tasks.Pin(run_id);
  seen.plans.Pin(run_id);
  seen.bases.Pin(run_id);
}

}  // namespace

BusObserver::BusObserver(Bus& bus, std::string prefix, ObserverLimits limits, Hooks hooks)
    : bus_(bus), prefix_(std::move(prefix)), limits_(limits), hooks_(std::move(hooks)), statuses_(limits.runs) {
  SubscribeMessages<status_t>(bus_, StatusChannel(prefix_), [this](status_t&& s) {
    if (hooks_.on_status) hooks_.on_status(s);
    statuses_.Add(std::move(s), std::chrono::steady_clock::now());
  });
}

bool BusObserver::Follow(const std::string& name) {
  if (instances_.count(name) != 0) return true;
  if (instances_.size() >= limits_.instances) return false;
  const auto added = instances_.try_emplace(name, limits_.runs).first;
  ObservedInstance* seen = &added->second;  // node-based: both stay valid
  const std::string* key = &added->first;
  followed_.push_back(name);
  for (const std::int64_t run : pinned_) PinIn(*seen, run);
  SubscribeMessages<state_t>(bus_, InstanceChannel(prefix_, name, kStateSuffix), [this, seen, key](state_t&& s) {
    if (hooks_.on_state) hooks_.on_state(*key, s);
    seen->states.Add(std::move(s), std::chrono::steady_clock::now());
  });
  if (limits_.telemetry) {
    SubscribeMessages<telemetry_t>(bus_, InstanceChannel(prefix_, name, kTelemetrySuffix),
                                   [this, seen, key](telemetry_t&& m) {
                                     if (hooks_.on_telemetry) hooks_.on_telemetry(*key, m);
                                     seen->telemetry.Add(std::move(m), std::chrono::steady_clock::now());
                                   });
    SubscribeMessages<mpc_t>(bus_, InstanceChannel(prefix_, name, kMpcSuffix), [this, seen, key](mpc_t&& m) {
      if (hooks_.on_mpc) hooks_.on_mpc(*key, m);
      seen->plans.Add(std::move(m), std::chrono::steady_clock::now());
    });
  }
  SubscribeMessages<task_state_t>(bus_, InstanceChannel(prefix_, name, kTaskSuffix), [seen](task_state_t&& m) {
    seen->tasks.Add(std::move(m), std::chrono::steady_clock::now());
  });
  SubscribeMessages<base_state_t>(bus_, InstanceChannel(prefix_, name, kBaseSuffix), [seen](base_state_t&& m) {
    seen->bases.Add(std::move(m), std::chrono::steady_clock::now());
  });
  return true;
}

void BusObserver::Discover() {
  if (!limits_.discover) return;
  for (const auto* e : statuses_.Latest()) {
    for (const std::string& name : e->message.instance_names) {
      if (instances_.size() >= limits_.instances) return;
      if (IsInstanceName(name)) Follow(name);
    }
  }
}

bool BusObserver::Pin(std::int64_t run_id) {
  if (!statuses_.Pin(run_id)) return false;  // its bound (limits.runs pins) is every channel's
  pinned_.insert(run_id);
  for (auto& [name, seen] : instances_) PinIn(seen, run_id);
  return true;
}

const ObservedInstance* BusObserver::Find(const std::string& name) const {
  const auto it = instances_.find(name);
  return it == instances_.end() ? nullptr : &it->second;
}

}  // namespace lagrange
