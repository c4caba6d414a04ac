#pragma once
// lagrangectl view --log: an lcm-logger recording instead of the bus. The
// log is read once, as warily as the bus (protocol/lcm_log.hpp, every packet
// checked before it is decoded): each instance's states (at most
// kMaxLogStates in all), telemetry, task states, mpc plans and floating bases, on the logger's clock
// from its first event. The page asks for a time t and is sent each
// instance at its last logged state at or before t, exactly: a floating base
// at the base state of that state's tick (logged just after it, maybe after t). What the log
// holds that the scene lacks, states that do not decode and a log cut short
// are notes, on the page and on stderr.

#include <lagrange/base_state_t.hpp>
#include <lagrange/mpc_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/task_state_t.hpp>

#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/client.hpp"
#include "protocol/lcm_log.hpp"
#include "tools/view/instance_json.hpp"

namespace lagrange::cli::view {

class LogView {
 public:
  // Reads `file` (LcmLogError when it is not a log) for `instances` under `bus`'s channel names; each note
  // goes to `err` too, one line each.
  LogView(const std::string& file, const ViewModels& models, std::vector<ViewInstance> instances,
          const LinkOptions& bus, std::ostream& err);
  // {file, duration, notes}: what the page shows of the log.
  nlohmann::json Info() const;
  // {t, instances}: every instance at its last logged state at or before `t` (s on the logger's clock).
  nlohmann::json FrameAt(double t) const;

 private:
  template <class T>
  struct Logged {
    double t = 0.0;  // s since the log's first event
    T message;
  };
  struct Telemetry {
    double residual = 0.0, bound = 0.0;
  };
  // What was read of one instance, in the log's order.
  struct Recorded {
    std::vector<Logged<state_t>> states;
    std::vector<Logged<Telemetry>> telemetry;
    std::vector<Logged<task_state_t>> tasks;
    std::vector<Logged<mpc_t>> plans;  // at most kMaxLogPlans
    std::vector<Logged<base_state_t>> bases;
  };
  struct Counts;

  void Read(const LinkOptions& bus);
  void Note(Counts& counts, const std::string& channel, const std::uint8_t* data, std::size_t size, double t);
  void Finish(const Counts& counts, LcmLogReader::End end);
  nlohmann::json InstanceAt(std::size_t i, double t) const;
  const base_state_t* BaseOf(const Recorded& r, const Logged<state_t>& s, double t) const;

  std::string file_;
  const ViewModels& models_;
  std::vector<ViewInstance> instances_;
  std::vector<Recorded> recorded_;  // by instance
  double duration_ = 0.0;
  std::vector<std::string> notes_;
};

}  // namespace lagrange::cli::view
