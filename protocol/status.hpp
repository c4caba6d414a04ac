#pragma once
// What a status_t says, and how much of it fits: the descriptions lagranged
// writes of each instance's integrator and effects, the size check that
// keeps a status within one datagram, and the readers a client uses to take
// an instance's joint names, mode reason and settings out of a status
// without trusting its counts.
//
// Every string a reader returns came from the bus and is escaped
// (base/escape.hpp) for printing.

#include <lagrange/status_t.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/vocabulary.hpp"

namespace lagrange {

// The longest last_rejection and last_command_error a daemon writes, bytes.
inline constexpr std::size_t kMaxStatusReasonBytes = 199;
// Bytes of a joint name kept in a status (before escaping): a URDF's names
// are the file's, of any length.
inline constexpr std::size_t kMaxJointNameBytes = 60;

// True when a status carrying these instances and joint names, with every
// reason and description at the longest it can be, fits in one datagram.
// lagranged refuses a scene whose instances alone would not fit.
bool StatusFits(const std::vector<std::string>& instances, const std::vector<std::int32_t>& dofs,
                const std::vector<std::string>& joints);

// The integrator's name (telemetry_t.integrator): lagrange's (ToString of
// config.type), "none" for an external plant, and for a plant MuJoCo steps
// (`mujoco` set) MuJoCo's own, "mujoco-euler", "mujoco-rk4" or
// "mujoco-implicit": lagrange's integrator then never runs.
std::string_view IntegratorName(IntegratorType type, bool external_plant,
                                std::optional<MujocoIntegrator> mujoco = std::nullopt);
// status_t.instance_integrators: "rk4", "rk4 x4", "dopri5 rtol=1e-08 atol=1e-10
// max_steps=200", "mujoco-implicit x4"; "none" for an external plant.
std::string IntegratorDescription(const IntegratorConfig& config, bool external_plant,
                                  std::optional<MujocoIntegrator> mujoco = std::nullopt);
// status_t.instance_effects: the effects on, comma-separated in EffectKind order.
std::string EffectsDescription(const EffectFlags& flags);

// Every instance's joint names from a status (status_t.joint_names: instance
// after instance, instance_dofs[i] each), escaped for printing, one list per
// instance; empty (no lists) when the status carries no names or its counts
// do not add up (Σ instance_dofs ≠ num_joints, sizes that disagree with
// their counts): names are never attributed to the wrong instance.
std::vector<std::vector<std::string>> JointNamesByInstance(const status_t& status);
// The joint names a status gives for `instance` (JointNamesByInstance); empty
// when the status names no such instance, carries no names, or its counts do
// not add up.
std::vector<std::string> JointNamesIn(const status_t& status, const std::string& instance);

// Why a status says `instance` is in `mode` (status_t.instance_reasons),
// escaped; "" when the status names no such instance, gives it another mode
// (a status is sent at 10 Hz, a state every tick), or gives no reason.
std::string ModeReasonIn(const status_t& status, const std::string& instance, std::int8_t mode);

// How a status says `instance` is integrated and computed
// (status_t.instance_integrators, _methods, _effects, _forces), escaped;
// nullopt when the status names no such instance or its arrays do not match
// its count (an older daemon's status).
struct InstanceSettings {
  std::string integrator;  // "rk4", "rk4 x4", "dopri5 rtol=1e-08 atol=1e-10 max_steps=200", "none"
  std::string method;      // closed-form | lagrangian | recursive
  std::string effects;     // the effects on, comma-separated ("" for none)
  bool forces = false;     // publishing <NAME>_FORCES
};
std::optional<InstanceSettings> SettingsIn(const status_t& status, const std::string& instance);

// The p-th percentile (p in (0, 1]) by nearest rank: the ceil(p n)-th
// smallest of the n samples, always one that was measured; the rule of the
// status's wake-up latency and compute figures (and of bench/'s). NaN for no
// samples. Reorders `v` (nth_element), allocates nothing.
double NearestRankPercentile(std::span<double> v, double p);

}  // namespace lagrange
