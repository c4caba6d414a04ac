#pragma once
// lagrangectl view on the bus: every instance of the scenes under each
// daemon's channel prefix (and, as text, those a daemon's status names that
// the scenes lack), followed from their states, telemetry and task states;
// --rate times a second a frame of them all for the page. It only listens:
// it never publishes. It keeps only each instance's latest messages, and each
// browser is sent the newest frame when it can take one (FrameHub), so a slow
// browser skips frames and never queues them.

#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/bus.hpp"
#include "protocol/client.hpp"
#include "tools/view/instance_json.hpp"

namespace lagrange::cli::view {

// The newest frame, and a wait for one newer than a browser's last: each
// browser's stream thread waits here, so none holds more than one frame.
class FrameHub {
 public:
  void Publish(std::string frame);
  // The newest frame if newer than `seq` (which it updates), waiting up to `timeout`; null on timeout or stop.
  std::shared_ptr<const std::string> Next(std::uint64_t& seq, std::chrono::milliseconds timeout);
  void Stop();
  bool stopped();

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::shared_ptr<const std::string> frame_;
  std::uint64_t seq_ = 0;
  bool stopped_ = false;
};

class LiveView {
 public:
  // `instances`: the scenes' (each with its model), `prefixes` one per daemon; `bus` with --lcm-url and --bus-key.
  LiveView(const ViewModels& models, const std::vector<ViewInstance>& instances, std::vector<std::string> prefixes,
           LinkOptions bus);
  // Listens, and publishes a frame into `hub` `rate` times a second, until Ctrl-C (Interrupted()).
  void Run(double rate, FrameHub& hub);

 private:
  using SteadyClock = std::chrono::steady_clock;
  // One instance and what the bus last said of it.
  struct Tracked {
    ViewInstance instance;
    std::optional<state_t> state;
    SteadyClock::time_point received;
    std::map<std::int64_t, SteadyClock::time_point> run_heard;  // run ids heard (two: which is which cannot be told)
    std::optional<telemetry_t> telemetry;
    std::optional<task_state_t> task;  // a task-space controller's frame and target (<NAME>_TASK)
    nlohmann::json event;  // the latest entry into fault, estop or stopped, from every state (not only the frames sent)
  };

  LinkOptions Link(const std::string& prefix) const;
  void SubscribeStatuses(Bus& bus);
  void SubscribeTracked(Bus& bus, std::size_t i);
  void OnState(std::size_t i, state_t s);
  void SubscribeNamedInStatus(Bus& bus);
  nlohmann::json Frame();
  nlohmann::json TrackedJson(const Tracked& t, SteadyClock::time_point now) const;
  nlohmann::json DaemonsJson(SteadyClock::time_point now) const;

  const ViewModels& models_;
  std::vector<std::string> prefixes_;
  LinkOptions bus_;
  std::vector<Tracked> tracked_;  // grows only on the bus thread (Run), which alone reads it
  std::size_t extra_instances_ = 0;
  std::map<std::size_t, std::pair<status_t, SteadyClock::time_point>> statuses_;  // by prefix index
};

}  // namespace lagrange::cli::view
