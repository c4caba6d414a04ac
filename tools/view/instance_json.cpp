#include "tools/view/instance_json.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "base/escape.hpp"
#include "controllers/factory.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"

namespace lagrange::cli::view {
namespace {

using nlohmann::json;

constexpr double kTaskCurrent = 0.1;  // s of simulated time between a state and its controller's task state

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

bool FollowsJointSetpoint(const state_t& s) {
  const std::optional<ControllerType> type = ParseControllerType(s.controller);
  if (type && IsTaskSpace(*type)) return false;
  return !(type == ControllerType::kExternal && s.mode == state_t::MODE_RUNNING);
}

json InstanceJson(const ViewInstance& instance, const ViewModels& models, const state_t& s, double age,
                  const task_state_t* task) {
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
  if (AllFinite(s.q)) j["poses"] = model.Poses(Eigen::Map<const VectorXd>(s.q.data(), s.num_dofs));
  else j["note"] = "non-finite q: not drawn";
  if (FollowsJointSetpoint(s) && AllFinite(s.q_des))
    j["ghost"] = model.Poses(Eigen::Map<const VectorXd>(s.q_des.data(), s.num_dofs));
  if (task != nullptr && TaskIsCurrent(s, *task)) j["target"] = TargetJson(*task);
  return j;
}

}  // namespace lagrange::cli::view
