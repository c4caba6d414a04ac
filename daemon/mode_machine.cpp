#include "daemon/mode_machine.hpp"

namespace lagrange {
namespace {

// Outcome helpers: `s` becomes `mode` for `reason`, entered anew.
ModeOutcome Enter(ModeState s, Mode mode, const char* reason) {
  s.mode = mode;
  s.reason = reason;
  return {s, nullptr, true};
}
ModeOutcome Stay(const ModeState& s) { return {s, nullptr, false}; }
ModeOutcome Refuse(const ModeState& s, const char* why) { return {s, why, false}; }

bool Commanding(Mode m) { return m == Mode::kRunning || m == Mode::kHold; }

// Leaving a mode that ignored the setpoints: running, or hold when the
// streamed setpoint it would follow has already timed out.
ModeOutcome RunOrHold(const ModeState& s, const ModeContext& c) {
  if (c.setpoints_timed_out) return Enter(s, Mode::kHold, kSetpointsTimedOut);
  ModeState next = s;
  next.mode = Mode::kRunning;
  next.reason = nullptr;
  return {next, nullptr, s.mode != Mode::kRunning};
}

// An external plant re-armed: waiting for its first fresh state.
ModeOutcome Rearm(ModeState s) {
  return Enter(s, Mode::kWaiting, s.estop_latched ? kWaitingEstopLatched : kWaitingForState);
}

ModeOutcome OnEstop(ModeState s) {
  if (s.mode == Mode::kFault) return Refuse(s, kEstopWhileFaulted);
  s.estop_latched = true;
  s.hold_on_arrival = false;
  // An external plant that commands nothing keeps its mode; its first fresh
  // state after re-arming then brakes instead of running.
  if (s.mode == Mode::kStopped) return Stay(s);
  if (s.mode == Mode::kWaiting) {
    s.reason = kWaitingEstopLatched;
    return Stay(s);
  }
  return Enter(s, Mode::kEstop, kEstopped);
}

ModeOutcome OnClearEstop(ModeState s, const ModeContext& c) {
  if (c.estop_this_tick) return Refuse(s, kClearWithEstop);  // the estop wins its tick
  if (s.mode == Mode::kStopped) return Rearm(s);      // the watchdog re-armed; a latched estop stays
  if (s.estop_latched && c.estop_dwelling) return Refuse(s, kClearWithinDwell);  // it brakes its dwell out
  if (s.mode == Mode::kWaiting && s.estop_latched) {  // the estop cleared: the first state holds
    s.estop_latched = false;
    s.hold_on_arrival = true;
    s.reason = kWaitingForState;
    return Stay(s);
  }
  if (s.mode != Mode::kEstop) return Refuse(s, kClearWithoutEstop);
  s.estop_latched = false;
  return Enter(s, Mode::kHold, kLeftEstop);
}

// The instance is back at its initial state; reset keeps a latched estop.
ModeOutcome OnReset(ModeState s, const ModeContext& c) {
  s.hold_on_arrival = false;
  if (c.external_plant) return Rearm(s);
  if (s.estop_latched) return Enter(s, Mode::kEstop, kEstopped);
  if (c.external_controller) return Enter(s, Mode::kHold, kNoTorqueYet);  // until its first torque
  if (c.mpc) return Enter(s, Mode::kHold, kNoPlanYet);                     // until its first plan
  s.mode = Mode::kRunning;
  s.reason = nullptr;
  return {s, nullptr, true};
}

ModeOutcome OnPause(ModeState s, const ModeContext& c) {
  if (c.external_plant) return Refuse(s, kPauseExternalPlant);
  if (!Commanding(s.mode)) return Refuse(s, kPauseNotRunning);
  s.before_pause = s.mode;
  s.paused_reason = s.reason;
  return Enter(s, Mode::kPaused, kPausedByCommand);
}

ModeOutcome OnResume(ModeState s) {
  if (s.mode != Mode::kPaused) return Refuse(s, kResumeNotPaused);
  s.mode = s.before_pause;  // as it was: a hold keeps the position it held
  s.reason = s.paused_reason;
  return Stay(s);
}

// A hold for want of the torques or plans of the controller that was active.
bool TorqueHold(const ModeState& s) {
  const char* r = s.reason;
  return s.mode == Mode::kHold && (r == kTorquesTimedOut || r == kNoTorqueYet || r == kNoPlanYet || r == kPlanRanOut ||
                                   r == kPlanLineSearchFailed || r == kPlanNotPositiveDefinite || r == kPlanDiverged);
}

ModeOutcome OnControllerSwitched(const ModeState& s, const ModeContext& c) {
  if (c.external_controller) {  // hold until its first torque
    return Commanding(s.mode) ? Enter(s, Mode::kHold, kNoTorqueYet) : Stay(s);
  }
  if (c.mpc) return Commanding(s.mode) ? Enter(s, Mode::kHold, kNoPlanYet) : Stay(s);  // until its first plan
  if (TorqueHold(s)) return RunOrHold(s, c);  // the torque stream no longer matters: the setpoints decide
  return Stay(s);
}

// Streamed setpoints (or, under an external controller, torques) resume a hold.
ModeOutcome Resume(ModeState s) {
  if (s.mode != Mode::kHold) return Stay(s);
  s.mode = Mode::kRunning;
  s.reason = nullptr;
  return {s, nullptr, true};
}

// The inputs whose arrival and timeout decide running and hold: the ones the
// active controller follows.
enum class Stream : std::uint8_t { kSetpoints, kPoses, kTorques, kPlans };
Stream DecidingStream(const ModeContext& c) {
  if (c.external_controller) return Stream::kTorques;
  if (c.mpc) return Stream::kPlans;
  return c.task_space ? Stream::kPoses : Stream::kSetpoints;
}

// An input of `stream` arrived: it resumes a hold when it is the deciding one.
ModeOutcome OnArrived(const ModeState& s, Stream stream, const ModeContext& c) {
  return DecidingStream(c) == stream ? Resume(s) : Stay(s);
}

// `stream` timed out: a running instance that follows it holds, for `reason`.
ModeOutcome OnTimedOut(const ModeState& s, Stream stream, const ModeContext& c, const char* reason) {
  if (DecidingStream(c) != stream || s.mode != Mode::kRunning) return Stay(s);
  return Enter(s, Mode::kHold, reason);
}

ModeOutcome OnMeasuredArrived(ModeState s, const ModeContext& c) {
  if (s.mode != Mode::kWaiting) return Stay(s);
  const bool hold = s.hold_on_arrival;
  s.hold_on_arrival = false;
  if (s.estop_latched) return Enter(s, Mode::kEstop, kEstopped);
  if (hold) return Enter(s, Mode::kHold, kLeftEstop);
  return RunOrHold(s, c);
}

// The watchdog: a measured state that cannot be used stops an external plant.
ModeOutcome OnMeasuredProblem(const ModeState& s, ModeEvent e) {
  if (s.mode == Mode::kStopped || s.mode == Mode::kFault) return Stay(s);
  switch (e) {
    case ModeEvent::kMeasuredTimedOut:
      return s.mode == Mode::kWaiting ? Stay(s) : Enter(s, Mode::kStopped, kMeasuredTimedOut);
    case ModeEvent::kMeasuredNotFinite: return Enter(s, Mode::kStopped, kMeasuredNotFinite);
    case ModeEvent::kMeasuredWrongSize: return Enter(s, Mode::kStopped, kMeasuredWrongSize);
    default:  // a second source: nothing is locked onto while waiting
      return s.mode == Mode::kWaiting ? Stay(s) : Enter(s, Mode::kStopped, kMeasuredSecondSource);
  }
}

}  // namespace

ModeOutcome Transition(const ModeState& s, ModeEvent e, const ModeContext& c) {
  switch (e) {
    case ModeEvent::kStart: {
      ModeState first;
      if (c.external_plant) return Enter(first, Mode::kWaiting, kWaitingForState);
      if (c.external_controller) return Enter(first, Mode::kHold, kNoTorqueYet);
      if (c.mpc) return Enter(first, Mode::kHold, kNoPlanYet);
      return {first, nullptr, true};
    }
    case ModeEvent::kEstop: return OnEstop(s);
    case ModeEvent::kClearEstop: return OnClearEstop(s, c);
    case ModeEvent::kReset: return OnReset(s, c);
    case ModeEvent::kPause: return OnPause(s, c);
    case ModeEvent::kResume: return OnResume(s);
    case ModeEvent::kControllerSwitched: return OnControllerSwitched(s, c);
    case ModeEvent::kSetpointArrived: return OnArrived(s, Stream::kSetpoints, c);
    case ModeEvent::kSetpointsTimedOut: return OnTimedOut(s, Stream::kSetpoints, c, kSetpointsTimedOut);
    case ModeEvent::kPoseArrived: return OnArrived(s, Stream::kPoses, c);
    case ModeEvent::kPosesTimedOut: return OnTimedOut(s, Stream::kPoses, c, kSetpointsTimedOut);
    case ModeEvent::kTorqueArrived: return OnArrived(s, Stream::kTorques, c);
    case ModeEvent::kTorquesTimedOut: return OnTimedOut(s, Stream::kTorques, c, kTorquesTimedOut);
    case ModeEvent::kMeasuredArrived: return OnMeasuredArrived(s, c);
    case ModeEvent::kMeasuredTimedOut:
    case ModeEvent::kMeasuredNotFinite:
    case ModeEvent::kMeasuredWrongSize:
    case ModeEvent::kMeasuredSecondSource: return OnMeasuredProblem(s, e);
    case ModeEvent::kFault: return Enter(s, Mode::kFault, c.fault);
    case ModeEvent::kPlanArrived: return OnArrived(s, Stream::kPlans, c);
    case ModeEvent::kPlanLapsed: return OnTimedOut(s, Stream::kPlans, c, c.plan_reason);
  }
  return Stay(s);
}

}  // namespace lagrange
