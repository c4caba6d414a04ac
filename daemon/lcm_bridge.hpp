#pragma once
// The daemon's LCM side, on two threads of its own; they meet the tick only
// at the runtime's mailboxes and the record ring.
//
// LcmReceiver (receive thread): for each instance it subscribes to
// <NAME>_SETPOINT and <NAME>_COMMAND, checks every packet's raw layout before
// decoding (daemon/wire.hpp), validates what it decodes, and hands the good
// ones to the tick; bad ones are dropped, counted, and their reason kept.
//
// LcmPublisher (publish thread): waits on an eventfd the tick writes, turns
// each tick record into one state_t per instance on <NAME>_STATE, and every
// 0.1 s of ticks a status_t on LAGRANGE_STATUS. It also logs mode changes,
// faults and refused commands.

#include <lcm/lcm-cpp.hpp>
#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <array>
#include <atomic>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "daemon/channels.hpp"
#include "daemon/loop.hpp"
#include "daemon/setpoint_check.hpp"
#include "daemon/runtime.hpp"

namespace lagrange {

// A reason, carried between threads in a mailbox (no allocation to move it).
struct Reason {
  std::array<char, 200> text{};
  void Set(const std::string& s);
};

// Counters the receive thread keeps and the publish thread reports.
struct ReceiverStats {
  std::atomic<std::int64_t> setpoints_accepted{0};
  std::atomic<std::int64_t> setpoints_rejected{0};
  std::atomic<std::int64_t> commands_rejected{0};    // refused here, before reaching the tick
  std::atomic<std::int64_t> decode_errors{0};
  LatestMailbox<Reason> last_setpoint_rejection{Reason{}};
  LatestMailbox<Reason> last_command_error{Reason{}};
};

// How a setpoint's age is judged against the scene's setpoint_timeout.
enum class SetpointAge : std::uint8_t {
  kWall,    // now − utime: sender and daemon clocks in step (NTP, or the same host)
  kStream,  // (arrival − utime) − the least such offset in the current stream: a message's
            // delay relative to the stream's own timeline, whatever the clocks' offset
            // (lcm-logplayer replaying a recorded stream, hosts whose clocks differ). A gap
            // longer than the timeout starts a new stream.
};

class LcmReceiver {
 public:
  // Subscribes on `lcm`. Reads the runtime's immutable configuration only.
  LcmReceiver(lcm::LCM& lcm, const ChannelNames& channels, Runtime& runtime, Clock& clock, ReceiverStats& stats,
              SetpointAge age = SetpointAge::kWall);

  // Handles messages until `stop` is set (checked every 20 ms).
  void Run(const std::atomic<bool>& stop);

 private:
  struct InstanceInfo {
    std::string name;
    int n = 0;
    std::vector<std::string> controllers;
    std::vector<ControllerType> controller_types;
    SetpointRules rules;
    double timeout = 0.5;
    // SetpointAge::kStream: the current stream's least (arrival − utime) and last arrival, µs.
    std::int64_t least_offset = 0;
    std::int64_t last_arrival = -1;
  };
  // Age of a setpoint sent at `utime` and arriving now, s.
  double Age(InstanceInfo& info, std::int64_t utime);
  struct Handler {
    LcmReceiver* self;
    std::size_t index;
    void OnSetpoint(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
    void OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  };
  void HandleSetpoint(std::size_t i, const lcm::ReceiveBuffer* rbuf);
  void HandleCommand(std::size_t i, const lcm::ReceiveBuffer* rbuf);
  void WarnAtMostOncePerSecond(std::string message);
  void Refuse(std::atomic<std::int64_t>& counter, LatestMailbox<Reason>& last, std::size_t i, const std::string& why);
  void RejectSetpoint(std::size_t i, const std::string& why);
  void RejectCommand(std::size_t i, const std::string& why);
  void DecodeError(const std::string& channel, const char* why);

  lcm::LCM& lcm_;
  Runtime& runtime_;
  Clock& clock_;
  ReceiverStats& stats_;
  SetpointAge age_;
  std::vector<InstanceInfo> info_;
  std::vector<Handler> handlers_;
  setpoint_t setpoint_;  // decoded into; keeps its capacity
  command_t command_;
  std::int64_t last_log_us_ = 0;
  std::int64_t suppressed_ = 0;
};

class LcmPublisher {
 public:
  LcmPublisher(lcm::LCM& lcm, const ChannelNames& channels, Runtime& runtime, SpscRing<TickRecord>& ring,
               const Loop& loop, ReceiverStats& stats, int notify_fd);

  // Publishes records as they come until `stop` is set.
  void Run(const std::atomic<bool>& stop);
  // Publishes whatever is left in the ring and a final status.
  void Drain();

  // For bench/: from now on also writes one CSV line per tick record,
  // "tick,utime_us,wake_latency_ns,compute_ns,overruns", on this (the publish) thread.
  // False when the file cannot be opened.
  bool WriteTimingCsv(const std::string& path);

  std::int64_t states_published() const { return states_published_; }

 private:
  void Publish(const TickRecord& record);
  void PublishStatus(const TickRecord& last);
  void LogEvents(const TickRecord& record);
  void WriteTiming(const TickRecord& record);

  lcm::LCM& lcm_;
  ChannelNames channels_;
  SpscRing<TickRecord>& ring_;
  const Loop& loop_;
  ReceiverStats& stats_;
  int notify_fd_;
  int status_every_;
  double period_;
  std::vector<std::string> names_;
  std::vector<std::vector<std::string>> controller_names_;
  std::vector<state_t> states_;
  std::vector<Mode> modes_;
  std::vector<double> latencies_, computes_;  // µs, this status window
  std::int64_t commands_applied_ = 0;   // by the tick, from its records
  std::int64_t commands_refused_by_tick_ = 0;
  std::string last_setpoint_rejection_, last_command_error_;
  std::int64_t states_published_ = 0;
  bool have_record_ = false;
  TickRecord last_;
  std::ofstream timing_csv_;  // open only with --timing-csv
};

}  // namespace lagrange
