#pragma once
// The tick: every instance of a scene, its mode, and the mailboxes through
// which the LCM thread reaches it. Built before the loop; Tick allocates
// nothing, takes no lock, logs nothing and sends nothing.
//
// One tick, per instance:
//   take commands → take the latest setpoint → check its timeout →
//   control and integrate (by mode) → check health → record for the publisher
//
// Modes (state_t.MODE_*):
//   running  follows the streamed setpoint, or the scene trajectory until one arrives
//   hold     streamed setpoints went stale or stopped: on_timeout behaviour
//            (hold-position: q_d = q when it began, at rest; zero-torque: τ = 0);
//            the next valid setpoint resumes running
//   fault    the controller's law, the integrator, the state or the energy
//            (|T + V| > max_energy) failed: the last good state is kept, τ = 0,
//            nothing moves; reset clears it
//   paused   frozen: time and state stand still; resume returns to the mode before
//   estop    the controller is bypassed and every joint braked, τ = −B q̇ within the
//            torque limits; clear_estop enters hold. reset keeps an estop.

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "controllers/controller.hpp"
#include "daemon/clock.hpp"
#include "daemon/instance.hpp"
#include "daemon/mailbox.hpp"
#include "daemon/scene.hpp"

namespace lagrange {

enum class Mode : std::int8_t { kRunning = 0, kHold = 1, kFault = 2, kPaused = 3, kEstop = 4 };
std::string_view ToString(Mode mode);

// A setpoint the LCM thread has validated, or the news that a stale one came.
struct SetpointMessage {
  Setpoint setpoint;
  bool stale = false;
};

enum class CommandKind : std::int8_t {
  kSwitchController = 1,
  kSetGains = 2,
  kReset = 3,
  kPause = 4,
  kResume = 5,
  kEstop = 6,
  kClearEstop = 7,
};

// A command the LCM thread has decoded and checked against what does not
// change (controller names, gain sizes); the tick checks the rest.
struct CommandMessage {
  CommandKind kind = CommandKind::kReset;
  std::int64_t utime = 0;
  int controller = -1;  // switch: the target; set-gains: the controller the gains are for
  Gains gains;          // sized n
};

// Where the LCM receive thread meets one instance.
struct InstanceChannels {
  InstanceChannels(int n, std::size_t command_capacity);
  LatestMailbox<SetpointMessage> setpoints;
  SpscRing<CommandMessage> commands;
  std::atomic<int> active_controller{0};  // published by the tick, read by the receiver
};

// One instance at one tick, as the publisher sends it.
struct InstanceRecord {
  explicit InstanceRecord(int n = 0);
  double t = 0.0;
  VectorXd q, qd, qdd, tau, q_des, qd_des;
  double kinetic_energy = 0.0, potential_energy = 0.0;
  int controller = 0;
  Mode mode = Mode::kRunning;
  // What happened in this tick (static strings: the tick never formats).
  const char* fault = nullptr;
  int commands_accepted = 0;
  int commands_rejected = 0;
  const char* command_error = nullptr;
};

struct TickRecord {
  std::int64_t tick = 0;
  std::int64_t utime = 0;        // wall clock, µs
  Nanoseconds wake_latency = 0;
  Nanoseconds compute = 0;
  std::int64_t overruns = 0;     // total so far
  std::vector<InstanceRecord> instances;
};

class Runtime {
 public:
  explicit Runtime(const Scene& scene);
  ~Runtime();

  std::size_t size() const { return slots_.size(); }
  double period() const { return period_; }
  Instance& instance(std::size_t i);
  InstanceChannels& channels(std::size_t i);
  Mode mode(std::size_t i) const;

  // A record sized for this scene (the publisher ring's prototype).
  TickRecord MakeRecord() const;

  // One tick at monotonic time `now`: fills record.instances.
  void Tick(Nanoseconds now, TickRecord& record);

 private:
  struct Slot;
  void TakeCommands(Slot& s, Nanoseconds now, InstanceRecord& r);
  void TakeSetpoint(Slot& s, Nanoseconds now);
  void ControlAndIntegrate(Slot& s);
  void CheckHealth(Slot& s, bool stepped_ok, InstanceRecord& r);
  void Record(Slot& s, InstanceRecord& r);
  void EnterHold(Slot& s);
  void Fault(Slot& s, const char* why, InstanceRecord& r);

  double period_;
  std::vector<std::unique_ptr<Slot>> slots_;
};

// Default energy bound of a plant: 1000 × (1 J + Σ m g × reach), a few
// hundred times anything its gravity can supply.
double DefaultMaxEnergy(const PlantSpec& plant);

}  // namespace lagrange
