#include "tools/view/instance_json.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

#include <Eigen/Geometry>

#include "base/escape.hpp"
#include "controllers/factory.hpp"
#include "protocol/channels.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "protocol/setpoint_check.hpp"

namespace lagrange::cli::view {
namespace {

using nlohmann::json;

constexpr double kTaskCurrent = 0.1;  // s of simulated time between a state and its controller's task state
constexpr double kBaseCurrent = 0.1;  // s of simulated time between a state and its base's state

bool AllFinite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// A task-space controller's target pose as the page draws it (a ghost frame): the frame's name, the
// target's position (m) and orientation (w, x, y, z), as the daemon published them; null when not finite.
json TargetJson(const task_state_t& task) {
  const auto finite = [](const auto& a) {
    return std::all_of(std::begin(a), std::end(a), [](double x) { return std::isfinite(x); });
  };
  if (!finite(task.position_des) || !finite(task.orientation_des)) return nullptr;
  return {{"frame", Escape(task.frame)},
          {"tick", task.tick},
          {"p", {task.position_des[0], task.position_des[1], task.position_des[2]}},
          {"q", {task.orientation_des[0], task.orientation_des[1], task.orientation_des[2], task.orientation_des[3]}}};
}

}  // namespace

std::string Dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

json Numbers(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(std::isfinite(x) ? json(x) : json(nullptr));
  return a;
}

bool TaskIsCurrent(const state_t& s, const task_state_t& task) {
  return task.run_id == s.run_id && task.controller == s.controller && std::abs(task.t - s.t) <= kTaskCurrent;
}

bool BaseIsCurrent(const state_t& s, const base_state_t& base) {
  return base.run_id == s.run_id && std::abs(base.t - s.t) <= kBaseCurrent;
}

std::optional<BasePose> BasePoseOf(const base_state_t& base) {
  const Eigen::Vector3d p(base.position[0], base.position[1], base.position[2]);
  Eigen::Quaterniond q(base.orientation[3], base.orientation[0], base.orientation[1], base.orientation[2]);
  if (!p.allFinite() || !q.coeffs().allFinite() || !(std::abs(q.norm() - 1.0) <= kUnitQuaternionTolerance))
    return std::nullopt;
  q.normalize();
  return BasePose{q.toRotationMatrix(), p};
}

bool PlanIsCurrent(const state_t& s, const mpc_t& plan) {
  constexpr double kTick = 1e-3;  // s: a plan is taken in a tick, its state published in the same one
  return plan.run_id == s.run_id && plan.controller == s.controller && plan.followed && plan.t <= s.t + kTick &&
         plan.num_knots > 0 && plan.knot_t.size() == static_cast<std::size_t>(plan.num_knots) &&
         s.t <= plan.knot_t.back();
}

json PlanJson(const ViewModel& model, const mpc_t& plan) {
  const int n = model.num_dofs();
  if (plan.num_states != 2 * n || plan.knot_x.size() != static_cast<std::size_t>(plan.num_knots)) return nullptr;
  json paths = json::array();
  for (int f = 0; f < model.kinematics().num_frames(); ++f) paths.push_back(json::array());
  for (const std::vector<double>& x : plan.knot_x) {
    if (x.size() != static_cast<std::size_t>(2 * n) || !AllFinite(x)) return nullptr;
    const json poses = model.Poses(Eigen::Map<const VectorXd>(x.data(), n));  // q of the knot's (q, qd)
    for (std::size_t f = 0; f < poses.size(); ++f) paths[f].push_back({poses[f][9], poses[f][10], poses[f][11]});
  }
  return {{"sequence", plan.plan},
          {"status", Escape(plan.status, 32)},
          {"followed", plan.followed},
          {"age", plan.age},
          {"t", Numbers(plan.knot_t)},
          {"paths", std::move(paths)}};
}

bool FollowsJointSetpoint(const state_t& s) {
  const std::optional<ControllerType> type = ParseControllerType(s.controller);
  if (type && IsTaskSpace(*type)) return false;
  return !(type == ControllerType::kExternal && s.mode == state_t::MODE_RUNNING);
}

json InstanceJson(const ViewInstance& instance, const ViewModels& models, const state_t& s, double age,
                  const task_state_t* task, const mpc_t* plan, const base_state_t* base) {
  json j = {{"model", instance.model},
            {"name", Escape(instance.Label())},
            {"run", RunIdText(s.run_id)},
            {"mode", ModeName(s.mode)},
            {"controller", Escape(s.controller)},
            {"t", s.t},
            {"tick", s.tick},
            {"age", age},
            {"q", Numbers(s.q)},
            {"q_des", Numbers(s.q_des)},
            {"tau", Numbers(s.tau)}};
  if (instance.model < 0) {
    j["note"] = "not in the scene: not drawn (give lagrangectl view the scene lagranged runs: --scene)";
    return j;
  }
  const ViewModel& model = *models[static_cast<std::size_t>(instance.model)];
  if (s.num_dofs != model.num_dofs()) {
    j["note"] = "its state has " + std::to_string(s.num_dofs) + " joints, the scene's model " +
                std::to_string(model.num_dofs()) + ": not drawn (another scene?)";
    return j;
  }
  BasePose at;  // a fixed base: the world's origin
  if (model.floating_base()) {
    if (base == nullptr || !BaseIsCurrent(s, *base)) {
      j["note"] = "no pose of its floating base (" +
                  Escape(InstanceChannel(instance.prefix, instance.name, kBaseSuffix)) + ") of this run yet: not drawn";
      return j;
    }
    const std::optional<BasePose> pose = BasePoseOf(*base);
    if (!pose) {
      j["note"] = "its base's pose is not finite or its quaternion not unit: not drawn";
      return j;
    }
    at = *pose;
    j["base"] = {{"p", {base->position[0], base->position[1], base->position[2]}},
                 {"q", {base->orientation[0], base->orientation[1], base->orientation[2], base->orientation[3]}},
                 {"tick", base->tick},
                 {"t", base->t}};
  }
  if (AllFinite(s.q))
    j["poses"] = model.Poses(Eigen::Map<const VectorXd>(s.q.data(), s.num_dofs), at);
  else j["note"] = "non-finite q: not drawn";
  if (FollowsJointSetpoint(s) && AllFinite(s.q_des))
    j["ghost"] = model.Poses(Eigen::Map<const VectorXd>(s.q_des.data(), s.num_dofs), at);
  if (task != nullptr && TaskIsCurrent(s, *task)) j["target"] = TargetJson(*task);
  if (plan != nullptr && PlanIsCurrent(s, *plan)) {
    if (json p = PlanJson(model, *plan); !p.is_null()) j["plan"] = std::move(p);
  }
  return j;
}

}  // namespace lagrange::cli::view
