#pragma once
// What one lagranged's channels say, for a client that listens (lagrangectl
// watch, the view, DaemonLink in protocol/client.hpp): its statuses by run id,
// and the instances they name (or that were asked for by name), each with its
// latest state, telemetry, task state and mpc plan per run id. Several runs may publish
// one prefix (two daemons started on one bus): they are kept apart by run id,
// never mixed. Everything is bounded: runs per channel (the least recently
// heard forgotten, but never a run a client pinned), instances followed, and
// only names a scene could give an instance (IsInstanceName) are followed from
// a status. Every message goes through the typed receive
// (protocol/receive.hpp). It subscribes on the thread that handles the bus,
// never from inside a handler (Discover after Handle).

#include <lagrange/mpc_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/base_state_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "protocol/bus.hpp"

namespace lagrange {

// The latest message of each run id on one channel, at most `capacity` runs.
// A new run beyond that forgets the run heard from least recently, unless it
// is pinned (Pin): a client that chose a run keeps it whatever a flood of
// forged run ids does (every identity on the bus is copyable).
template <class Message>
class LatestByRun {
 public:
  using Time = std::chrono::steady_clock::time_point;
  struct Entry {
    Message message;
    Time received;
    std::int64_t count = 0;  // the run's messages heard since it was last kept anew
  };
  explicit LatestByRun(std::size_t capacity) : capacity_(capacity) {}

  // Keeps `message` as its run's latest. Null when the run is new, `capacity`
  // runs are kept and every one of them is pinned: it is not kept.
  Entry* Add(Message&& message, Time now) {
    auto it = entries_.find(message.run_id);
    if (it == entries_.end()) {
      if (entries_.size() >= capacity_) {  // forget the unpinned run heard from least recently
        auto oldest = entries_.end();
        for (auto e = entries_.begin(); e != entries_.end(); ++e) {
          if (pinned_.contains(e->first)) continue;
          if (oldest == entries_.end() || e->second.received < oldest->second.received) oldest = e;
        }
        if (oldest == entries_.end()) return nullptr;
        entries_.erase(oldest);
      }
      it = entries_.emplace(message.run_id, Entry{}).first;
    }
    it->second.message = std::move(message);
    it->second.received = now;
    ++it->second.count;
    return &it->second;
  }
  // Never forgets run `run_id` (heard yet or not). At most `capacity` runs are
  // pinned: false for one more (nothing changes). Pinned for good.
  bool Pin(std::int64_t run_id) {
    if (!pinned_.contains(run_id) && pinned_.size() >= capacity_) return false;
    pinned_.insert(run_id);
    return true;
  }
  bool pinned(std::int64_t run_id) const { return pinned_.contains(run_id); }
  // Most recently heard first.
  std::vector<const Entry*> Latest() const {
    std::vector<const Entry*> v;
    for (const auto& [id, e] : entries_) v.push_back(&e);
    std::sort(v.begin(), v.end(), [](const Entry* a, const Entry* b) { return a->received > b->received; });
    return v;
  }
  // The most recently heard; null when none.
  const Entry* Newest() const {
    const Entry* newest = nullptr;
    for (const auto& [id, e] : entries_) newest = newest == nullptr || e.received > newest->received ? &e : newest;
    return newest;
  }
  const Entry* Find(std::int64_t run_id) const {
    const auto it = entries_.find(run_id);
    return it == entries_.end() ? nullptr : &it->second;
  }
  const std::map<std::int64_t, Entry>& entries() const { return entries_; }
  bool empty() const { return entries_.empty(); }

 private:
  std::size_t capacity_;
  std::map<std::int64_t, Entry> entries_;
  std::set<std::int64_t> pinned_;  // at most capacity_
};

struct ObserverLimits {
  std::size_t runs = 4;        // run ids kept per channel
  std::size_t instances = 64;  // instances followed in all (asked for and named in a status)
  bool discover = true;        // follow the instances a status names
  bool telemetry = true;       // follow each instance's telemetry (a client acting on one reads none)
};

// One instance as the bus last showed it, per run.
struct ObservedInstance {
  explicit ObservedInstance(std::size_t runs) : states(runs), telemetry(runs), tasks(runs), plans(runs), bases(runs) {}
  LatestByRun<state_t> states;
  LatestByRun<telemetry_t> telemetry;
  LatestByRun<task_state_t> tasks;
  LatestByRun<mpc_t> plans;  // an mpc controller's latest plan (<NAME>_MPC), with the telemetry (limits.telemetry)
  LatestByRun<base_state_t> bases;  // a floating base's (<NAME>_BASE)
};

// Called for each message received, before it is kept (the instance still shows the previous one).
// Initialised members: a hook left out of a designated initializer is none, without a warning.
struct ObserverHooks {
  std::function<void(const std::string& instance, const state_t&)> on_state{};
  std::function<void(const std::string& instance, const telemetry_t&)> on_telemetry{};
  std::function<void(const status_t&)> on_status{};
  std::function<void(const std::string& instance, const mpc_t&)> on_mpc{};
};

class BusObserver {
 public:
  using Hooks = ObserverHooks;
  // Listens on `bus` to the daemon whose channels start with `prefix`; subscribes its status channel now.
  BusObserver(Bus& bus, std::string prefix, ObserverLimits limits = {}, Hooks hooks = {});
  BusObserver(const BusObserver&) = delete;
  BusObserver& operator=(const BusObserver&) = delete;

  // Follows `name`'s state, telemetry, task, mpc and base channels (once; within limits.instances). False when refused.
  bool Follow(const std::string& name);
  // Follows the instances the kept statuses name (limits.discover), in the order they name them.
  void Discover();
  // Never forgets run `run_id` on any channel (its statuses; every followed
  // instance's state, telemetry, task and plans, followed now or later): a client
  // that chose a run keeps it whatever a flood of forged run ids does. At most
  // limits.runs runs: false for one more (nothing changes).
  bool Pin(std::int64_t run_id);

  const std::string& prefix() const { return prefix_; }
  const LatestByRun<status_t>& statuses() const { return statuses_; }
  // By name; node-based: a reference stays valid while the observer lives.
  const std::map<std::string, ObservedInstance>& instances() const { return instances_; }
  const ObservedInstance* Find(const std::string& name) const;
  // Names in the order they were followed.
  const std::vector<std::string>& followed() const { return followed_; }

 private:
  Bus& bus_;
  std::string prefix_;
  ObserverLimits limits_;
  Hooks hooks_;
  LatestByRun<status_t> statuses_;
  std::map<std::string, ObservedInstance> instances_;
  std::vector<std::string> followed_;
  std::set<std::int64_t> pinned_;  // statuses_'s pins, given to each instance followed later
};

}  // namespace lagrange
