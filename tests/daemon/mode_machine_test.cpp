// The mode machine (daemon/mode_machine.hpp) as a table: every mode under
// every event, each cell written out by hand, then the cells whose outcome
// depends on the context or on what the machine remembers (a latched estop,
// a hold on arrival, a pause's mode to resume).

#include <gtest/gtest.h>

#include <array>
#include <string>

#include "daemon/mode_machine.hpp"

namespace lagrange {
namespace {

constexpr Mode kModes[] = {Mode::kRunning, Mode::kHold,    Mode::kFault,  Mode::kPaused,
                           Mode::kEstop,   Mode::kStopped, Mode::kWaiting};
constexpr int kNumModes = 7;

const char* EventName(ModeEvent e) {
  constexpr const char* kNames[kNumModeEvents] = {"start",
                                                  "estop",
                                                  "clear_estop",
                                                  "reset",
                                                  "pause",
                                                  "resume",
                                                  "controller switched",
                                                  "setpoint arrived",
                                                  "setpoints timed out",
                                                  "pose arrived",
                                                  "poses timed out",
                                                  "torque arrived",
                                                  "torques timed out",
                                                  "measured arrived",
                                                  "measured timed out",
                                                  "measured not finite",
                                                  "measured wrong size",
                                                  "measured second source",
                                                  "fault",
                                                  "plan arrived",
                                                  "plan lapsed"};
  return kNames[static_cast<int>(e)];
}

// A state in `mode` as the runtime would hold it: a reason for every mode
// but running, a pause remembering a hold.
ModeState In(Mode mode) {
  ModeState s;
  s.mode = mode;
  switch (mode) {
    case Mode::kRunning: break;
    case Mode::kHold: s.reason = kSetpointsTimedOut; break;
    case Mode::kFault: s.reason = "the integrator failed its tolerance"; break;
    case Mode::kPaused:
      s.reason = kPausedByCommand;
      s.before_pause = Mode::kHold;
      s.paused_reason = kSetpointsTimedOut;
      break;
    case Mode::kEstop:
      s.reason = kEstopped;
      s.estop_latched = true;
      break;
    case Mode::kStopped: s.reason = kMeasuredTimedOut; break;
    case Mode::kWaiting: s.reason = kWaitingForState; break;
  }
  return s;
}

// One cell: the next mode, or kRefused for a command the mode does not allow.
constexpr int kRefused = -1;
constexpr int R = static_cast<int>(Mode::kRunning), H = static_cast<int>(Mode::kHold),
              F = static_cast<int>(Mode::kFault), P = static_cast<int>(Mode::kPaused),
              E = static_cast<int>(Mode::kEstop), S = static_cast<int>(Mode::kStopped),
              W = static_cast<int>(Mode::kWaiting), X = kRefused;

struct Row {
  ModeEvent event;
  std::array<int, kNumModes> next;  // from running, hold, fault, paused, estop, stopped, waiting
};

void ExpectRow(const Row& row, const ModeContext& context, const char* label) {
  for (int m = 0; m < kNumModes; ++m) {
    const ModeOutcome out = Transition(In(kModes[m]), row.event, context);
    const std::string where =
        std::string(label) + ": " + EventName(row.event) + " in " + std::string(ToString(kModes[m]));
    if (row.next[m] == kRefused) {
      EXPECT_NE(out.refused, nullptr) << where;
      EXPECT_EQ(out.next.mode, kModes[m]) << where << " (a refusal changes nothing)";
    } else {
      EXPECT_EQ(out.refused, nullptr) << where << ": refused: " << out.refused;
      EXPECT_EQ(static_cast<int>(out.next.mode), row.next[m]) << where << " went to " << ToString(out.next.mode);
    }
    // A reason exactly when not running.
    EXPECT_EQ(out.next.reason == nullptr, out.next.mode == Mode::kRunning) << where;
  }
}

// A simulated plant under the scene's own controller: setpoints decide.
TEST(ModeMachine, EveryModeUnderEveryEventInASimulatedPlant) {
  const ModeContext sim{.fault = "the controller's output was not finite"};
  const Row rows[] = {
      //                                 running hold fault paused estop stopped waiting
      {ModeEvent::kEstop, {E, E, X, E, E, S, W}},
      {ModeEvent::kClearEstop, {X, X, X, X, H, W, X}},
      {ModeEvent::kPause, {P, P, X, X, X, X, X}},
      {ModeEvent::kResume, {X, X, X, H, X, X, X}},
      {ModeEvent::kControllerSwitched, {R, H, F, P, E, S, W}},
      {ModeEvent::kSetpointArrived, {R, R, F, P, E, S, W}},
      {ModeEvent::kSetpointsTimedOut, {H, H, F, P, E, S, W}},
      {ModeEvent::kPoseArrived, {R, H, F, P, E, S, W}},
      {ModeEvent::kPosesTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kTorqueArrived, {R, H, F, P, E, S, W}},
      {ModeEvent::kTorquesTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kMeasuredArrived, {R, H, F, P, E, S, R}},
      {ModeEvent::kMeasuredTimedOut, {S, S, F, S, S, S, W}},
      {ModeEvent::kMeasuredNotFinite, {S, S, F, S, S, S, S}},
      {ModeEvent::kMeasuredWrongSize, {S, S, F, S, S, S, S}},
      {ModeEvent::kMeasuredSecondSource, {S, S, F, S, S, S, W}},
      {ModeEvent::kFault, {F, F, F, F, F, F, F}},
      {ModeEvent::kPlanArrived, {R, H, F, P, E, S, W}},
      {ModeEvent::kPlanLapsed, {R, H, F, P, E, S, W}},
  };
  // Every event but start and reset (below: reset depends on the latch, not the mode).
  static_assert(std::size(rows) == kNumModeEvents - 2);
  for (const Row& row : rows) ExpectRow(row, sim, "simulated plant");
}

TEST(ModeMachine, ResetRunsAgainUnlessAnEstopIsLatched) {
  for (const Mode m : kModes) {
    ModeState s = In(m);
    s.estop_latched = false;
    EXPECT_EQ(Transition(s, ModeEvent::kReset, {}).next.mode, Mode::kRunning) << ToString(m);
    s.estop_latched = true;
    const ModeOutcome latched = Transition(s, ModeEvent::kReset, {});
    EXPECT_EQ(latched.next.mode, Mode::kEstop) << ToString(m) << ": reset keeps a latched estop";
    EXPECT_TRUE(latched.next.estop_latched);
  }
  // Under an external controller it holds until the first torque.
  EXPECT_EQ(Transition(In(Mode::kFault), ModeEvent::kReset, {.external_controller = true}).next.reason, kNoTorqueYet);
  // An external plant is re-armed and waits for its state, estop latched or not.
  ModeState latched = In(Mode::kEstop);
  const ModeOutcome rearmed = Transition(latched, ModeEvent::kReset, {.external_plant = true});
  EXPECT_EQ(rearmed.next.mode, Mode::kWaiting);
  EXPECT_EQ(rearmed.next.reason, kWaitingEstopLatched);
  EXPECT_TRUE(rearmed.entered);
}

// Under an external controller the torques decide running and hold; setpoints are ignored.
TEST(ModeMachine, UnderAnExternalControllerTheTorquesDecide) {
  const ModeContext external{.external_controller = true};
  const Row rows[] = {
      //                                 running hold fault paused estop stopped waiting
      {ModeEvent::kSetpointArrived, {R, H, F, P, E, S, W}},    {ModeEvent::kSetpointsTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kPoseArrived, {R, H, F, P, E, S, W}},        {ModeEvent::kPosesTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kTorqueArrived, {R, R, F, P, E, S, W}},      {ModeEvent::kTorquesTimedOut, {H, H, F, P, E, S, W}},
      {ModeEvent::kControllerSwitched, {H, H, F, P, E, S, W}},
  };
  for (const Row& row : rows) ExpectRow(row, external, "external controller");
  EXPECT_EQ(Transition(In(Mode::kRunning), ModeEvent::kTorquesTimedOut, external).next.reason, kTorquesTimedOut);
  const ModeOutcome switched = Transition(In(Mode::kHold), ModeEvent::kControllerSwitched, external);
  EXPECT_EQ(switched.next.reason, kNoTorqueYet);
  EXPECT_TRUE(switched.entered) << "a hold entered anew captures the position again";
}

// Under an mpc controller its plans decide: one that ran out or failed holds
// (by the fallback) with its reason, the next usable one resumes; setpoints,
// poses and torques change no mode (the setpoint is the plan's reference).
TEST(ModeMachine, UnderAnMpcControllerThePlansDecide) {
  const ModeContext mpc{.mpc = true, .plan_reason = kPlanDiverged};
  const Row rows[] = {
      //                                 running hold fault paused estop stopped waiting
      {ModeEvent::kSetpointArrived, {R, H, F, P, E, S, W}},    {ModeEvent::kSetpointsTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kPoseArrived, {R, H, F, P, E, S, W}},        {ModeEvent::kPosesTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kTorqueArrived, {R, H, F, P, E, S, W}},      {ModeEvent::kTorquesTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kPlanArrived, {R, R, F, P, E, S, W}},        {ModeEvent::kPlanLapsed, {H, H, F, P, E, S, W}},
      {ModeEvent::kControllerSwitched, {H, H, F, P, E, S, W}},
  };
  for (const Row& row : rows) ExpectRow(row, mpc, "mpc controller");
  EXPECT_EQ(Transition(In(Mode::kRunning), ModeEvent::kPlanLapsed, mpc).next.reason, kPlanDiverged);
  EXPECT_EQ(Transition({}, ModeEvent::kStart, mpc).next.reason, kNoPlanYet);
  EXPECT_EQ(Transition(In(Mode::kFault), ModeEvent::kReset, mpc).next.reason, kNoPlanYet);
  // Switching away from a plan hold lets the setpoints decide.
  ModeState plan_hold = In(Mode::kHold);
  plan_hold.reason = kPlanRanOut;
  EXPECT_EQ(Transition(plan_hold, ModeEvent::kControllerSwitched, {}).next.mode, Mode::kRunning);
}

// Under a task-space controller the poses decide: a joint setpoint's arrival
// or timeout (a stream from before a switch) changes nothing, so a pose that
// ends a hold leaves the instance running for good.
TEST(ModeMachine, UnderATaskSpaceControllerThePosesDecide) {
  const ModeContext task{.task_space = true};
  const Row rows[] = {
      //                                 running hold fault paused estop stopped waiting
      {ModeEvent::kSetpointArrived, {R, H, F, P, E, S, W}},    {ModeEvent::kSetpointsTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kPoseArrived, {R, R, F, P, E, S, W}},        {ModeEvent::kPosesTimedOut, {H, H, F, P, E, S, W}},
      {ModeEvent::kTorqueArrived, {R, H, F, P, E, S, W}},      {ModeEvent::kTorquesTimedOut, {R, H, F, P, E, S, W}},
      {ModeEvent::kControllerSwitched, {R, H, F, P, E, S, W}},
  };
  for (const Row& row : rows) ExpectRow(row, task, "task-space controller");
  EXPECT_EQ(Transition(In(Mode::kRunning), ModeEvent::kPosesTimedOut, task).next.reason, kSetpointsTimedOut);
  const ModeOutcome resumed = Transition(In(Mode::kHold), ModeEvent::kPoseArrived, task);
  EXPECT_TRUE(resumed.entered);
  EXPECT_EQ(Transition(resumed.next, ModeEvent::kSetpointsTimedOut, task).next.mode, Mode::kRunning)
      << "a joint stream that timed out before does not flip it back to hold";
}

TEST(ModeMachine, LeavingATorqueHoldLetsTheSetpointsDecide) {
  ModeState torque_hold = In(Mode::kHold);
  torque_hold.reason = kTorquesTimedOut;
  EXPECT_EQ(Transition(torque_hold, ModeEvent::kControllerSwitched, {}).next.mode, Mode::kRunning);
  const ModeOutcome stale = Transition(torque_hold, ModeEvent::kControllerSwitched, {.setpoints_timed_out = true});
  EXPECT_EQ(stale.next.mode, Mode::kHold);
  EXPECT_EQ(stale.next.reason, kSetpointsTimedOut);
  // A hold for another reason stays.
  EXPECT_EQ(Transition(In(Mode::kHold), ModeEvent::kControllerSwitched, {}).next.reason, kSetpointsTimedOut);
}

TEST(ModeMachine, PauseAndResumeReturnToTheModeAndReasonBefore) {
  ModeState hold = In(Mode::kHold);
  hold.reason = kLeftEstop;
  const ModeOutcome paused = Transition(hold, ModeEvent::kPause, {});
  EXPECT_EQ(paused.next.mode, Mode::kPaused);
  const ModeOutcome resumed = Transition(paused.next, ModeEvent::kResume, {});
  EXPECT_EQ(resumed.next.mode, Mode::kHold);
  EXPECT_EQ(resumed.next.reason, kLeftEstop);
  EXPECT_FALSE(resumed.entered) << "a resumed hold keeps the position it held";
  EXPECT_EQ(Transition(In(Mode::kRunning), ModeEvent::kPause, {.external_plant = true}).refused, kPauseExternalPlant);
}

TEST(ModeMachine, AnEstopStaysLatchedThroughTheWatchdogAndBrakesTheFirstStateAfterRearming) {
  // Estopped while stopped: the latch is kept, the mode too.
  const ModeOutcome estop = Transition(In(Mode::kStopped), ModeEvent::kEstop, {.external_plant = true});
  EXPECT_EQ(estop.next.mode, Mode::kStopped);
  EXPECT_TRUE(estop.next.estop_latched);
  // Clear re-arms the watchdog but not the estop; the first state brakes.
  const ModeOutcome rearmed = Transition(estop.next, ModeEvent::kClearEstop, {.external_plant = true});
  EXPECT_EQ(rearmed.next.mode, Mode::kWaiting);
  EXPECT_EQ(rearmed.next.reason, kWaitingEstopLatched);
  EXPECT_EQ(Transition(rearmed.next, ModeEvent::kMeasuredArrived, {}).next.mode, Mode::kEstop);
  // A second clear lifts the estop; the first state then holds.
  const ModeOutcome cleared = Transition(rearmed.next, ModeEvent::kClearEstop, {.external_plant = true});
  EXPECT_FALSE(cleared.next.estop_latched);
  EXPECT_TRUE(cleared.next.hold_on_arrival);
  const ModeOutcome first = Transition(cleared.next, ModeEvent::kMeasuredArrived, {});
  EXPECT_EQ(first.next.mode, Mode::kHold);
  EXPECT_EQ(first.next.reason, kLeftEstop);
  EXPECT_FALSE(first.next.hold_on_arrival);
}

// Until a latched estop has lasted the scene's estop_dwell, no clear lifts
// it: refused in estop and in a waiting external plant whose estop is
// latched. Re-arming a plant its watchdog stopped lifts no estop, so it is
// allowed; the estop stays latched. After the dwell the same clear holds.
TEST(ModeMachine, AClearWithinTheEstopsDwellIsRefusedAndTheEstopStaysLatched) {
  const ModeOutcome estop = Transition(In(Mode::kEstop), ModeEvent::kClearEstop, {.estop_dwelling = true});
  EXPECT_EQ(estop.refused, kClearWithinDwell);
  EXPECT_EQ(estop.next.mode, Mode::kEstop);
  EXPECT_TRUE(estop.next.estop_latched);
  ModeState waiting = In(Mode::kWaiting);
  waiting.estop_latched = true;
  waiting.reason = kWaitingEstopLatched;
  const ModeOutcome held = Transition(waiting, ModeEvent::kClearEstop, {.external_plant = true, .estop_dwelling = true});
  EXPECT_EQ(held.refused, kClearWithinDwell);
  EXPECT_TRUE(held.next.estop_latched);
  ModeState stopped = In(Mode::kStopped);
  stopped.estop_latched = true;
  const ModeOutcome rearmed =
      Transition(stopped, ModeEvent::kClearEstop, {.external_plant = true, .estop_dwelling = true});
  EXPECT_EQ(rearmed.refused, nullptr);
  EXPECT_EQ(rearmed.next.mode, Mode::kWaiting);
  EXPECT_TRUE(rearmed.next.estop_latched);
  const ModeOutcome after = Transition(In(Mode::kEstop), ModeEvent::kClearEstop, {.estop_dwelling = false});
  EXPECT_EQ(after.refused, nullptr);
  EXPECT_EQ(after.next.mode, Mode::kHold);
  EXPECT_FALSE(after.next.estop_latched);
}

TEST(ModeMachine, AClearInTheEstopsOwnTickIsRefusedInEveryMode) {
  for (const Mode m : kModes) {
    const ModeOutcome out = Transition(In(m), ModeEvent::kClearEstop, {.estop_this_tick = true});
    EXPECT_EQ(out.refused, kClearWithEstop) << ToString(m);
    EXPECT_EQ(out.next.mode, m) << ToString(m);
  }
}

TEST(ModeMachine, FaultKeepsTheLatchAndRefusesAnEstopUntilReset) {
  ModeState faulted = Transition(In(Mode::kEstop), ModeEvent::kFault, {.fault = "the energy left its bound"}).next;
  EXPECT_EQ(faulted.reason, std::string("the energy left its bound"));
  EXPECT_TRUE(faulted.estop_latched);
  EXPECT_EQ(Transition(faulted, ModeEvent::kEstop, {}).refused, kEstopWhileFaulted);
  EXPECT_EQ(Transition(faulted, ModeEvent::kReset, {}).next.mode, Mode::kEstop);
}

TEST(ModeMachine, StartWaitsForAnExternalPlantAndHoldsForAnExternalController) {
  EXPECT_EQ(Transition({}, ModeEvent::kStart, {}).next.mode, Mode::kRunning);
  EXPECT_EQ(Transition({}, ModeEvent::kStart, {.external_plant = true}).next.reason, kWaitingForState);
  EXPECT_EQ(Transition({}, ModeEvent::kStart, {.external_controller = true}).next.reason, kNoTorqueYet);
}

TEST(ModeMachine, AMeasuredStateAfterTheSetpointsStoppedHolds) {
  const ModeOutcome out = Transition(In(Mode::kWaiting), ModeEvent::kMeasuredArrived,
                                     {.external_plant = true, .setpoints_timed_out = true});
  EXPECT_EQ(out.next.mode, Mode::kHold);
  EXPECT_EQ(out.next.reason, kSetpointsTimedOut);
}

TEST(ModeMachine, CommandsOnlyWhileRunningHoldingOrBraking) {
  for (const Mode m : kModes) {
    EXPECT_EQ(Commands(m), m == Mode::kRunning || m == Mode::kHold || m == Mode::kEstop) << ToString(m);
  }
}

}  // namespace
}  // namespace lagrange
