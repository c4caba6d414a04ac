#include "plant/plant_factory.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "base/enum_names.hpp"
#include "plant/lagrangian.hpp"
#include "plant/mimic_dynamics.hpp"
#include "plant/recursive_dynamics.hpp"
#include "plant/spatial_dynamics.hpp"

namespace lagrange {
namespace {

constexpr EnumName<PlantType> kPlantNames[] = {
    {PlantType::kPendulum, "pendulum"}, {PlantType::kArm2, "arm2"}, {PlantType::kCartPole, "cartpole"},
    {PlantType::kChain, "chain"},       {PlantType::kUrdf, "urdf"},
};
constexpr EnumName<JointType> kJointNames[] = {
    {JointType::kRevolute, "revolute"},
    {JointType::kPrismatic, "prismatic"},
};
constexpr EnumName<PendulumBody> kBodyNames[] = {
    {PendulumBody::kPointMass, "point"},
    {PendulumBody::kRod, "rod"},
};

std::string FormatNumber(double x) {
  std::ostringstream os;
  os.precision(17);
  os << x;
  return os.str();
}

enum class Range { kPositive, kNonNegative, kFinite };

std::optional<SpecError> CheckRange(std::string_view key, double value, Range range, std::string_view unit) {
  const bool ok = std::isfinite(value) && (range == Range::kFinite || (range == Range::kPositive && value > 0.0) ||
                                           (range == Range::kNonNegative && value >= 0.0));
  if (ok) return std::nullopt;
  const char* what = range == Range::kPositive      ? "a positive number"
                     : range == Range::kNonNegative ? "a number >= 0"
                                                    : "a finite number";
  return SpecError{std::string(key),
                   "expected " + std::string(what) + " (" + std::string(unit) + "), got " + FormatNumber(value)};
}

// One numeric parameter: its name, where it lives, its range and unit.
template <class P>
struct Field {
  std::string_view name;
  double P::*member;
  Range range;
  std::string_view unit;
};

template <class P, std::size_t N>
std::optional<SpecError> SetField(P& p, const Field<P> (&fields)[N], std::string_view name, double value) {
  for (const Field<P>& f : fields) {
    if (f.name != name) continue;
    if (auto err = CheckRange(name, value, f.range, f.unit)) return err;
    p.*(f.member) = value;
    return std::nullopt;
  }
  return SpecError{std::string(name), "unknown parameter"};
}

constexpr Field<PendulumParams> kPendulumFields[] = {
    {"m", &PendulumParams::m, Range::kPositive, "kg"},
    {"L", &PendulumParams::L, Range::kPositive, "m"},
    {"g", &PendulumParams::g, Range::kNonNegative, "m/s²"},
};
constexpr Field<Arm2Params> kArm2Fields[] = {
    {"m1", &Arm2Params::m1, Range::kPositive, "kg"},    {"m2", &Arm2Params::m2, Range::kPositive, "kg"},
    {"L1", &Arm2Params::L1, Range::kPositive, "m"},     {"L2", &Arm2Params::L2, Range::kPositive, "m"},
    {"g", &Arm2Params::g, Range::kNonNegative, "m/s²"},
};
constexpr Field<CartPoleParams> kCartPoleFields[] = {
    {"mc", &CartPoleParams::mc, Range::kPositive, "kg"},
    {"mp", &CartPoleParams::mp, Range::kPositive, "kg"},
    {"l", &CartPoleParams::l, Range::kPositive, "m"},
    {"g", &CartPoleParams::g, Range::kNonNegative, "m/s²"},
};

std::optional<SpecError> SetChainParam(ChainParams& p, std::string_view name, double value, int link) {
  if (name == "g" || name == "base_angle") {
    if (link >= 0) return SpecError{std::string(name), "is one value for the whole chain, not per link"};
    if (name == "g") {
      if (auto err = CheckRange(name, value, Range::kNonNegative, "m/s²")) return err;
      p.g = value;
    } else {
      if (auto err = CheckRange(name, value, Range::kFinite, "rad")) return err;
      p.base_angle = value;
    }
    return std::nullopt;
  }
  if (link >= p.num_links()) {
    return SpecError{std::string(name),
                     "expected a link index below " + std::to_string(p.num_links()) + ", got " + std::to_string(link)};
  }
  Range range;
  std::string_view unit;
  if (name == "m") {
    range = Range::kPositive;
    unit = "kg";
  } else if (name == "L") {
    range = Range::kPositive;
    unit = "m";
  } else if (name == "com") {
    range = Range::kFinite;
    unit = "m";
  } else if (name == "I") {
    range = Range::kNonNegative;
    unit = "kg·m²";
  } else
    return SpecError{std::string(name), "unknown parameter"};
  if (auto err = CheckRange(name, value, range, unit)) return err;
  const int first = link < 0 ? 0 : link;
  const int last = link < 0 ? p.num_links() : link + 1;
  for (int i = first; i < last; ++i) {
    ChainLink& l = p.links[i];
    if (name == "m")
      l.m = value;
    else if (name == "L")
      l.L = value;
    else if (name == "com")
      l.com = value;
    else
      l.I = value;
  }
  return std::nullopt;
}

// A chain link's joint by name; link -1 sets every link's.
std::optional<SpecError> SetChainJoints(ChainParams& p, std::string_view text, int link) {
  const std::optional<JointType> parsed = ValueOf(kJointNames, text);
  if (!parsed)
    return SpecError{"joints", "expected " + NamesInWords(kJointNames) + ", got '" + std::string(text) + "'"};
  const JointType joint = *parsed;
  if (link >= p.num_links()) {
    return SpecError{"joints",
                     "expected a link index below " + std::to_string(p.num_links()) + ", got " + std::to_string(link)};
  }
  const int first = link < 0 ? 0 : link;
  const int last = link < 0 ? p.num_links() : link + 1;
  for (int i = first; i < last; ++i) p.links[i].joint = joint;
  return std::nullopt;
}

// The tree the dynamics get (MakeRigidTree) is valid: a mass_scale can
// overflow the inertias (1e308) or lose them to underflow, which only the
// scaled tree shows. Reported under mass_scale. A tree without joints (a
// floating base's joints alone: a free body) has no link to scale here; a
// fixed one is refused for having none (ValidateUrdf), not for its scale.
std::optional<SpecError> CheckScaledTree(const UrdfParams& p) {
  if (!p.robot || p.mass_scale == 1.0 || p.robot->tree.joints.empty()) return std::nullopt;
  if (auto err = ValidateRigidTree(MakeRigidTree(p))) {
    return SpecError{"mass_scale", "expected a factor that leaves every link's mass and inertia valid, got " +
                                       FormatNumber(p.mass_scale) + " (" + *err + ")"};
  }
  return std::nullopt;
}

// mass_scale within [1e-6, 1e6]: a factor for a model
// error or a change of units, never one that takes a robot's inertias near
// overflow (1e308) or its energies to inf.
constexpr double kMinMassScale = 1e-6, kMaxMassScale = 1e6;
std::optional<SpecError> CheckMassScaleRange(double scale) {
  if (scale >= kMinMassScale && scale <= kMaxMassScale) return std::nullopt;
  return SpecError{"mass_scale", "expected a factor from 1e-06 to 1e+06, got " + FormatNumber(scale)};
}

// A urdf plant's gravity ("gx,gy,gz") or mass_scale.
std::optional<SpecError> SetUrdfParam(UrdfParams& p, std::string_view name, std::string_view text) {
  const std::string key(name);
  if (name == "gravity") {
    // Three comma-separated finite numbers, nothing else.
    Eigen::Vector3d g;
    std::string_view rest = text;
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) {
      const std::size_t comma = k < 2 ? rest.find(',') : rest.size();
      const std::optional<double> v =
          comma == std::string_view::npos ? std::nullopt : ParseFiniteNumber(rest.substr(0, comma));
      ok = v.has_value() && (k < 2 || rest.find(',') == std::string_view::npos);
      if (ok) g[k] = *v;
      rest.remove_prefix(std::min(rest.size(), comma + 1));
    }
    if (!ok) {
      return SpecError{key,
                       "expected gx,gy,gz (three finite numbers, m/s², world frame), got '" + std::string(text) + "'"};
    }
    p.gravity = g;
    return std::nullopt;
  }
  if (name == "mass_scale") {
    const std::optional<double> v = ParseFiniteNumber(text);
    if (!v) return SpecError{key, "expected a finite number, got '" + std::string(text) + "'"};
    if (auto err = CheckRange(name, *v, Range::kPositive, "a factor")) return err;
    if (auto err = CheckMassScaleRange(*v)) return err;
    UrdfParams scaled = p;
    scaled.mass_scale = *v;
    if (auto err = CheckScaledTree(scaled)) return err;
    p.mass_scale = *v;
    return std::nullopt;
  }
  return SpecError{key, "unknown parameter for urdf (expected one of gravity, mass_scale)"};
}

std::optional<SpecError> ValidateUrdf(const UrdfParams& p) {
  if (!p.robot) {
    return SpecError{"file", "expected a robot loaded from a URDF file (a urdf plant has no default robot)"};
  }
  if (!p.gravity.allFinite()) return SpecError{"gravity", "expected three finite numbers (m/s²)"};
  if (auto err = CheckRange("mass_scale", p.mass_scale, Range::kPositive, "a factor")) return err;
  if (auto err = CheckMassScaleRange(p.mass_scale)) return err;
  const std::string& file = p.file.empty() ? p.robot->file : p.file;
  if (p.robot->properties.size() != static_cast<std::size_t>(p.robot->tree.num_dofs())) {
    return SpecError{"file", file + ": expected one set of joint properties per degree of freedom"};
  }
  if (auto err = ValidateRigidTree(p.robot->tree)) return SpecError{"file", file + ": " + *err};
  return CheckScaledTree(p);
}

// How far body i's centre of mass can be from the world origin, m: the joint
// offsets from the root to it, its centre-of-mass offset, and each prismatic
// joint's travel (its largest |limit|, 1 m without one).
double BodyReach(const UrdfRobot& robot, int i) {
  const RigidTree& tree = robot.tree;
  double reach = tree.bodies[static_cast<std::size_t>(i)].com.norm();
  for (int j = i; j >= 0; j = tree.joints[static_cast<std::size_t>(j)].parent) {
    const TreeJoint& joint = tree.joints[static_cast<std::size_t>(j)];
    reach += joint.position.norm();
    if (joint.type != JointType::kPrismatic) continue;
    // A mimic travels its multiplier times the followed joint's travel, from its offset.
    const UrdfJointProperties& p = robot.properties[static_cast<std::size_t>(tree.DofOf(j))];
    const double travel = p.lower && p.upper ? std::max(std::abs(*p.lower), std::abs(*p.upper)) : 1.0;
    reach += joint.mimic < 0 ? travel : std::abs(joint.multiplier) * travel + std::abs(joint.offset);
  }
  return reach;
}

// Σ m g × the height the plant's masses can be lifted by, J: the most work its
// gravity can do.
double Reach(const PlantSpec& spec) {
  return std::visit(
      [](const auto& p) -> double {
        using P = std::decay_t<decltype(p)>;
        if constexpr (std::is_same_v<P, PendulumParams>)
          return p.m * p.g * p.L;
        else if constexpr (std::is_same_v<P, Arm2Params>)
          return (p.m1 + p.m2) * p.g * (p.L1 + p.L2);
        else if constexpr (std::is_same_v<P, CartPoleParams>)
          return (p.mc + p.mp) * p.g * 2.0 * p.l;
        else if constexpr (std::is_same_v<P, UrdfParams>) {
          if (!p.robot) return 0.0;
          double work = 0.0;
          for (int i = 0; i < p.robot->tree.num_joints(); ++i) {
            work += p.robot->tree.bodies[static_cast<std::size_t>(i)].mass * BodyReach(*p.robot, i);
          }
          return work * p.mass_scale * p.gravity.norm();
        } else {
          double mass = 0.0, length = 0.0;
          for (const ChainLink& l : p.links) {
            mass += l.m;
            length += l.L;
          }
          return mass * p.g * length;
        }
      },
      spec.params);
}

}  // namespace

std::string_view ToString(PlantType type) { return NameOf(kPlantNames, type); }
std::optional<PlantType> ParsePlantType(std::string_view name) { return ValueOf(kPlantNames, name); }
std::string PlantTypeNames() { return JoinedNames(kPlantNames); }

double DefaultMaxEnergy(const PlantSpec& spec) { return 1000.0 * (1.0 + Reach(spec)); }

int PlantSpec::num_dofs() const {
  switch (type()) {
    case PlantType::kPendulum: return 1;
    case PlantType::kArm2:
    case PlantType::kCartPole: return 2;
    case PlantType::kChain: return std::get<ChainParams>(params).num_links();
    case PlantType::kUrdf: {
      const auto& robot = std::get<UrdfParams>(params).robot;
      return robot ? robot->tree.num_dofs() : 0;
    }
  }
  return 0;
}

PlantSpec DefaultPlantSpec(PlantType type) {
  switch (type) {
    case PlantType::kPendulum: return {PendulumParams{}};
    case PlantType::kArm2: return {Arm2Params{}};
    case PlantType::kCartPole: return {CartPoleParams{}};
    case PlantType::kChain: return {ChainParams{}};
    case PlantType::kUrdf: return {UrdfParams{}};
  }
  return {PendulumParams{}};
}

PlantSpec UrdfPlantSpec(std::shared_ptr<const UrdfRobot> robot) {
  UrdfParams p;
  p.file = robot ? robot->file : std::string();
  p.robot = std::move(robot);
  return {p};
}

std::vector<std::string_view> PlantParamNames(PlantType type) {
  switch (type) {
    case PlantType::kPendulum: return {"m", "L", "g", "body"};
    case PlantType::kArm2: return {"m1", "m2", "L1", "L2", "g"};
    case PlantType::kCartPole: return {"mc", "mp", "l", "I", "g"};
    case PlantType::kChain: return {"links", "m", "L", "com", "I", "joints", "base_angle", "g"};
    case PlantType::kUrdf: return {"gravity", "mass_scale"};
  }
  return {};
}

std::optional<double> ParseFiniteNumber(std::string_view text) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<SpecError> SetChainLinks(PlantSpec& spec, int links) {
  auto* chain = std::get_if<ChainParams>(&spec.params);
  if (chain == nullptr) return SpecError{"links", "only a chain has a number of links"};
  if (links < 1 || links > kMaxDofs) {
    return SpecError{
        "links", "expected a whole number from 1 to " + std::to_string(kMaxDofs) + ", got " + std::to_string(links)};
  }
  chain->links.resize(static_cast<std::size_t>(links), chain->links.empty() ? ChainLink{} : chain->links.back());
  return std::nullopt;
}

std::optional<SpecError> SetPlantParam(PlantSpec& spec, std::string_view name, std::string_view text, int link) {
  const std::string key(name);
  if (link >= 0 && spec.type() != PlantType::kChain) {
    return SpecError{key, "per-link values are for chains only"};
  }
  if (spec.type() == PlantType::kPendulum && name == "body") {
    auto& p = std::get<PendulumParams>(spec.params);
    const std::optional<PendulumBody> body = ValueOf(kBodyNames, text);
    if (!body) return SpecError{key, "expected " + NamesInWords(kBodyNames) + ", got '" + std::string(text) + "'"};
    p.body = *body;
    return std::nullopt;
  }
  if (spec.type() == PlantType::kChain && name == "joints") {
    return SetChainJoints(std::get<ChainParams>(spec.params), text, link);
  }
  if (spec.type() == PlantType::kUrdf) return SetUrdfParam(std::get<UrdfParams>(spec.params), name, text);
  const std::vector<std::string_view> names = PlantParamNames(spec.type());
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string list;
    for (std::string_view n : names) list += (list.empty() ? "" : ", ") + std::string(n);
    return SpecError{key,
                     "unknown parameter for " + std::string(ToString(spec.type())) + " (expected one of " + list + ")"};
  }
  const std::optional<double> value = ParseFiniteNumber(text);
  if (!value) return SpecError{key, "expected a finite number, got '" + std::string(text) + "'"};
  if (name == "links") {
    const double v = *value;
    if (v != std::floor(v) || v < 1.0 || v > kMaxDofs) {
      return SpecError{key,
                       "expected a whole number from 1 to " + std::to_string(kMaxDofs) + ", got " + std::string(text)};
    }
    return SetChainLinks(spec, static_cast<int>(v));
  }
  return std::visit(
      [&](auto& p) -> std::optional<SpecError> {
        using P = std::decay_t<decltype(p)>;
        if constexpr (std::is_same_v<P, PendulumParams>) {
          return SetField(p, kPendulumFields, name, *value);
        } else if constexpr (std::is_same_v<P, Arm2Params>) {
          return SetField(p, kArm2Fields, name, *value);
        } else if constexpr (std::is_same_v<P, CartPoleParams>) {
          if (name == "I") {
            if (auto err = CheckRange(name, *value, Range::kNonNegative, "kg·m²")) return err;
            p.I = *value;
            return std::nullopt;
          }
          return SetField(p, kCartPoleFields, name, *value);
        } else if constexpr (std::is_same_v<P, ChainParams>) {
          return SetChainParam(p, name, *value, link);
        } else {
          return SpecError{std::string(name), "unknown parameter"};  // urdf: handled above
        }
      },
      spec.params);
}

std::optional<SpecError> ValidatePlantSpec(const PlantSpec& spec) {
  // Every setter already checks ranges; here are the checks across fields and
  // those a default-constructed or hand-built spec could still fail.
  return std::visit(
      [](const auto& p) -> std::optional<SpecError> {
        using P = std::decay_t<decltype(p)>;
        if constexpr (std::is_same_v<P, PendulumParams>) {
          for (const auto& f : kPendulumFields) {
            if (auto err = CheckRange(f.name, p.*(f.member), f.range, f.unit)) return err;
          }
        } else if constexpr (std::is_same_v<P, Arm2Params>) {
          for (const auto& f : kArm2Fields) {
            if (auto err = CheckRange(f.name, p.*(f.member), f.range, f.unit)) return err;
          }
        } else if constexpr (std::is_same_v<P, CartPoleParams>) {
          for (const auto& f : kCartPoleFields) {
            if (auto err = CheckRange(f.name, p.*(f.member), f.range, f.unit)) return err;
          }
          if (auto err = CheckRange("I", p.pole_inertia(), Range::kNonNegative, "kg·m²")) return err;
        } else if constexpr (std::is_same_v<P, UrdfParams>) {
          return ValidateUrdf(p);
        } else {
          if (p.num_links() < 1 || p.num_links() > kMaxDofs) {
            return SpecError{
                "links", "expected 1 to " + std::to_string(kMaxDofs) + " links, got " + std::to_string(p.num_links())};
          }
          if (auto err = CheckRange("g", p.g, Range::kNonNegative, "m/s²")) return err;
          if (auto err = CheckRange("base_angle", p.base_angle, Range::kFinite, "rad")) return err;
          for (int i = 0; i < p.num_links(); ++i) {
            const ChainLink& l = p.links[i];
            std::string at = std::to_string(i);  // built in place: g++ 12 warns falsely on "[" + string
            at.insert(at.begin(), '[');
            at.push_back(']');
            if (auto err = CheckRange("m" + at, l.m, Range::kPositive, "kg")) return err;
            if (auto err = CheckRange("L" + at, l.L, Range::kPositive, "m")) return err;
            if (auto err = CheckRange("com" + at, l.com_offset(), Range::kFinite, "m")) return err;
            if (auto err = CheckRange("I" + at, l.inertia(), Range::kNonNegative, "kg·m²")) return err;
            if (l.joint == JointType::kRevolute && l.inertia() == 0.0 && l.com_offset() == 0.0) {
              return SpecError{"I" + at, "expected I > 0 or com != 0: the link has no inertia about its joint"};
            }
          }
          // Each link valid, the chain may still not be: masses 1e119 apart leave M(0) singular in double
          // precision, which the dynamics refuse when built (found by the scene fuzzer: refused here, in one line).
          if (auto err = ValidateRigidTree(ToRigidTree(p))) {
            return SpecError{"m", "expected links whose masses and inertias give a positive definite mass matrix "
                                  "in double precision, got " + *err};
          }
        }
        return std::nullopt;
      },
      spec.params);
}

namespace {
bool HasClosedForm(PlantType type) {
  return type == PlantType::kPendulum || type == PlantType::kArm2 || type == PlantType::kCartPole;
}
}  // namespace

bool HasMethod(PlantType type, Method method) { return method != Method::kClosedForm || HasClosedForm(type); }

const char* NoMethodReason(PlantType type, Method method) {
  if (HasMethod(type, method)) return nullptr;
  switch (type) {  // only closed forms can be missing
    case PlantType::kChain: return "chain has no closed-form path (expected lagrangian or recursive)";
    case PlantType::kUrdf: return "urdf has no closed-form path (expected lagrangian or recursive)";
    default: return "this plant has no such path (expected lagrangian or recursive)";
  }
}

Method FastestMethod(PlantType type) { return HasClosedForm(type) ? Method::kClosedForm : Method::kRecursive; }

namespace {

bool HasNoRobot(const PlantSpec& spec) {
  const auto* urdf = std::get_if<UrdfParams>(&spec.params);
  return urdf != nullptr && urdf->robot == nullptr;
}

}  // namespace

std::vector<JointType> JointTypesOf(const PlantSpec& spec) {
  return HasNoRobot(spec) ? std::vector<JointType>{} : MakeRigidTree(spec).joint_types();
}

std::vector<std::string> JointNamesOf(const PlantSpec& spec) {
  return HasNoRobot(spec) ? std::vector<std::string>{} : MakeRigidTree(spec).joint_names();
}

RigidTree MakeRigidTree(const UrdfParams& p) {
  if (!p.robot) throw std::invalid_argument("file: no URDF robot loaded");
  RigidTree tree = p.robot->tree;
  tree.gravity = p.gravity;
  for (RigidBody& b : tree.bodies) {
    b.mass *= p.mass_scale;
    b.inertia *= p.mass_scale;
  }
  return tree;
}

RigidTree MakeRigidTree(const PlantSpec& spec) {
  return std::visit(
      [](const auto& p) -> RigidTree {
        if constexpr (std::is_same_v<std::decay_t<decltype(p)>, UrdfParams>) {
          return MakeRigidTree(p);
        } else {
          return ToRigidTree(p);
        }
      },
      spec.params);
}

MethodModels MakeMethodModels(const PlantSpec& spec) {
  MethodModels models;
  for (std::size_t k = 0; k < kNumMethods; ++k) {
    const auto method = static_cast<Method>(k);
    if (HasMethod(spec.type(), method)) models[k] = MakeDynamics(spec, method);
  }
  return models;
}

std::unique_ptr<Dynamics> MakeDynamics(const PlantSpec& spec, Method method) {
  if (auto err = ValidatePlantSpec(spec)) {
    throw std::invalid_argument(err->key + ": " + err->message);
  }
  if (!HasMethod(spec.type(), method)) {
    throw std::invalid_argument("method " + std::string(ToString(method)) + " is not available for " +
                                std::string(ToString(spec.type())) + " (use lagrangian or recursive)");
  }
  RigidTree tree = MakeRigidTree(spec);
  if (spec.type() == PlantType::kUrdf) {
    // With mimic joints the energies (so the Lagrangian path) are over the
    // degrees of freedom already; the recursive algorithms run on the free
    // tree and are reduced (plant/mimic_dynamics.hpp).
    if (method == Method::kRecursive && tree.has_mimics()) {
      auto free = std::make_shared<const SpatialDynamics>(tree.WithEveryJointFree());
      return std::make_unique<MimicDynamics>(tree, std::move(free));
    }
    if (method == Method::kRecursive) return std::make_unique<SpatialDynamics>(std::move(tree));
    return std::make_unique<LagrangianDynamics<RigidTree>>(std::move(tree));
  }
  // The built-in plants' trees are planar chains: their recursive and
  // (for the chain) Lagrangian paths run in 2-D (plant/recursive_dynamics.hpp).
  std::optional<PlanarChain> planar = PlanarChainOf(tree);
  if (!planar) throw std::logic_error("a built-in plant's tree is not a planar chain");
  if (method == Method::kRecursive) return std::make_unique<RecursiveDynamics>(std::move(*planar));
  return std::visit(
      [method, &planar](const auto& p) -> std::unique_ptr<Dynamics> {
        using P = std::decay_t<decltype(p)>;
        const bool closed = method == Method::kClosedForm;
        if constexpr (std::is_same_v<P, PendulumParams>) {
          if (closed) return std::make_unique<PendulumClosedForm>(p);
          return std::make_unique<LagrangianDynamics<Pendulum>>(Pendulum(p));
        } else if constexpr (std::is_same_v<P, Arm2Params>) {
          if (closed) return std::make_unique<Arm2ClosedForm>(p);
          return std::make_unique<LagrangianDynamics<Arm2>>(Arm2(p));
        } else if constexpr (std::is_same_v<P, CartPoleParams>) {
          if (closed) return std::make_unique<CartPoleClosedForm>(p);
          return std::make_unique<LagrangianDynamics<CartPole>>(CartPole(p));
        } else {
          return std::make_unique<LagrangianDynamics<PlanarChain>>(std::move(*planar));  // chain
        }
      },
      spec.params);
}

}  // namespace lagrange
