#pragma once
// What lagrangectl view sends the page of one instance at one moment, live
// (live.hpp) or from a log (log_view.hpp): its state, the poses of its frames
// at q, and what it is steered to:
//   ghost   the poses at q_des, where a controller follows that joint setpoint
//   target  a task-space controller's target frame (<NAME>_TASK), as published
//   plan    an mpc controller's latest plan (<NAME>_MPC): the path of every
//           frame through the plan's knots (poses at each knot's q, by the
//           same kinematics), drawn as polylines: where the optimiser
//           predicts the robot goes.
// A floating base's frames are placed in the world by its base's pose
// (<NAME>_BASE, base_state_t) of the state's run within 0.1 s of simulated
// time of it (the daemon publishes both every tick); without one the instance
// is named but not drawn (a note says why), never drawn at a made-up pose.
// Its ghost rides on the same base: the joints' setpoint, where the base is.
// q_des is the joint setpoint lagranged holds (state_t). A task-space
// controller does not follow it (its target is a frame's pose), nor does
// the external controller while it applies streamed torques (running): there
// q_des is only where the instance would be held, and no ghost is drawn for it.
// Every string from the bus is escaped (base/escape.hpp); the page puts text
// in the document only as text.

#include <lagrange/base_state_t.hpp>
#include <lagrange/mpc_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/task_state_t.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tools/view/view_model.hpp"

namespace lagrange::cli::view {

// One instance the view knows of: its daemon's channel prefix, its name, and its model (an index into the
// view's models; −1 when the scene has none of that name).
struct ViewInstance {
  std::string prefix, name;
  int model = -1;
  std::string Label() const { return prefix.empty() ? name : prefix + " " + name; }
};

using ViewModels = std::vector<std::unique_ptr<ViewModel>>;

// JSON text of `j`; bytes that are not UTF-8 (from the bus) become U+FFFD.
std::string Dump(const nlohmann::json& j);
// Numbers for JSON: null for a non-finite one (JSON has none).
nlohmann::json Numbers(const std::vector<double>& v);

// Whether `task` is the target of the controller `s` runs: the same run and controller, published within
// 0.1 s of simulated time of `s` (a controller switched away stops publishing it).
bool TaskIsCurrent(const state_t& s, const task_state_t& task);
// Whether a controller follows s.q_des (above): not a task-space controller, not `external` while running.
bool FollowsJointSetpoint(const state_t& s);

// Whether `base` is the base of the instance in state `s`: the same run, published within 0.1 s of simulated time.
bool BaseIsCurrent(const state_t& s, const base_state_t& base);
// The base's pose: p and the rotation of its quaternion (x, y, z, w), normalised; nullopt when a number is not
// finite or the quaternion's norm is off 1 by more than kUnitQuaternionTolerance (protocol/setpoint_check.hpp).
std::optional<BasePose> BasePoseOf(const base_state_t& base);

// Whether `plan` is what the controller `s` runs follows now: the same run and controller, taken no later
// than s (within a tick), and followed, its last knot not yet past.
bool PlanIsCurrent(const state_t& s, const mpc_t& plan);
// The plan's frame paths: {sequence, status, followed, age, t [knots], paths [frame][knot] = [x, y, z]}; null
// when its knots are not `model`'s state (2 n) or not finite.
nlohmann::json PlanJson(const ViewModel& model, const mpc_t& plan);

// Instance `instance` at state `s`, `age` s after it was published (or logged), with its latest task state,
// mpc plan and, for a floating base, base state (null: none): {model, name, run, mode, controller, t, tick,
// age, q, q_des, tau, poses, ghost, target, plan, base, note}; base {p, q (x, y, z, w), tick, t}, as published.
nlohmann::json InstanceJson(const ViewInstance& instance, const ViewModels& models, const state_t& s, double age,
                            const task_state_t* task, const mpc_t* plan = nullptr, const base_state_t* base = nullptr);

}  // namespace lagrange::cli::view
