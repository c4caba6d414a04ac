#pragma once
// An instance's mode machine: one function, (mode, event) => (mode, reason),
// called from wherever an event arrives (the tick's Take* steps, a command,
// the health check). It decides modes only; what a mode does each tick, and
// the timers that raise the timeout events, are the runtime's
// (daemon/runtime.hpp). tests/daemon/mode_machine_test.cpp checks it as a
// table: every mode under every event.
//
// Modes (protocol/mode.hpp):
//   running  follows the streamed setpoint, or the scene trajectory until one
//            arrives; under an external controller, the latest streamed torque
//   hold     holds where it was when it entered (held position), by the
//            scene's on_timeout behaviour, or by an external controller's
//            fallback
//   fault    frozen at the last good state under zero torque until reset
//   paused   frozen: time and state stand still until resume
//   estop    braked (τ = −B q̇); latched until clear_estop
//   stopped  external plant: the watchdog stopped commanding (zero torque once)
//   waiting  external plant, armed: waits for its first fresh measured state
//
// When does an instance hold? One rule, in two halves:
//   - The receiver refuses an input that is already stale when it arrives
//     (older than its timeout: setpoint_timeout, torque_timeout,
//     state_timeout; daemon/receiver.hpp). A refused input is counted and
//     changes no mode.
//   - The tick raises a timeout event when no accepted input came for its
//     timeout, counted from when the last one was sent (kSetpointsTimedOut,
//     kTorquesTimedOut, kMeasuredTimedOut; Runtime::TimedOut). Here a
//     running instance that follows streamed setpoints, or an external
//     controller's torques, then holds; an external plant stops.
//   The next accepted input (kSetpointArrived, kTorqueArrived) resumes
//   running from hold.
//   An mpc controller's plans are its stream: a plan that ran out or a
//   failed solve (kPlanLapsed, with the reason) holds by its fallback, the
//   next usable plan (kPlanArrived) resumes; it holds from start, reset and
//   a switch to it until its first plan, as an external controller does.
//   One stream decides, the one the active controller follows: an external
//   controller's torques, a task-space controller's poses (kPoseArrived; a
//   pose latches, so only one streamed with a twist times out:
//   kPosesTimedOut), else the joint setpoints. The others' events change
//   nothing (DecidingStream), so a joint stream that timed out under another
//   controller cannot send a task-space instance back to hold.
//
// The stop is sacred: an estop is taken before anything else in a tick, and
// a clear_estop that arrives in the same tick as an estop is refused
// (kClearWithEstop) whichever was sent first, so no flood of clears can
// cancel an estop as it lands. Nor can one shorten it: a clear_estop is
// refused until the latest estop has lasted the scene's estop_dwell
// (kClearWithinDwell; default 0.5 s, restarted by every estop), so an estop
// always brakes that long whoever sends clears, a key holder's flood or
// anyone's on an unsigned bus. Leaving an estop takes a clear_estop after
// that: a deliberate command of its own (a key holder's when the bus is
// signed). A latched estop survives a fault, the watchdog and reset. Under an external controller the torques decide,
//   never the setpoints. An instance also holds when an external controller
//   becomes active (until its first torque) and after clear_estop.

#include <cstdint>

#include "protocol/mode.hpp"

namespace lagrange {

enum class ModeEvent : std::uint8_t {
  kStart,                 // the instance is built (and its first mode is chosen)
  kEstop,                 // command estop
  kClearEstop,            // command clear_estop: leaves an estop, or re-arms a stopped external plant
  kReset,                 // command reset (the instance is back at its initial state)
  kPause,                 // command pause
  kResume,                // command resume
  kControllerSwitched,    // command switch (the new controller is active)
  kSetpointArrived,       // an accepted streamed setpoint was taken
  kSetpointsTimedOut,     // streamed setpoints stopped for setpoint_timeout
  kPoseArrived,           // an accepted pose for the active task-space controller was taken
  kPosesTimedOut,         // a pose streamed with a twist was not followed by another within setpoint_timeout
  kTorqueArrived,         // an accepted torque for the active external controller was taken
  kTorquesTimedOut,       // its torques stopped for torque_timeout
  kMeasuredArrived,       // an external plant's accepted measured state was taken
  kMeasuredTimedOut,      // no measured state for state_timeout
  kMeasuredNotFinite,     // the receiver saw a non-finite or out-of-range measured state
  kMeasuredWrongSize,     // ... one of the wrong num_dofs
  kMeasuredSecondSource,  // ... one from a second run id
  kFault,                 // the health check failed (ModeContext::fault says why)
  kPlanArrived,           // a usable plan for the active mpc controller was taken
  kPlanLapsed,            // its plan ran out or a solve failed (ModeContext::plan_reason says which)
};
inline constexpr int kNumModeEvents = 21;

// The machine's state: the mode, why it is not running, and what it
// remembers across events.
struct ModeState {
  Mode mode = Mode::kRunning;
  const char* reason = nullptr;         // null while running (one of the k* reasons below, or a fault)
  bool estop_latched = false;           // an estop not yet cleared: survives a fault, the watchdog and reset
  bool hold_on_arrival = false;         // external plant waiting after clear_estop: its first state holds
  Mode before_pause = Mode::kRunning;   // paused: the mode to resume
  const char* paused_reason = nullptr;  // paused: the reason to resume with
};

// What an event's outcome depends on besides the state.
struct ModeContext {
  bool external_plant = false;       // the plant is outside lagranged
  bool external_controller = false;  // the active controller (after the event) streams torques over LCM
  bool task_space = false;           // the active controller (after the event) follows poses, not joint setpoints
  bool mpc = false;                  // the active controller (after the event) follows an optimiser's plans
  bool setpoints_timed_out = false;  // streamed setpoints were accepted and then stopped for setpoint_timeout
  bool estop_this_tick = false;      // an estop arrived in the same tick as this event (kClearEstop)
  bool estop_dwelling = false;       // the latched estop has not yet lasted estop_dwell (kClearEstop)
  const char* fault = nullptr;       // kFault: why (a static string)
  const char* plan_reason = nullptr;  // kPlanLapsed: why (one of the kPlan* reasons below)
};

struct ModeOutcome {
  ModeState next;
  const char* refused = nullptr;  // a command the mode does not allow (nothing changed), or null
  // next.mode was entered by this event (also hold re-entered anew): its
  // entry actions run (hold: capture the held position; stopped and fault:
  // restore the last good state, zero torque; waiting: re-arm).
  bool entered = false;
};

// The one transition function; pure, allocation-free.
ModeOutcome Transition(const ModeState& state, ModeEvent event, const ModeContext& context);

// Whether an instance in `mode` commands its plant this tick (running, hold,
// estop): it is integrated (or an external plant is sent a torque) and its
// time runs.
inline bool Commands(Mode mode) { return mode == Mode::kRunning || mode == Mode::kHold || mode == Mode::kEstop; }

// Why an instance is not running (static strings, published in the status).
inline constexpr char kSetpointsTimedOut[] = "streamed setpoints timed out (setpoint_timeout)";
inline constexpr char kTorquesTimedOut[] = "streamed torques timed out (torque_timeout)";
inline constexpr char kNoTorqueYet[] = "no torque yet on the external controller's channel";
// An mpc controller's plans (controllers/mpc.hpp): the optimiser thread's first
// plan has not come, the latest one's horizon ran out, or a solve failed (by
// its DdpStatus). Each holds by the controller's fallback until a usable plan.
inline constexpr char kNoPlanYet[] = "no plan yet from the mpc optimiser";
inline constexpr char kPlanRanOut[] = "the mpc plan's horizon ran out (no newer plan)";
inline constexpr char kPlanLineSearchFailed[] = "the mpc solve failed: line-search-failed";
inline constexpr char kPlanNotPositiveDefinite[] = "the mpc solve failed: not-positive-definite";
inline constexpr char kPlanDiverged[] = "the mpc solve failed: diverged";
inline constexpr char kLeftEstop[] = "cleared from an emergency stop";
inline constexpr char kEstopped[] = "emergency stop";
inline constexpr char kPausedByCommand[] = "paused by command";
inline constexpr char kWaitingForState[] = "waiting for the measured state (state_channel)";
inline constexpr char kWaitingEstopLatched[] = "waiting for the measured state; estop latched";
inline constexpr char kMeasuredTimedOut[] = "the measured state timed out (state_timeout)";
inline constexpr char kMeasuredNotFinite[] = "a measured state was not finite or out of range";
inline constexpr char kMeasuredWrongSize[] = "a measured state had the wrong num_dofs";
inline constexpr char kMeasuredSecondSource[] = "a measured state came from a second source (run_id)";

// Why a command was refused by the mode (static strings, in the reply).
inline constexpr char kEstopWhileFaulted[] = "estop: the instance is faulted (frozen); reset it";
inline constexpr char kClearWithoutEstop[] = "clear_estop: the instance is not in an emergency stop";
inline constexpr char kClearWithEstop[] =
    "clear_estop: an estop arrived in the same tick, and an estop wins; send clear_estop again to leave it";
inline constexpr char kClearWithinDwell[] =
    "clear_estop: an emergency stop lasts at least the scene's estop_dwell (default 0.5 s) before a clear can end "
    "it; send clear_estop again once it has";
inline constexpr char kPauseExternalPlant[] =
    "pause: an external plant keeps moving and cannot be frozen (estop brakes it)";
inline constexpr char kPauseNotRunning[] = "pause: the instance is not running or holding";
inline constexpr char kResumeNotPaused[] = "resume: the instance is not paused";

}  // namespace lagrange
