#include "base/vocabulary.hpp"

#include <cmath>
#include <iterator>

#include "base/enum_names.hpp"

namespace lagrange {
namespace {

constexpr EnumName<Method> kMethodNames[] = {
    {Method::kClosedForm, "closed-form"},
    {Method::kLagrangian, "lagrangian"},
    {Method::kRecursive, "recursive"},
};

constexpr EnumName<IntegratorType> kIntegratorNames[] = {
    {IntegratorType::kExplicitEuler, "explicit-euler"},
    {IntegratorType::kSemiImplicitEuler, "semi-implicit-euler"},
    {IntegratorType::kRk4, "rk4"},
    {IntegratorType::kDormandPrince, "dopri5"},
    {IntegratorType::kVariational, "variational"},
};

constexpr EnumName<EffectKind> kEffectKindNames[] = {
    {EffectKind::kGravity, "gravity"},         {EffectKind::kCoriolis, "coriolis"},
    {EffectKind::kDamping, "damping"},         {EffectKind::kFriction, "friction"},
    {EffectKind::kLimits, "limits"},           {EffectKind::kSaturation, "saturation"},
    {EffectKind::kDisturbance, "disturbance"},
};
static_assert(std::size(kEffectKindNames) == kNumEffectKinds);

constexpr EnumName<ControllerType> kControllerNames[] = {
    {ControllerType::kNone, "none"},
    {ControllerType::kPd, "pd"},
    {ControllerType::kGravityCompensation, "gravity-compensation"},
    {ControllerType::kComputedTorque, "computed-torque"},
    {ControllerType::kCartPolePd, "cartpole-pd"},
    {ControllerType::kLqr, "lqr"},
    {ControllerType::kSwingUp, "swing-up"},
    {ControllerType::kExternal, "external"},
    {ControllerType::kCartesianImpedance, "cartesian-impedance"},
    {ControllerType::kOperationalSpace, "operational-space"},
    {ControllerType::kMpc, "mpc"},
};

}  // namespace

std::string_view ToString(Method method) { return NameOf(kMethodNames, method); }
std::optional<Method> ParseMethod(std::string_view name) { return ValueOf(kMethodNames, name); }
std::string MethodNames() { return NamesInWords(kMethodNames); }

std::string_view ToString(IntegratorType type) { return NameOf(kIntegratorNames, type); }
std::optional<IntegratorType> ParseIntegratorType(std::string_view name) { return ValueOf(kIntegratorNames, name); }
std::string IntegratorTypeNames() { return JoinedNames(kIntegratorNames); }

const char* CheckIntegratorConfig(const IntegratorConfig& c) {
  // Bounds keep a tick's work finite: substeps and max_steps multiply the
  // evaluations one call may make. NaN fails every comparison, so it is refused.
  if (c.substeps < 1 || c.substeps > 1000) return "integrator.substeps: expected 1 to 1000";
  if (!std::isfinite(c.rtol) || !(c.rtol > 0.0)) return "integrator.rtol: expected a finite number > 0";
  if (!std::isfinite(c.atol) || !(c.atol > 0.0)) return "integrator.atol: expected a finite number > 0";
  if (c.max_steps < 1 || c.max_steps > 10000000) return "integrator.max_steps: expected 1 to 10000000";
  if (!std::isfinite(c.newton_tol) || !(c.newton_tol > 0.0)) {
    return "integrator.newton_tol: expected a finite number > 0";
  }
  if (c.newton_max_iterations < 1 || c.newton_max_iterations > 1000) {
    return "integrator.newton_max_iterations: expected 1 to 1000";
  }
  return nullptr;
}

std::optional<MujocoIntegrator> ParseMujocoIntegrator(std::string_view name) {
  if (name == "euler" || name == "semi-implicit-euler") return MujocoIntegrator::kEuler;
  if (name == "rk4") return MujocoIntegrator::kRk4;
  if (name == "implicit") return MujocoIntegrator::kImplicit;
  return std::nullopt;
}

std::string_view ToString(MujocoIntegrator integrator) {
  switch (integrator) {
    case MujocoIntegrator::kEuler: return "euler";
    case MujocoIntegrator::kRk4: return "rk4";
    case MujocoIntegrator::kImplicit: return "implicit";
  }
  return "?";
}

std::string_view ToString(EffectKind kind) { return NameOf(kEffectKindNames, kind); }
std::optional<EffectKind> ParseEffectKind(std::string_view name) { return ValueOf(kEffectKindNames, name); }
std::string EffectKindNames() { return JoinedNames(kEffectKindNames); }

bool EffectFlags::on(EffectKind kind) const { return FlagOf(*this, kind); }

std::string_view ToString(ControllerType type) { return NameOf(kControllerNames, type); }
std::optional<ControllerType> ParseControllerType(std::string_view name) { return ValueOf(kControllerNames, name); }
std::string ControllerTypeNames() { return JoinedNames(kControllerNames); }

bool IsTaskSpace(ControllerType type) {
  return type == ControllerType::kCartesianImpedance || type == ControllerType::kOperationalSpace;
}

}  // namespace lagrange
