#pragma once
// The daemon's receive thread: it meets the tick only at the runtime's
// mailboxes (daemon/runtime.hpp), and speaks LCM's wire format through
// protocol/bus.hpp, never through lcm::LCM (see there why). What it sends out
// is the publisher's (daemon/publisher.hpp), but for its own refusals.
//
// Receiver: for each instance it subscribes to <NAME>_SETPOINT, <NAME>_POSE
// and <NAME>_COMMAND on the input bus (and an external controller's torque
// channel, an external plant's state_channel), checks every packet's raw
// layout before decoding (protocol/wire.hpp), validates what it decodes
// (protocol/setpoint_check.hpp, command_check.hpp), and hands the good ones to
// the tick; bad ones are dropped, counted, and their reason kept. It answers
// commands it refuses itself with a reply_t. It also listens on this run's
// output channels (<NAME>_STATE, <NAME>_REPLY, <NAME>_TELEMETRY,
// <NAME>_FORCES, LAGRANGE_STATUS) and counts messages there from another run
// id: a second daemon, or a spoofer.
//
// Every string that came from the bus is escaped (base/escape.hpp) before
// it is logged or published.

#include <lagrange/command_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/torque_t.hpp>

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "daemon/runtime.hpp"
#include "daemon/throttle.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "protocol/command_check.hpp"
#include "protocol/setpoint_check.hpp"
#include "protocol/status.hpp"

namespace lagrange {

// A reason, carried between threads in a mailbox (no allocation to move it).
struct Reason {
  std::array<char, kMaxStatusReasonBytes + 1> text{};  // NUL-terminated
  void Set(const std::string& s);
};

// Replies per second the daemon sends at most, from each thread; beyond it
// verdicts are counted (replies_suppressed) but not sent, so a flood of
// commands cannot become a flood on the output bus.
inline constexpr double kMaxRepliesPerSecond = 2000.0;

// Counters the receive thread keeps and the publish thread reports.
struct ReceiverStats {
  std::atomic<std::int64_t> setpoints_accepted{0};
  std::atomic<std::int64_t> setpoints_rejected{0};
  std::atomic<std::int64_t> torques_accepted{0};
  std::atomic<std::int64_t> torques_rejected{0};
  std::atomic<std::int64_t> measured_accepted{0};
  std::atomic<std::int64_t> measured_rejected{0};
  std::atomic<std::int64_t> commands_rejected{0};  // refused here, before reaching the tick
  std::atomic<std::int64_t> decode_errors{0};
  std::atomic<std::int64_t> replies_suppressed{0};
  // From the buses the receiver reads.
  std::atomic<std::int64_t> datagrams_dropped_kernel{0};
  std::atomic<std::int64_t> datagrams_malformed{0};
  std::atomic<std::int64_t> fragments_dropped{0};
  // Messages on this run's output channels from another run.
  std::atomic<std::int64_t> foreign_messages{0};
  std::atomic<std::int64_t> last_foreign_run_id{0};
  // Signed bus (--bus-key): whether the input bus checks signatures, every channel the
  // receiver subscribed to (set once by its constructor, before the threads start), the
  // messages on each refused for their signature (same order) and their total.
  bool bus_signed = false;
  std::vector<std::string> channels;
  std::deque<std::atomic<std::int64_t>> unauthenticated;
  std::atomic<std::int64_t> datagrams_unauthenticated{0};
  LatestMailbox<Reason> last_setpoint_rejection{Reason{}};  // setpoints, torques and measured states
  LatestMailbox<Reason> last_command_error{Reason{}};
};

// How a setpoint's age is judged against the scene's setpoint_timeout (and a
// torque's against torque_timeout, a measured state's against state_timeout).
enum class SetpointAge : std::uint8_t {
  kWall,    // now − utime: sender and daemon clocks in step (NTP, or the same host)
  kStream,  // (arrival − utime) − the least such offset in the current stream: a message's
            // delay relative to the stream's own timeline, whatever the clocks' offset
            // (lcm-logplayer replaying a recorded stream, hosts whose clocks differ). A gap
            // longer than the timeout starts a new stream. A packet whose timestamp is out
            // of line with the stream by more than the timeout (ahead, or stale) is refused
            // and does not move the timeline unless kStreamConfirmations such packets in a
            // row agree with one another.
};
inline constexpr int kStreamConfirmations = 3;

class Receiver {
 public:
  // Subscribes on `input` (setpoints, commands) and, when `output_listener`
  // is given, on it for this run's output channels (it may be `input` itself
  // when both directions share a bus). Refusals are answered on `replies`
  // (a bus this thread alone publishes on). Reads the run's model
  // (runtime.model(): channels, rules, timeouts) and reaches the tick only
  // through the runtime's mailboxes.
  Receiver(Bus& input, Bus* output_listener, Bus& replies, Runtime& runtime, Clock& clock, ReceiverStats& stats,
           SetpointAge age, std::int64_t run_id);

  // Handles messages until `stop` is set (checked every 20 ms).
  void Run(const std::atomic<bool>& stop);
  // Waits up to `timeout_ms` for traffic on either bus, handles what came, and
  // updates the bus counters in the stats.
  void Poll(int timeout_ms);

 private:
  // SetpointAge::kStream: one stream's least (arrival − utime), its last
  // in-line arrival, µs; and a candidate timeline being confirmed.
  struct Timeline {
    std::int64_t least_offset = 0;
    std::int64_t last_arrival = -1;
    std::int64_t candidate_offset = 0;
    int candidate_count = 0;
  };
  // What the receiver keeps of one instance between packets (the rest is
  // the instance's model): each stream's timeline, an external controller's
  // sender, its last sequence number and when it last sent, an external
  // plant's source and last accepted tick.
  struct InstanceData {
    Timeline setpoints;
    Timeline poses;
    Timeline torques;
    std::int64_t torque_source = 0;
    std::int64_t torque_sequence = 0;
    std::int64_t torque_last_us = 0;
    Timeline measured;
    std::int64_t measured_source = 0;    // the previous packet's run id (0: none yet)
    std::int64_t measured_tick = 0;      // the last accepted state's tick (from measured_source)
    std::int64_t measured_last_us = -1;  // when it was accepted, wall clock µs
  };
  // A setpoint's age against its instance's timeout, or why it is refused.
  struct AgeVerdict {
    bool ok = true;
    const char* out_of_line = nullptr;  // kStream: refused as out of line with its stream
    double age = 0.0;                   // s; < 0 for a timestamp in the future
  };
  AgeVerdict Age(Timeline& line, double timeout, std::int64_t utime);
  // "stale: sent X s ago (NAME X s)" or "timestamp X s in the future ...".
  static std::string AgeReason(const AgeVerdict& age, const char* timeout_name, double timeout);
  // Instance i's active controller as the tick last published it, and why it
  // refuses a `kind` target ("" when it follows it).
  const ControllerModel& ActiveController(std::size_t i) const;
  std::string Refusal(std::size_t i, TargetKind kind) const;
  void HandleSetpoint(std::size_t i, const std::uint8_t* data, std::size_t size);
  void HandlePose(std::size_t i, const std::uint8_t* data, std::size_t size);
  void HandleTorque(std::size_t i, const std::uint8_t* data, std::size_t size);
  void HandleMeasured(std::size_t i, const std::uint8_t* data, std::size_t size);
  void RejectInput(std::size_t i, std::atomic<std::int64_t>& counter, const char* what, const std::string& why);
  void Trip(std::size_t i, MeasuredProblem problem, const std::string& why);
  void HandleCommand(std::size_t i, const std::uint8_t* data, std::size_t size);
  void HandleOwnOutput(std::string_view channel, const std::uint8_t* data, std::size_t size);
  void Warn(const std::string& message);
  void Refuse(std::atomic<std::int64_t>& counter, LatestMailbox<Reason>& last, std::size_t i, const std::string& why);
  void RejectSetpoint(std::size_t i, const std::string& why);
  void RejectCommand(std::size_t i, const std::string& why);
  void DecodeError(const std::string& channel, const char* why);
  void UpdateBusStats();
  // Subscribes `handler` to `channel` on `bus`, and lists the channel for the status's per-channel counts.
  void Listen(Bus& bus, const std::string& channel, Bus::Handler handler);

  Bus& input_;
  Bus* output_listener_;
  Bus& replies_;
  Runtime& runtime_;
  const DaemonModel& model_;
  Clock& clock_;
  ReceiverStats& stats_;
  SetpointAge age_;
  std::int64_t run_id_;
  std::vector<InstanceData> data_;  // by instance
  setpoint_t setpoint_;             // decoded into; keeps its capacity
  pose_setpoint_t pose_;
  command_t command_;
  torque_t torque_;
  state_t measured_;
  reply_t reply_;
  LogThrottle log_throttle_, foreign_throttle_, old_format_throttle_;
  std::int64_t old_format_said_ = 0;  // datagrams in the old signature format (LGS1) the log has told of
  TokenBucket reply_budget_{kMaxRepliesPerSecond, kMaxRepliesPerSecond};
};

}  // namespace lagrange
