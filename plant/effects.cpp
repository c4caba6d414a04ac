#include "plant/effects.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace lagrange {
namespace {

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
  return std::nullopt;
}

Effects::Effects(EffectsConfig config, int n)
    : config_(std::move(config)),
      terms_(config_.terms()),
      flags_{config_.gravity,     config_.coriolis,
             config_.damping.has_value(), config_.friction.has_value(),
             config_.limits.has_value(),  !config_.disturbance.empty(),
             config_.saturation.has_value()},
      passes_command_through_(!config_.saturation && config_.disturbance.empty() && !config_.damping &&
                              !config_.friction && !config_.limits) {
  if (auto e = ValidateEffects(config_, n)) throw std::invalid_argument(e->key + ": " + e->message);
}

void Effects::ComputeGeneralizedForce(double t, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, VecRef tau) {
  Saturate(tau_cmd, tau);
  AddDisturbance(t, tau);
  AddDamping(qd, tau);
  AddFriction(qd, tau);
  AddLimits(q, qd, tau);
}

// The stages loop over the joints by index: n is small (1 to a few tens), where
// Eigen's vectorised loops cost more in set-up than they save.
void Effects::Saturate(ConstVecRef tau_cmd, VecRef tau) {
  const int n = static_cast<int>(tau.size());
  if (!config_.saturation) {
    for (int i = 0; i < n; ++i) tau[i] = tau_cmd[i];
    return;
  }
  ++counts_.saturation;
  const VectorXd& max = *config_.saturation;
  for (int i = 0; i < n; ++i) tau[i] = std::min(std::max(tau_cmd[i], -max[i]), max[i]);
}

void Effects::AddDisturbance(double t, VecRef tau) {
  if (config_.disturbance.empty()) return;
  ++counts_.disturbance;
  for (const Push& p : config_.disturbance) {
    if (t >= p.start && t < p.start + p.duration) {
      for (int i = 0; i < tau.size(); ++i) tau[i] += p.tau[i];
    }
  }
}

void Effects::AddDamping(ConstVecRef qd, VecRef tau) {
  if (!config_.damping) return;
  ++counts_.damping;
  const VectorXd& b = *config_.damping;
  for (int i = 0; i < tau.size(); ++i) tau[i] -= b[i] * qd[i];
}

void Effects::AddFriction(ConstVecRef qd, VecRef tau) {
  if (!config_.friction) return;
  ++counts_.friction;
  const CoulombFriction& f = *config_.friction;
  for (int i = 0; i < tau.size(); ++i) tau[i] -= f.coulomb[i] * std::tanh(qd[i] / f.velocity_scale);
}

void Effects::AddLimits(ConstVecRef q, ConstVecRef qd, VecRef tau) {
  if (!config_.limits) return;
  ++counts_.limits;
  for (int i = 0; i < tau.size(); ++i) tau[i] += LimitForce(*config_.limits, i, q[i], qd[i]);
}

void Effects::AddLimits(ConstVecRef q, ConstVecRef qd, VecRef tau, VecRef springs) {
  if (!config_.limits) return;
  ++counts_.limits;
  for (int i = 0; i < tau.size(); ++i) {
    tau[i] += LimitForce(*config_.limits, i, q[i], qd[i]);
    springs[i] += LimitSpring(*config_.limits, i, q[i]);
  }
}

double Effects::DissipatedPower(ConstVecRef q, ConstVecRef qd) const {
  double p = 0.0;
  if (config_.damping) p += qd.dot(config_.damping->cwiseProduct(qd));
  if (config_.friction) {
    const CoulombFriction& f = *config_.friction;
    for (int i = 0; i < qd.size(); ++i) p += qd[i] * f.coulomb[i] * std::tanh(qd[i] / f.velocity_scale);
  }
  if (config_.limits) {
    for (int i = 0; i < qd.size(); ++i) {
      p -= qd[i] * (LimitForce(*config_.limits, i, q[i], qd[i]) - LimitSpring(*config_.limits, i, q[i]));
    }
  }
  return p;
}

double Effects::LimitPotentialEnergy(ConstVecRef q) const {
  if (!config_.limits) return 0.0;
  double e = 0.0;
  for (int i = 0; i < q.size(); ++i) {
    const double f = LimitSpring(*config_.limits, i, q[i]);
    e += 0.5 * f * f / config_.limits->stiffness;
  }
  return e;
}

}  // namespace lagrange
