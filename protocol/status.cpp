#include "protocol/status.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "base/escape.hpp"
#include "protocol/bus.hpp"
#include "protocol/wire.hpp"

namespace lagrange {
namespace {

// The longest reason a status can carry for one instance's mode (the tick's
// static reasons and faults are shorter).
constexpr std::size_t kLongestModeReason = 64;

}  // namespace

bool StatusFits(const std::vector<std::string>& instances, const std::vector<std::int32_t>& dofs,
                const std::vector<std::string>& joints) {
  status_t s{};
  // A reason at its longest (kMaxStatusReasonBytes, written escaped); a tick's
  // command error, an instance name (<= 48 bytes) + ": " + one of the tick's
  // short static reasons, is shorter.
  s.last_rejection.assign(kMaxStatusReasonBytes, 'x');
  s.last_command_error = s.last_rejection;
  s.num_instances = static_cast<std::int32_t>(instances.size());
  s.instance_names = instances;
  s.instance_modes.assign(instances.size(), 0);
  s.instance_dofs = dofs;
  s.instance_reasons.assign(instances.size(), std::string(kLongestModeReason, 'x'));
  // The longest each description can be (IntegratorDescription, EffectsDescription).
  s.instance_integrators.assign(instances.size(), std::string(80, 'x'));
  s.instance_methods.assign(instances.size(), std::string(11, 'x'));
  s.instance_effects.assign(instances.size(), std::string(64, 'x'));
  s.instance_forces.assign(instances.size(), false);
  s.num_joints = static_cast<std::int32_t>(joints.size());
  s.joint_names = joints;
  // The most channels a signed run lists, each name at LCM's longest (63 bytes).
  s.num_unauthenticated_channels = kMaxStatusChannels;
  s.unauthenticated_channels.assign(kMaxStatusChannels, std::string(63, 'x'));
  s.unauthenticated_counts.assign(kMaxStatusChannels, 0);
  return s.getEncodedSize() <= static_cast<int>(kMaxMessageSize);
}

std::string_view IntegratorName(IntegratorType type, bool external_plant, std::optional<MujocoIntegrator> mujoco) {
  if (external_plant) return "none";
  if (mujoco) {
    switch (*mujoco) {
      case MujocoIntegrator::kEuler: return "mujoco-euler";
      case MujocoIntegrator::kRk4: return "mujoco-rk4";
      case MujocoIntegrator::kImplicit: return "mujoco-implicit";
    }
  }
  return ToString(type);
}

std::string IntegratorDescription(const IntegratorConfig& c, bool external_plant,
                                  std::optional<MujocoIntegrator> mujoco) {
  std::string text(IntegratorName(c.type, external_plant, mujoco));
  if (external_plant) return text;
  if (!mujoco && c.type == IntegratorType::kDormandPrince) {
    char settings[96];
    std::snprintf(settings, sizeof settings, " rtol=%g atol=%g max_steps=%d", c.rtol, c.atol, c.max_steps);
    text += settings;
  }
  if (c.substeps > 1) text += " x" + std::to_string(c.substeps);
  return text;
}

std::string EffectsDescription(const EffectFlags& flags) {
  std::string text;
  for (int k = 0; k < kNumEffectKinds; ++k) {
    const auto kind = static_cast<EffectKind>(k);
    if (!flags.on(kind)) continue;
    if (!text.empty()) text += ',';
    text += ToString(kind);
  }
  return text;
}

std::vector<std::vector<std::string>> JointNamesByInstance(const status_t& status) {
  const auto instances = static_cast<std::size_t>(std::max(status.num_instances, 0));
  if (status.instance_names.size() != instances || status.instance_dofs.size() != instances ||
      status.joint_names.size() != static_cast<std::size_t>(std::max(status.num_joints, 0))) {
    return {};
  }
  std::size_t total = 0;
  for (const std::int32_t n : status.instance_dofs) {
    if (n < 0) return {};
    total += static_cast<std::size_t>(n);
  }
  if (total != status.joint_names.size()) return {};  // names that cannot be attributed are not attributed
  std::vector<std::vector<std::string>> names(instances);
  std::size_t first = 0;
  for (std::size_t i = 0; i < instances; ++i) {
    const auto n = static_cast<std::size_t>(status.instance_dofs[i]);
    for (std::size_t j = first; j < first + n; ++j) names[i].push_back(Escape(status.joint_names[j], 80));
    first += n;
  }
  return names;
}

std::vector<std::string> JointNamesIn(const status_t& status, const std::string& instance) {
  std::vector<std::vector<std::string>> names = JointNamesByInstance(status);
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (status.instance_names[i] == instance) return std::move(names[i]);
  }
  return {};
}

std::string ModeReasonIn(const status_t& status, const std::string& instance, std::int8_t mode) {
  const std::size_t count =
      std::min({status.instance_names.size(), status.instance_modes.size(), status.instance_reasons.size()});
  for (std::size_t i = 0; i < count; ++i) {
    if (status.instance_names[i] == instance) {
      return status.instance_modes[i] == mode ? Escape(status.instance_reasons[i]) : "";
    }
  }
  return "";
}

std::optional<InstanceSettings> SettingsIn(const status_t& status, const std::string& instance) {
  const std::size_t count = status.instance_names.size();
  if (status.instance_integrators.size() != count || status.instance_methods.size() != count ||
      status.instance_effects.size() != count || status.instance_forces.size() != count) {
    return std::nullopt;
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (status.instance_names[i] != instance) continue;
    return InstanceSettings{Escape(status.instance_integrators[i], 80), Escape(status.instance_methods[i], 40),
                            Escape(status.instance_effects[i], 120), status.instance_forces[i] != 0};
  }
  return std::nullopt;
}

double NearestRankPercentile(std::span<double> v, double p) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
  const auto k = static_cast<std::ptrdiff_t>(std::clamp<std::size_t>(rank, 1, v.size()) - 1);
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

}  // namespace lagrange
