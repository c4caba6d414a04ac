#include "plant/effects.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace lagrange {
namespace {

// Gravity and Coriolis need no parameters; the others are configured when given.
bool IsConfigured(const EffectsConfig& c, EffectKind kind) {
  switch (kind) {
    case EffectKind::kGravity:
    case EffectKind::kCoriolis: return true;
    case EffectKind::kDamping: return c.damping.has_value();
    case EffectKind::kFriction: return c.friction.has_value();
    case EffectKind::kLimits: return c.limits.has_value();
    case EffectKind::kSaturation: return c.saturation.has_value();
    case EffectKind::kDisturbance: return !c.disturbance.empty();
  }
  return false;
}

// What the config gives, less config.off.
EffectFlags InitialFlags(const EffectsConfig& c) {
  EffectFlags f{.gravity = c.gravity,
                .coriolis = c.coriolis,
                .damping = c.damping.has_value(),
                .friction = c.friction.has_value(),
                .limits = c.limits.has_value(),
                .disturbance = !c.disturbance.empty(),
                .saturation = c.saturation.has_value()};
  for (EffectKind kind : c.off) FlagOf(f, kind) = false;
  return f;
}

// No force stage on: tau = tau_cmd.
bool PassesCommandThrough(const EffectFlags& f) {
  return !f.saturation && !f.disturbance && !f.damping && !f.friction && !f.limits;
}

std::optional<EffectsError> CheckVector(const std::string& key, const VectorXd& v, int n, bool strictly_positive) {
  if (v.size() != n) {
    return EffectsError{key,
                        "expected " + std::to_string(n) + " values (one per joint), got " + std::to_string(v.size())};
  }
  for (int i = 0; i < n; ++i) {
    const bool ok = std::isfinite(v[i]) && (strictly_positive ? v[i] > 0.0 : v[i] >= 0.0);
    if (!ok) {
      std::ostringstream os;
      os << "expected " << (strictly_positive ? "positive" : "non-negative") << " finite values, got " << v[i]
         << " at index " << i;
      return EffectsError{key, os.str()};
    }
  }
  return std::nullopt;
}

std::optional<EffectsError> CheckScalar(const std::string& key, double x, bool strictly_positive) {
  if (std::isfinite(x) && (strictly_positive ? x > 0.0 : x >= 0.0)) return std::nullopt;
  std::ostringstream os;
  os << "expected a " << (strictly_positive ? "positive" : "non-negative") << " number, got " << x;
  return EffectsError{key, os.str()};
}

// One-sided spring-damper force of one joint past its limits (0 inside).
double LimitForce(const JointLimits& l, int i, double q, double qd) {
  if (q > l.upper[i]) return std::min(0.0, -l.stiffness * (q - l.upper[i]) - l.damping * qd);
  if (q < l.lower[i]) return std::max(0.0, -l.stiffness * (q - l.lower[i]) - l.damping * qd);
  return 0.0;
}

// The spring part of LimitForce: −k × penetration.
double LimitSpring(const JointLimits& l, int i, double q) {
  if (q > l.upper[i]) return -l.stiffness * (q - l.upper[i]);
  if (q < l.lower[i]) return -l.stiffness * (q - l.lower[i]);
  return 0.0;
}

}  // namespace

const char* NotConfiguredReason(EffectKind kind) {
  switch (kind) {
    case EffectKind::kDamping:
      return "effect damping has no coefficients under effects (give them there; list it in effects.off to start it "
             "off)";
    case EffectKind::kFriction:
      return "effect friction has no coefficients under effects (give them there; list it in effects.off to start it "
             "off)";
    case EffectKind::kLimits:
      return "effect limits has no joint limits under effects (give them there; list it in effects.off to start it "
             "off)";
    case EffectKind::kSaturation:
      return "effect saturation has no torque bounds under effects (give them there; list it in effects.off to start "
             "it off)";
    case EffectKind::kDisturbance:
      return "effect disturbance has no pushes under effects (give them there; list it in effects.off to start it off)";
    case EffectKind::kGravity:
    case EffectKind::kCoriolis: break;  // always configured
  }
  return "this effect is always available";
}

std::optional<EffectsError> ValidateEffects(const EffectsConfig& c, int n) {
  if (c.damping) {
    if (auto e = CheckVector("damping", *c.damping, n, false)) return e;
  }
  if (c.friction) {
    if (auto e = CheckVector("friction.coulomb", c.friction->coulomb, n, false)) return e;
    if (auto e = CheckScalar("friction.velocity_scale", c.friction->velocity_scale, true)) return e;
  }
  if (c.limits) {
    const JointLimits& l = *c.limits;
    for (const auto& [key, v] : {std::pair{"limits.lower", &l.lower}, std::pair{"limits.upper", &l.upper}}) {
      if (v->size() != n) {
        return EffectsError{
            key, "expected " + std::to_string(n) + " values (one per joint), got " + std::to_string(v->size())};
      }
    }
    for (int i = 0; i < n; ++i) {
      if (std::isnan(l.lower[i]) || std::isnan(l.upper[i]) || !(l.lower[i] < l.upper[i])) {
        std::ostringstream os;
        os << "expected lower < upper at index " << i << ", got " << l.lower[i] << " and " << l.upper[i];
        return EffectsError{"limits", os.str()};
      }
    }
    if (auto e = CheckScalar("limits.stiffness", l.stiffness, true)) return e;
    if (auto e = CheckScalar("limits.damping", l.damping, false)) return e;
  }
  if (c.saturation) {
    if (auto e = CheckVector("saturation", *c.saturation, n, true)) return e;
  }
  for (std::size_t k = 0; k < c.disturbance.size(); ++k) {
    const Push& p = c.disturbance[k];
    const std::string key = "disturbance[" + std::to_string(k) + "]";
    if (!std::isfinite(p.start)) return EffectsError{key + ".start", "expected a finite time in s"};
    if (auto e = CheckScalar(key + ".duration", p.duration, true)) return e;
    if (p.tau.size() != n) {
      return EffectsError{key + ".tau", "expected " + std::to_string(n) + " values (one per joint), got " +
                                            std::to_string(p.tau.size())};
    }
    if (!p.tau.allFinite()) return EffectsError{key + ".tau", "expected finite values"};
  }
  // An effect listed off could never be switched on without its parameters.
  for (EffectKind kind : c.off) {
    if (!IsConfigured(c, kind)) {
      return EffectsError{"off", "expected effects whose parameters are given, got " + std::string(ToString(kind))};
    }
  }
  return std::nullopt;
}

Effects::Effects(EffectsConfig config, int n)
    : config_(std::move(config)), flags_(InitialFlags(config_)), passes_command_through_(PassesCommandThrough(flags_)) {
  if (auto e = ValidateEffects(config_, n)) throw std::invalid_argument(e->key + ": " + e->message);
  terms_ = {flags_.gravity, flags_.coriolis};
}

bool Effects::Configured(EffectKind kind) const { return IsConfigured(config_, kind); }

bool Effects::SetEnabled(EffectKind kind, bool on) {
  // A stage switched on without its parameters would read an empty optional;
  // a kind out of range (a cast from the wire) names no flag.
  if ((on && !Configured(kind)) || static_cast<int>(kind) >= kNumEffectKinds) return false;
  FlagOf(flags_, kind) = on;
  terms_ = {flags_.gravity, flags_.coriolis};
  passes_command_through_ = PassesCommandThrough(flags_);
  return true;
}

void Effects::ComputeGeneralizedForce(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef tau) {
  Saturate(tau_cmd, tau);
  AddDisturbance(t, tau);
  AddDamping(qd, tau);
  AddFriction(qd, tau);
  AddLimits(q, qd, tau);
}

void Effects::ComputeGeneralizedForceDerivatives(ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef dtau_dq,
                                                 VecRef dtau_dqd, VecRef dtau_dcmd) const {
  const int n = static_cast<int>(q.size());
  for (int i = 0; i < n; ++i) {
    dtau_dq[i] = 0.0;
    dtau_dqd[i] = 0.0;
    dtau_dcmd[i] = 1.0;
  }
  if (flags_.saturation) {
    const VectorXd& max = *config_.saturation;
    for (int i = 0; i < n; ++i) dtau_dcmd[i] = std::abs(tau_cmd[i]) <= max[i] ? 1.0 : 0.0;
  }
  if (flags_.damping) {
    for (int i = 0; i < n; ++i) dtau_dqd[i] -= (*config_.damping)[i];
  }
  if (flags_.friction) {
    const CoulombFriction& f = *config_.friction;
    for (int i = 0; i < n; ++i) {
      const double t = std::tanh(qd[i] / f.velocity_scale);
      dtau_dqd[i] -= f.coulomb[i] / f.velocity_scale * (1.0 - t * t);
    }
  }
  if (flags_.limits) {
    const JointLimits& l = *config_.limits;
    for (int i = 0; i < n; ++i) {
      // Where LimitForce takes its spring-damper branch (strictly nonzero).
      const bool upper = q[i] > l.upper[i] && -l.stiffness * (q[i] - l.upper[i]) - l.damping * qd[i] < 0.0;
      const bool lower = q[i] < l.lower[i] && -l.stiffness * (q[i] - l.lower[i]) - l.damping * qd[i] > 0.0;
      if (upper || lower) {
        dtau_dq[i] -= l.stiffness;
        dtau_dqd[i] -= l.damping;
      }
    }
  }
}

// The stages loop over the joints by index: n is small (1 to a few tens), where
// Eigen's vectorised loops cost more in set-up than they save.
void Effects::Saturate(ConstVecRef tau_cmd, VecRef tau) {
  const int n = static_cast<int>(tau.size());
  if (!flags_.saturation) {
    for (int i = 0; i < n; ++i) tau[i] = tau_cmd[i];
    return;
  }
  ++counts_.saturation;
  const VectorXd& max = *config_.saturation;
  for (int i = 0; i < n; ++i) tau[i] = std::min(std::max(tau_cmd[i], -max[i]), max[i]);
}

void Effects::AddDisturbance(double t, VecRef tau) {
  if (!flags_.disturbance) return;
  ++counts_.disturbance;
  for (const Push& p : config_.disturbance) {
    if (t >= p.start && t < p.start + p.duration) {
      for (int i = 0; i < tau.size(); ++i) tau[i] += p.tau[i];
    }
  }
}

void Effects::AddDamping(ConstVecRef qd, VecRef tau) {
  if (!flags_.damping) return;
  ++counts_.damping;
  const VectorXd& b = *config_.damping;
  for (int i = 0; i < tau.size(); ++i) tau[i] -= b[i] * qd[i];
}

void Effects::AddFriction(ConstVecRef qd, VecRef tau) {
  if (!flags_.friction) return;
  ++counts_.friction;
  const CoulombFriction& f = *config_.friction;
  for (int i = 0; i < tau.size(); ++i) tau[i] -= f.coulomb[i] * std::tanh(qd[i] / f.velocity_scale);
}

void Effects::AddLimits(ConstVecRef q, ConstVecRef qd, VecRef tau) {
  if (!flags_.limits) return;
  ++counts_.limits;
  for (int i = 0; i < tau.size(); ++i) tau[i] += LimitForce(*config_.limits, i, q[i], qd[i]);
}

void Effects::AddLimits(ConstVecRef q, ConstVecRef qd, VecRef tau, VecRef springs) {
  if (!flags_.limits) return;
  ++counts_.limits;
  for (int i = 0; i < tau.size(); ++i) {
    tau[i] += LimitForce(*config_.limits, i, q[i], qd[i]);
    springs[i] += LimitSpring(*config_.limits, i, q[i]);
  }
}

double Effects::DissipatedPower(ConstVecRef q, ConstVecRef qd) const {
  double p = 0.0;
  if (flags_.damping) p += qd.dot(config_.damping->cwiseProduct(qd));
  if (flags_.friction) {
    const CoulombFriction& f = *config_.friction;
    for (int i = 0; i < qd.size(); ++i) p += qd[i] * f.coulomb[i] * std::tanh(qd[i] / f.velocity_scale);
  }
  if (flags_.limits) {
    for (int i = 0; i < qd.size(); ++i) {
      p -= qd[i] * (LimitForce(*config_.limits, i, q[i], qd[i]) - LimitSpring(*config_.limits, i, q[i]));
    }
  }
  return p;
}

double Effects::LimitPotentialEnergy(ConstVecRef q) const {
  if (!flags_.limits) return 0.0;
  double e = 0.0;
  for (int i = 0; i < q.size(); ++i) {
    const double f = LimitSpring(*config_.limits, i, q[i]);
    e += 0.5 * f * f / config_.limits->stiffness;
  }
  return e;
}

}  // namespace lagrange
