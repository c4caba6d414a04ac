#pragma once
// lagrangectl view on the bus: every instance of the scenes under each
// daemon's channel prefix (and, as text, those a daemon's status names that
// the scenes lack), followed from their states, telemetry, task states and mpc plans;
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
#include "protocol/observer.hpp"
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
  // One instance drawn: which daemon (prefix index) and name, and the latest entry into fault, estop or stopped,
  // from every state (not only the frames sent). What the bus said of it is its observer's.
  struct Tracked {
    ViewInstance instance;
    std::size_t daemon = 0;
    nlohmann::json event;
  };

  LinkOptions Link(const std::string& prefix) const;
  void Observe(Bus& bus);
  void OnState(std::size_t d, const std::string& name, const state_t& s);
  void TrackNamedInStatus();
  nlohmann::json Frame();
  nlohmann::json TrackedJson(const Tracked& t, const ObservedInstance& seen, SteadyClock::time_point now) const;
  nlohmann::json DaemonsJson(SteadyClock::time_point now) const;

  const ViewModels& models_;
  std::vector<std::string> prefixes_;
  LinkOptions bus_;
  std::vector<Tracked> tracked_;  // grows only on the bus thread (Run), which alone reads it
  std::map<std::pair<std::size_t, std::string>, std::size_t> index_;  // (daemon, name) => tracked_
  std::vector<std::unique_ptr<BusObserver>> observers_;               // one per prefix
};

}  // namespace lagrange::cli::view
