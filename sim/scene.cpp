#include "sim/scene.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>

#include "base/escape.hpp"
#include "base/number_text.hpp"
#include "protocol/channels.hpp"
#include "protocol/signing.hpp"
#include "sim/scene_control.hpp"
#include "sim/yaml_reader.hpp"
#ifdef LAGRANGE_HAVE_MUJOCO
#include "plant/mujoco_plant.hpp"
#endif

namespace lagrange {
namespace {

// plant: {type: urdf, file: PATH, gravity: [gx, gy, gz], params: {mass_scale: s}, floating_base: true}.
// With floating_base true the file is read on a free base into *floating
// (null: the caller takes none, and says why), and the spec is its joints' (FixedBaseOf).
// `forced`: read on a free base whatever the node says (a mujoco plant's floating_base is its own key).
PlantSpec ReadUrdfPlant(const YamlReader& node, UrdfFiles& urdf, std::optional<FloatingBaseConfig>* floating,
                        bool forced) {
  const std::optional<YamlReader> fb = node.Optional("floating_base");
  const bool free_base = forced || (fb && fb->Bool());
  if (free_base && floating == nullptr) {
    fb->Fail("expected no floating_base here: a floating base is simulated by lagrange itself (a plant of type urdf)");
  }
  PlantSpec spec;
  if (free_base) {
    floating->emplace();
    (*floating)->robot = urdf.Load(node.Required("file"), UrdfOptions{.floating_base = true});
    spec = UrdfPlantSpec(FixedBaseOf(*(*floating)->robot));
    std::get<UrdfParams>(spec.params).file = (*floating)->robot->file;
  } else {
    spec = UrdfPlantSpec(urdf.Load(node.Required("file")));
  }
  if (auto g = node.Optional("gravity")) SetUrdfParam(spec, "gravity", *g);
  if (auto params = node.Optional("params")) {
    for (const auto& [key, value] : params->Entries()) {
      if (key == "gravity") value.Fail("a urdf plant's gravity is plant.gravity: [gx, gy, gz]");
      SetUrdfParam(spec, key, value);
    }
  }
  return spec;
}

// `floating`: where a urdf plant's floating base goes (ReadUrdfPlant); null where none is taken.
// `free_base`: a urdf plant read on a free base whatever its own key says.
PlantSpec ReadPlant(const YamlReader& node, Method* method, UrdfFiles& urdf,
                    std::optional<FloatingBaseConfig>* floating = nullptr, bool free_base = false) {
  const YamlReader type_node = node.Required("type");
  const std::optional<PlantType> type = ParsePlantType(type_node.Text());
  if (!type) type_node.Fail("expected one of " + PlantTypeNames() + ", got '" + type_node.Text() + "'");
  const bool is_urdf = *type == PlantType::kUrdf;
  if (!is_urdf && node.Has("floating_base")) {
    node.Required("floating_base")
        .Fail("expected no floating_base on a " + std::string(ToString(*type)) +
              " plant: a floating base is read from a URDF file (type: urdf, or a mujoco plant's free joint)");
  }
  if (is_urdf)
    node.ExpectKeys({"type", "file", "gravity", "method", "params", "floating_base"});
  else
    node.ExpectKeys({"type", "method", "params"});
  PlantSpec spec = is_urdf ? ReadUrdfPlant(node, urdf, floating, free_base) : DefaultPlantSpec(*type);

  if (auto params = node.Optional("params"); params && !is_urdf) {
    std::vector<std::pair<std::string, YamlReader>> entries = params->Entries();
    // The chain's link count first, so per-link lists can be checked against it.
    std::stable_partition(entries.begin(), entries.end(), [](const auto& e) { return e.first == "links"; });
    for (const auto& [key, value] : entries) {
      const std::vector<std::string_view> names = PlantParamNames(*type);
      if (std::find(names.begin(), names.end(), key) == names.end()) {
        std::string list;
        for (std::string_view n : names) list += (list.empty() ? "" : ", ") + std::string(n);
        value.Fail("unknown parameter for " + std::string(ToString(*type)) + " (expected one of: " + list + ")");
      }
      if (value.IsSequence()) {
        if (*type != PlantType::kChain || key == "links" || key == "g" || key == "base_angle") {
          value.Fail("expected a single value");
        }
        const int links = spec.num_dofs();
        if (static_cast<int>(value.Size()) != links) {
          value.Fail("expected " + std::to_string(links) + " values (one per link), got " +
                     std::to_string(value.Size()));
        }
        for (int i = 0; i < links; ++i) {
          const YamlReader item = value.At(static_cast<std::size_t>(i));
          if (auto err = SetPlantParam(spec, key, item.Text(), i)) item.Fail(err->message);
        }
      } else if (auto err = SetPlantParam(spec, key, value.Text())) {
        value.Fail(err->message);
      }
    }
  }
  if (auto err = ValidatePlantSpec(spec)) {
    node.Fail(is_urdf && (err->key == "file" || err->key == "gravity") ? err->key : "params." + err->key, err->message);
  }

  *method = FastestMethod(*type);
  if (auto m = node.Optional("method")) {
    const std::optional<Method> parsed = ParseMethod(m->Text());
    if (!parsed) m->Fail("expected " + MethodNames() + ", got '" + m->Text() + "'");
    if (const char* why = NoMethodReason(*type, *parsed)) m->Fail(why);  // as the method command says
    if (floating != nullptr && *floating && *parsed != Method::kRecursive) m->Fail(kFloatingMethod);
    *method = *parsed;
  }
  return spec;
}

// `off` (false, no) written for an effect: switch it off, whatever a URDF said.
bool IsOff(const YamlReader& node) {
  if (!node.IsScalar()) return false;
  const std::string text = node.Text();
  return text == "off" || text == "false" || text == "no";
}

// The effects a URDF gives its joints, each on only where the file gives it:
// stops at <limit lower upper> (±inf for joints without, the default
// stiffness and damping; none either for a locked joint, lower == upper: a
// stop of zero width is not one a spring of finite stiffness can hold, so
// that joint moves freely unless the scene's effects.limits give it a stop), damping and Coulomb friction from
// <dynamics damping friction> when some joint's is positive (0 for the others).
EffectsConfig UrdfEffects(const UrdfRobot& robot) {
  EffectsConfig c;
  const int n = robot.tree.num_dofs();
  const double inf = std::numeric_limits<double>::infinity();
  JointLimits limits;
  limits.lower = VectorXd::Constant(n, -inf);
  limits.upper = VectorXd::Constant(n, inf);
  VectorXd damping = VectorXd::Zero(n), friction = VectorXd::Zero(n);
  bool any_limit = false;
  for (int i = 0; i < n; ++i) {
    const UrdfJointProperties& p = robot.properties[static_cast<std::size_t>(i)];
    if (p.lower && p.upper && *p.lower < *p.upper) {
      limits.lower[i] = *p.lower;
      limits.upper[i] = *p.upper;
      any_limit = true;
    }
    damping[i] = p.damping.value_or(0.0);
    friction[i] = p.friction.value_or(0.0);
  }
  if (any_limit) c.limits = limits;
  if ((damping.array() > 0.0).any()) c.damping = damping;
  if ((friction.array() > 0.0).any()) c.friction = CoulombFriction{friction};
  return c;
}

// The scene's effects over `c` (a URDF's, or none): a key the scene writes
// replaces what was there (inside friction and limits, key by key); `off`
// switches an effect off.
// The first joint whose stops are not lower < upper, named: "limits: expected
// lower < upper for joint 'elbow', got 1 and 1".
std::optional<EffectsError> CheckStops(const EffectsConfig& c, const std::vector<std::string>& names) {
  if (!c.limits) return std::nullopt;
  const JointLimits& l = *c.limits;
  const auto size = static_cast<Eigen::Index>(names.size());
  if (l.lower.size() != size || l.upper.size() != size) return std::nullopt;  // ValidateEffects says so
  for (Eigen::Index i = 0; i < size; ++i) {
    if (!(l.lower[i] < l.upper[i])) {
      return EffectsError{"limits", "expected lower < upper for joint '" + Escape(names[static_cast<std::size_t>(i)]) +
                                        "', got " + FormatDouble(l.lower[i]) + " and " + FormatDouble(l.upper[i])};
    }
  }
  return std::nullopt;
}

std::optional<EffectsError> CheckEffects(const EffectsConfig& c, const std::vector<std::string>& names) {
  if (auto err = CheckStops(c, names)) return err;
  return ValidateEffects(c, static_cast<int>(names.size()));
}

EffectsConfig ReadEffects(const YamlReader& node, const std::vector<std::string>& names, EffectsConfig c) {
  const int n = static_cast<int>(names.size());
  node.ExpectKeys({"gravity", "coriolis", "damping", "friction", "limits", "saturation", "disturbance", "off"});
  if (auto v = node.Optional("gravity")) c.gravity = v->Bool();
  if (auto v = node.Optional("coriolis")) c.coriolis = v->Bool();
  if (auto v = node.Optional("damping")) {
    if (IsOff(*v)) {
      c.damping.reset();
    } else {
      c.damping = v->NumberOrVector(n);
      if ((c.damping->array() < 0.0).any()) v->Fail("expected damping coefficients >= 0");
    }
  }
  if (auto v = node.Optional("friction")) {
    if (IsOff(*v)) {
      c.friction.reset();
    } else {
      v->ExpectKeys({"coulomb", "velocity_scale"});
      CoulombFriction f = c.friction.value_or(CoulombFriction{});
      if (!c.friction || v->Has("coulomb")) f.coulomb = v->Required("coulomb").NumberOrVector(n);
      if (auto s = v->Optional("velocity_scale")) f.velocity_scale = s->PositiveNumber();
      c.friction = f;
    }
  }
  if (auto v = node.Optional("limits")) {
    if (IsOff(*v)) {
      c.limits.reset();
    } else {
      v->ExpectKeys({"lower", "upper", "stiffness", "damping"});
      JointLimits l = c.limits.value_or(JointLimits{});
      if (!c.limits || v->Has("lower")) l.lower = v->Required("lower").VectorOrInfinity(n);
      if (!c.limits || v->Has("upper")) l.upper = v->Required("upper").VectorOrInfinity(n);
      if (auto s = v->Optional("stiffness")) l.stiffness = s->PositiveNumber();
      if (auto s = v->Optional("damping")) l.damping = s->NonNegativeNumber();
      c.limits = l;
    }
  }
  if (auto v = node.Optional("saturation")) {
    if (IsOff(*v))
      c.saturation.reset();
    else
      c.saturation = v->NumberOrVector(n);
  }
  if (auto v = node.Optional("disturbance")) {
    for (std::size_t i = 0; i < v->Size(); ++i) {
      const YamlReader p = v->At(i);
      p.ExpectKeys({"start", "duration", "tau"});
      c.disturbance.push_back(
          Push{p.Required("start").Number(), p.Required("duration").PositiveNumber(), p.Required("tau").Vector(n)});
    }
  }
  std::vector<EffectKind> off;
  std::vector<YamlReader> off_items;
  if (auto v = node.Optional("off")) {
    // Effects given above that start off; a command (SET_EFFECT) may turn them on.
    for (std::size_t i = 0; i < v->Size(); ++i) {
      off_items.push_back(v->At(i));
      const std::optional<EffectKind> kind = ParseEffectKind(off_items.back().Text());
      if (!kind) {
        off_items.back().Fail("expected one of " + EffectKindNames() + ", got '" + Escape(off_items.back().Text()) +
                              "'");
      }
      off.push_back(*kind);
    }
  }
  c.off.clear();
  if (auto err = CheckEffects(c, names)) node.Fail(err->key, err->message);
  const Effects probe(c, static_cast<int>(names.size()));  // valid now: it cannot throw
  for (std::size_t i = 0; i < off.size(); ++i) {
    if (!probe.Configured(off[i])) off_items[i].Fail(NotConfiguredReason(off[i]));
  }
  c.off = off;
  return c;
}

IntegratorConfig ReadIntegrator(const YamlReader& node) {
  node.ExpectKeys({"type", "substeps", "rtol", "atol", "max_steps"});
  // The same rules as the run-time integrator command (CheckIntegratorConfig), with the key named.
  IntegratorConfig c;
  if (auto v = node.Optional("type")) {
    const std::optional<IntegratorType> t = ParseIntegratorType(v->Text());
    if (!t) v->Fail("expected one of " + IntegratorTypeNames() + ", got '" + v->Text() + "'");
    c.type = *t;
  }
  if (auto v = node.Optional("substeps")) c.substeps = v->Integer(1, 1000);
  if (auto v = node.Optional("rtol")) c.rtol = v->PositiveNumber();
  if (auto v = node.Optional("atol")) c.atol = v->PositiveNumber();
  if (auto v = node.Optional("max_steps")) c.max_steps = v->Integer(1, 10000000);
  if (const char* why = CheckIntegratorConfig(c)) node.Fail(why);
  return c;
}

// |tau| bounds from a URDF's <limit effort> (+inf where it gives none, or 0,
// which some files write for "unspecified").
VectorXd UrdfTorqueLimits(const UrdfRobot& robot) {
  const int n = robot.tree.num_dofs();
  VectorXd limits = VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  for (int i = 0; i < n; ++i) {
    const std::optional<double>& effort = robot.properties[static_cast<std::size_t>(i)].effort;
    if (effort && *effort > 0.0) limits[i] = *effort;
  }
  return limits;
}

// controller, controllers, torque_limits, setpoint, setpoint_limits, setpoint_timeout, on_timeout.
void ReadControl(const YamlReader& node, double period, InstanceConfig& inst, UrdfFiles& urdf) {
  const int n = inst.plant.num_dofs();
  if (auto c = node.Optional("controller")) {
    inst.controller = ReadController(*c, inst.plant, period, inst.q0, inst.integrator, urdf);
  }
  if (auto list = node.Optional("controllers")) {
    std::set<ControllerType> seen = {inst.controller.type};
    for (std::size_t i = 0; i < list->Size(); ++i) {
      const YamlReader item = list->At(i);
      inst.alternates.push_back(ReadController(item, inst.plant, period, inst.q0, inst.integrator, urdf));
      if (!seen.insert(inst.alternates.back().type).second) {
        item.Required("type").Fail("a second " + std::string(ToString(inst.alternates.back().type)) +
                                   " controller (each type once per instance)");
      }
    }
  }
  inst.torque_limits = VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  if (const auto* p = std::get_if<UrdfParams>(&inst.plant.params)) inst.torque_limits = UrdfTorqueLimits(*p->robot);
  if (auto t = node.Optional("torque_limits")) {
    inst.torque_limits = t->NumberOrVector(n);
    if ((inst.torque_limits.array() <= 0.0).any()) t->Fail("expected positive limits (N·m or N)");
  }
  if (auto s = node.Optional("setpoint")) inst.setpoint = ReadTrajectory(*s, n);
  inst.setpoint_lower = VectorXd::Constant(n, -std::numeric_limits<double>::infinity());
  inst.setpoint_upper = VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  if (inst.effects.limits) {
    inst.setpoint_lower = inst.effects.limits->lower;
    inst.setpoint_upper = inst.effects.limits->upper;
  }
  if (inst.mujoco) {  // MuJoCo's joint ranges, where it limits a joint
    inst.setpoint_lower = inst.mujoco->lower;
    inst.setpoint_upper = inst.mujoco->upper;
  }
  if (auto l = node.Optional("setpoint_limits")) {
    l->ExpectKeys({"lower", "upper"});
    inst.setpoint_lower = l->Required("lower").VectorOrInfinity(n);
    inst.setpoint_upper = l->Required("upper").VectorOrInfinity(n);
    if (!(inst.setpoint_lower.array() < inst.setpoint_upper.array()).all())
      l->Fail("expected lower < upper for every joint");
  }
  if (auto t = node.Optional("setpoint_timeout")) inst.setpoint_timeout = t->PositiveNumber();
  if (auto w = node.Optional("workspace")) {
    w->ExpectKeys({"lower", "upper"});
    inst.workspace_lower = w->Required("lower").VectorOrInfinity(3);
    inst.workspace_upper = w->Required("upper").VectorOrInfinity(3);
    if (!(inst.workspace_lower.array() < inst.workspace_upper.array()).all()) {
      w->Fail("expected lower < upper in x, y and z (m, world frame)");
    }
  }
  if (auto b = node.Optional("on_timeout")) {
    const std::string v = b->Text();
    if (v == "hold-position")
      inst.on_timeout = TimeoutBehaviour::kHoldPosition;
    else if (v == "zero-torque")
      inst.on_timeout = TimeoutBehaviour::kZeroTorque;
    else
      b->Fail("expected hold-position or zero-torque, got '" + v + "'");
  }
  if (auto e = node.Optional("max_energy")) inst.max_energy = e->PositiveNumber();
  if (auto d = node.Optional("estop_damping")) {
    inst.estop_damping = d->NumberOrVector(n);
    if ((inst.estop_damping->array() <= 0.0).any()) d->Fail("expected positive damping (N·m·s/rad or N·s/m)");
  }
  if (auto d = node.Optional("estop_dwell")) {
    inst.estop_dwell = d->NonNegativeNumber();
    if (inst.estop_dwell > kMaxEstopDwell) {
      d->Fail("expected 0 to 3600 s (how long an emergency stop lasts before a clear can end it), got " + d->Text());
    }
  }
}

// plant: {type: external, model: {...}, state_channel: CH, torque_channel: CH2, state_timeout: s}
bool IsExternalPlant(const YamlReader& plant) {
  return plant.IsMap() && plant.Has("type") && plant.Required("type").Text() == "external";
}

std::string ReadChannel(const YamlReader& node) {
  std::string channel = node.Text();
  if (const std::string why = CheckChannelName(channel); !why.empty()) node.Fail(why);
  return channel;
}

ExternalPlantConfig ReadExternalPlant(const YamlReader& node, double period) {
  node.ExpectKeys({"type", "model", "state_channel", "torque_channel", "state_timeout", "phase_lock", "phase_lag"});
  ExternalPlantConfig e;
  e.state_channel = ReadChannel(node.Required("state_channel"));
  e.torque_channel = ReadChannel(node.Required("torque_channel"));
  if (e.state_channel == e.torque_channel) {
    node.Required("torque_channel").Fail("expected a channel other than state_channel");
  }
  if (auto v = node.Optional("phase_lock")) e.phase_lock = v->Bool();
  if (auto v = node.Optional("phase_lag")) {
    e.phase_lag = v->PositiveNumber();
    if (e.phase_lag >= period) v->Fail("expected less than the period (" + FormatDouble(period) + " s)");
  }
  if (auto t = node.Optional("state_timeout")) {
    e.state_timeout = t->PositiveNumber();
    if (e.state_timeout < 2.0 * period) {
      t->Fail("expected at least two ticks (" + FormatDouble(2.0 * period) + " s): a state arrives once per tick");
    }
  }
  return e;
}

// plant: {type: mujoco, file: F, model: {...}}
bool IsMujocoPlant(const YamlReader& plant) {
  return plant.IsMap() && plant.Has("type") && plant.Required("type").Text() == "mujoco";
}

bool IsUrdfFile(const std::string& name) {
  return name.size() > 5 && name.compare(name.size() - 5, 5, ".urdf") == 0;
}

bool IsUrdfModel(const YamlReader& model) {
  return model.IsMap() && model.Has("type") && model.Required("type").Text() == "urdf";
}

// Lagrange's model of a mujoco plant: `model:`, else the URDF file itself.
// With the URDF itself as the model, `gravity` and `method` are a urdf plant's
// keys (gravity then MuJoCo's too), so a urdf scene becomes a mujoco one by its type alone.
// floating_base: true: MuJoCo's first free joint is the robot's base, and the
// model (a URDF) is read on a free base into *floating, as a urdf plant's.
PlantSpec ReadMujocoModel(const YamlReader& node, Method* method, UrdfFiles& urdf,
                          std::optional<FloatingBaseConfig>& floating) {
  node.ExpectKeys({"type", "file", "model", "gravity", "method", "floating_base"});
  const YamlReader file = node.Required("file");
  const std::optional<YamlReader> fb = node.Optional("floating_base");
  const bool free_base = fb && fb->Bool();
  if (auto model = node.Optional("model")) {
    for (const char* key : {"gravity", "method"}) {
      if (node.Has(key)) {
        node.Required(key).Fail("with model: given, this is the model's key (model." + std::string(key) +
                                "); MuJoCo's gravity is its file's");
      }
    }
    if (!free_base) return ReadPlant(*model, method, urdf);
    if (!IsUrdfModel(*model)) {
      model->Required("type").Fail("expected urdf: a floating base's model is a URDF read on a free base");
    }
    if (model->Has("floating_base")) {
      model->Required("floating_base").Fail("expected it on the plant (plant.floating_base), not on its model");
    }
    return ReadPlant(*model, method, urdf, &floating, /*free_base=*/true);
  }
  if (!IsUrdfFile(file.Text())) {
    file.Fail("an MJCF file needs model: {type: urdf, file: ...} (lagrange's model of the robot, for the controllers)");
  }
  PlantSpec spec;
  if (free_base) {
    floating.emplace();
    floating->robot = urdf.Load(file, UrdfOptions{.floating_base = true});
    spec = UrdfPlantSpec(FixedBaseOf(*floating->robot));
    std::get<UrdfParams>(spec.params).file = floating->robot->file;
  } else {
    spec = UrdfPlantSpec(urdf.Load(file));
  }
  if (auto g = node.Optional("gravity")) SetUrdfParam(spec, "gravity", *g);
  if (auto err = ValidatePlantSpec(spec)) file.Fail(err->message);
  *method = FastestMethod(PlantType::kUrdf);
  if (auto m = node.Optional("method")) {
    const std::optional<Method> parsed = ParseMethod(m->Text());
    if (!parsed) m->Fail("expected " + MethodNames() + ", got '" + m->Text() + "'");
    if (const char* why = NoMethodReason(PlantType::kUrdf, *parsed)) m->Fail(why);
    if (free_base && *parsed != Method::kRecursive) m->Fail(kFloatingMethod);
    *method = *parsed;
  }
  if (free_base) *method = Method::kRecursive;
  return spec;
}

// integrator: {type: euler|rk4|implicit, substeps: N}: MuJoCo's, as 2.2.2 has them.
void ReadMujocoIntegrator(const YamlReader& node, MujocoPlantConfig& c) {
  node.ExpectKeys({"type", "substeps"});
  if (auto v = node.Optional("type")) {
    const std::optional<MujocoIntegrator> t = ParseMujocoIntegrator(v->Text());
    if (!t) {
      v->Fail("expected one of " + std::string(kMujocoIntegratorNames) + " for a mujoco plant (MuJoCo 2.2.2's), got '" +
              Escape(v->Text(), 60) + "'");
    }
    c.integrator = *t;
  }
  if (auto v = node.Optional("substeps")) c.substeps = v->Integer(1, 1000);
}

// Loads the MuJoCo model at period / substeps; its joints must be the model's degrees of freedom (matched
// by name, in its order) and its mimics, each coupled by a joint equality (plant/mujoco_plant.hpp).
void LoadMujocoModel(const YamlReader& plant_node, double period, UrdfFiles& urdf, InstanceConfig& inst) {
  const YamlReader file = plant_node.Required("file");
  if (file.Text().empty()) file.Fail("expected the path of an MJCF or URDF file, got ''");
  MujocoPlantConfig& c = *inst.mujoco;
  c.file = (std::filesystem::path(plant_node.file()).parent_path() / file.Text()).lexically_normal().string();
#ifdef LAGRANGE_HAVE_MUJOCO
  MujocoOptions options;
  options.period = period;
  options.substeps = c.substeps;
  options.integrator = c.integrator;
  std::shared_ptr<const UrdfRobot> robot;
  if (IsUrdfFile(file.Text())) {  // the exact inertias of lagrange's reading of the same file (unscaled)
    robot = inst.floating ? inst.floating->robot : urdf.Load(file);
    options.exact_inertia = &robot->tree;
  }
  options.floating_base = inst.floating.has_value();  // MuJoCo's first free joint is the base
  if (!plant_node.Has("model")) options.gravity = std::get<UrdfParams>(inst.plant.params).gravity;  // plant.gravity
  options.joint_order = JointNamesOf(inst.plant);  // q in lagrange's model's order, the joints matched by name
  if (const auto* p = std::get_if<UrdfParams>(&inst.plant.params); p != nullptr && p->robot) {
    options.mimics = MimicsOf(p->robot->tree);  // coupled in MuJoCo by its joint equality
  }
  std::shared_ptr<const MujocoPlantModel> model;
  try {
    model = LoadMujocoPlant(c.file, options);
  } catch (const std::exception& e) {
    file.Fail(Escape(e.what(), 400));
  }
  c.model = model;
  const int base = inst.floating ? kFreeFlyerNv : 0;  // the joints' ranges follow the base's six
  c.lower = Eigen::Map<const VectorXd>(model->info().lower.data() + base, model->num_dofs() - base);
  c.upper = Eigen::Map<const VectorXd>(model->info().upper.data() + base, model->num_dofs() - base);
#else
  (void)period;
  (void)urdf;
  plant_node.Required("type").Fail(
      "this lagrange was built without MuJoCo (libmujoco-dev was not found when it was configured)");
#endif
}

// The YAML node of each controller, in the order of InstanceConfig's controller, alternates.
std::vector<YamlReader> ControllerNodes(const YamlReader& node) {
  std::vector<YamlReader> nodes;
  if (auto c = node.Optional("controller")) nodes.push_back(*c);
  if (auto list = node.Optional("controllers")) {
    for (std::size_t i = 0; i < list->Size(); ++i) nodes.push_back(list->At(i));
  }
  return nodes;
}

// An mpc plan's box is the instance's torque_limits on its actuated joints (a URDF's <limit effort> unless the
// scene gives torque_limits), as Crocoddyl's box-FDDP takes the model's effort limits and MJPC its ctrlrange:
// each must be finite.
void CheckMpcLimits(const YamlReader& node, const YamlReader& controller, const ControllerConfig& c,
                    const InstanceConfig& inst) {
  const int n = inst.plant.num_dofs();
  for (int j : MpcActuated(c.mpc, n, inst.plant.type() == PlantType::kCartPole)) {
    if (std::isfinite(inst.torque_limits[j])) continue;
    const std::string what = "expected a finite limit on every joint an mpc controller actuates (its plan's box), "
                             "joint " + std::to_string(j) + " has none";
    if (auto t = node.Optional("torque_limits")) t->Fail(what);
    controller.Required("type").Fail("mpc needs torque_limits (or the URDF's effort limits): " + what);
  }
}

// External controllers' fallbacks name a controller the instance configures;
// an external plant's controllers run here, once per tick.
void CheckExternalControl(const YamlReader& node, const InstanceConfig& inst) {
  std::vector<const ControllerConfig*> all = ControllerConfigs(inst);
  if (!node.Has("controller")) all.erase(all.begin());  // the default `none`: no node of its own
  const std::vector<YamlReader> nodes = ControllerNodes(node);
  std::string holders;
  for (const ControllerConfig* c : all) {
    if (c->type != ControllerType::kExternal && c->type != ControllerType::kNone && c->type != ControllerType::kMpc)
      holders += ", " + std::string(ToString(c->type));
  }
  for (std::size_t k = 0; k < all.size(); ++k) {
    const ControllerConfig& c = *all[k];
    if (inst.external && c.type == ControllerType::kExternal) {
      nodes[k].Required("type").Fail("an external plant's controller runs in lagranged (expected another type)");
    }
    if (inst.external && c.continuous) {
      nodes[k].Required("continuous").Fail("an external plant's controller runs once per tick on the measured state");
    }
    if (inst.mujoco && c.continuous) {
      nodes[k].Required("continuous").Fail("a mujoco plant's controller runs once per tick (MuJoCo holds the force over its steps)");
    }
    if (c.type == ControllerType::kMpc) CheckMpcLimits(node, nodes[k], c, inst);
    const std::optional<std::string>& fallback =
        c.type == ControllerType::kMpc ? c.mpc.fallback : c.external.fallback;
    if ((c.type != ControllerType::kExternal && c.type != ControllerType::kMpc) || !fallback) continue;
    const std::string& f = *fallback;
    bool found = f == "brake";
    for (const ControllerConfig* other : all) {
      found = found || (other->type != ControllerType::kExternal && other->type != ControllerType::kNone &&
                        other->type != ControllerType::kMpc && ToString(other->type) == f);
    }
    if (!found) {
      nodes[k]
          .Required("fallback")
          .Fail("expected brake" +
                (holders.empty() ? "" : " or one of this instance's controllers (" + holders.substr(2) + ")") +
                ", got '" + Escape(f) + "'");
    }
  }
}

}  // namespace

bool NormaliseBaseQuaternion(VecRef base_q) {
  const double norm = base_q.segment<4>(3).norm();
  if (!(std::abs(norm - 1.0) <= kQuaternionNormTolerance)) return false;
  base_q.segment<4>(3) /= norm;
  return true;
}

namespace {

// initial: {base_q: [px, py, pz, x, y, z, w], base_v: [vx, vy, vz, wx, wy, wz]}: a floating base's.
void ReadInitialBase(const YamlReader& init, std::optional<FloatingBaseConfig>& floating) {
  for (const char* key : {"base_q", "base_v"}) {
    if (init.Has(key) && !floating)
      init.Required(key).Fail(
          "expected no base state: the plant's base is fixed "
          "(a urdf or mujoco plant's floating_base: true frees it)");
  }
  if (auto q = init.Optional("base_q")) {
    VectorXd base = q->Vector(kFreeFlyerNq);
    if (!NormaliseBaseQuaternion(base)) {
      q->Fail("expected [px, py, pz, x, y, z, w] with a unit quaternion (x, y, z, w), got one of norm " +
              FormatDouble(base.segment<4>(3).norm()));
    }
    floating->q0 = base;
  }
  if (auto v = init.Optional("base_v")) floating->v0 = v->Vector(kFreeFlyerNv);
}

// A floating base steps on its manifold (plant/floating_integrator.hpp).
void CheckFloatingIntegrator(const YamlReader& node, const IntegratorConfig& integrator) {
  const IntegratorType t = integrator.type;
  if (t == IntegratorType::kExplicitEuler || t == IntegratorType::kSemiImplicitEuler || t == IntegratorType::kRk4 ||
      t == IntegratorType::kVariational) {
    return;
  }
  node.Required("integrator").Required("type").Fail(std::string(kFloatingIntegrators) + ", got " +
                                                    std::string(ToString(t)));
}

// What a floating base's controllers and keys must be (FloatingBaseRefusal),
// checked before the controllers are read: a refused type is named as such,
// not by its own missing keys. One MuJoCo steps keeps no energy balance.
void CheckFloatingControl(const YamlReader& node, bool mujoco) {
  for (const YamlReader& c : ControllerNodes(node)) {
    const YamlReader type = c.Required("type");
    const std::optional<ControllerType> t = ParseControllerType(type.Text());
    if (!t) continue;  // ReadController names it
    if (const char* why = FloatingBaseRefusal(*t)) type.Fail(why);
    if (auto k = c.Optional("continuous"); k && k->Bool()) {
      k->Fail("a floating base's controller runs once per tick (its force is held over the step)");
    }
  }
  if (auto e = node.Optional("energy_balance"); e && mujoco) {
    e->Fail("expected no energy_balance for a floating base MuJoCo steps (it keeps no energy balance yet)");
  }
}

// pd's gravity_compensation: stance balances a floating base's weight over its feet: not on a fixed base.
void CheckNoStance(const YamlReader& node, const InstanceConfig& inst) {
  std::vector<const ControllerConfig*> all = ControllerConfigs(inst);
  if (!node.Has("controller")) all.erase(all.begin());  // the default `none`: no node of its own
  const std::vector<YamlReader> nodes = ControllerNodes(node);
  for (std::size_t k = 0; k < all.size(); ++k) {
    if (!all[k]->stance.on) continue;
    nodes[k]
        .Required("gravity_compensation")
        .Fail(
            "expected none on a fixed base: stance balances a floating base's weight over its feet in contact "
            "(a urdf or mujoco plant with floating_base: true)");
  }
}

// energy_balance: {bound: J, on_exceed: warn|fault}
EnergyBalanceBound ReadEnergyBalanceBound(const YamlReader& node, bool external_plant) {
  if (external_plant) node.Fail("expected no energy_balance for an external plant (it keeps no energy balance)");
  node.ExpectKeys({"bound", "on_exceed"});
  EnergyBalanceBound b;
  b.bound = node.Required("bound").PositiveNumber();
  if (auto o = node.Optional("on_exceed")) {
    const std::string v = o->Text();
    if (v == "warn")
      b.on_exceed = OnResidualExceeded::kWarn;
    else if (v == "fault")
      b.on_exceed = OnResidualExceeded::kFault;
    else
      o->Fail("expected warn or fault, got '" + Escape(v, 60) + "'");
  }
  return b;
}

InstanceConfig ReadInstance(const YamlReader& node, double period, UrdfFiles& urdf) {
  node.ExpectKeys({"name", "plant", "initial", "effects", "integrator", "controller", "controllers", "torque_limits",
                   "setpoint", "setpoint_limits", "setpoint_timeout", "workspace", "on_timeout", "max_energy",
                   "energy_balance", "estop_damping", "estop_dwell", "telemetry", "forces"});
  InstanceConfig inst;
  const YamlReader name = node.Required("name");
  inst.name = name.Text();
  if (!IsInstanceName(inst.name)) {
    name.Fail("expected a lower-case name of letters, digits and _ starting with a letter, got '" + inst.name + "'");
  }
  const YamlReader plant_node = node.Required("plant");
  if (IsExternalPlant(plant_node)) {
    inst.external = ReadExternalPlant(plant_node, period);
    inst.plant = ReadPlant(plant_node.Required("model"), &inst.method, urdf);
  } else if (IsMujocoPlant(plant_node)) {
    inst.mujoco = MujocoPlantConfig{};
    inst.plant = ReadMujocoModel(plant_node, &inst.method, urdf, inst.floating);
  } else {
    inst.plant = ReadPlant(plant_node, &inst.method, urdf, &inst.floating);
  }
  const int n = inst.plant.num_dofs();
  inst.q0 = VectorXd::Zero(n);
  inst.qd0 = VectorXd::Zero(n);
  if (auto init = node.Optional("initial")) {
    init->ExpectKeys({"q", "qd", "base_q", "base_v"});
    if (auto q = init->Optional("q")) inst.q0 = q->Vector(n);
    if (auto qd = init->Optional("qd")) inst.qd0 = qd->Vector(n);
    ReadInitialBase(*init, inst.floating);
  }
  // A URDF's effects, then the scene's keys over them; the merged result is what is validated.
  const auto* urdf_params = inst.mujoco ? nullptr : std::get_if<UrdfParams>(&inst.plant.params);
  if (urdf_params) inst.effects = UrdfEffects(*urdf_params->robot);
  if (inst.mujoco && node.Has("effects")) node.Required("effects").Fail(std::string(kMujocoEffects) + ": expected no effects");
  const std::vector<std::string> names = JointNamesOf(inst.plant);
  if (auto e = node.Optional("effects")) {
    inst.effects = ReadEffects(*e, names, inst.effects);
  } else if (auto err = urdf_params ? CheckEffects(inst.effects, names) : std::nullopt) {
    node.Required("plant").Fail("file", Escape(urdf_params->file) + ": its joints' " + err->key + ": " + err->message);
  }
  if (inst.mujoco) {
    if (auto i = node.Optional("integrator")) ReadMujocoIntegrator(*i, *inst.mujoco);
    // Lagrange's nearest (MuJoCo's Euler is semi-implicit), for the switch
    // checks' sake; never run: status and telemetry name MuJoCo's (IntegratorName).
    inst.integrator.type = inst.mujoco->integrator == MujocoIntegrator::kEuler ? IntegratorType::kSemiImplicitEuler
                                                                                 : IntegratorType::kRk4;
    inst.integrator.substeps = inst.mujoco->substeps;
    LoadMujocoModel(plant_node, period, urdf, inst);
  } else if (auto i = node.Optional("integrator")) {
    if (inst.external) i->Fail(kExternalNotIntegrated);  // as the integrator command says
    inst.integrator = ReadIntegrator(*i);
    const bool coriolis = inst.effects.coriolis && std::find(inst.effects.off.begin(), inst.effects.off.end(),
                                                             EffectKind::kCoriolis) == inst.effects.off.end();
    if (inst.integrator.type == IntegratorType::kVariational && !coriolis) {
      i->Required("type").Fail(
          kVariationalNeedsCoriolis);  // the command's refusal is the same (Instance::SetIntegrator)
    }
  }
  if (inst.floating && !inst.mujoco) CheckFloatingIntegrator(node, inst.integrator);
  if (auto t = node.Optional("telemetry")) inst.telemetry = t->Bool();
  if (auto f = node.Optional("forces")) inst.forces = f->Bool();
  if (auto e = node.Optional("energy_balance")) inst.energy_balance = ReadEnergyBalanceBound(*e, inst.external.has_value());
  if (inst.floating) CheckFloatingControl(node, inst.mujoco.has_value());
  ReadControl(node, period, inst, urdf);
  CheckExternalControl(node, inst);
  if (!inst.floating) CheckNoStance(node, inst);
  return inst;
}

Scene ReadScene(const YamlReader& root) {
  root.ExpectKeys({"description", "period", "instances", "bus"});
  Scene scene;
  scene.file = root.file();
  if (auto bus = root.Optional("bus")) {
    bus->ExpectKeys({"key_file", "domain"});
    const std::optional<YamlReader> key = bus->Optional("key_file");
    const std::optional<YamlReader> domain = bus->Optional("domain");
    if (!key && !domain) bus->Fail("expected key_file (the bus key) and/or domain (what signatures are bound to)");
    if (key) {
      if (key->Text().empty()) key->Fail("expected the path of a bus key file, got ''");
      // Like a URDF file's path: relative to the scene's directory; an absolute one replaces it.
      scene.bus_key_file = (std::filesystem::path(scene.file).parent_path() / key->Text()).lexically_normal().string();
    }
    if (domain) {
      if (const std::string why = BusDomainProblem("domain", domain->Text()); !why.empty()) {
        domain->Fail("expected 1 to " + std::to_string(kMaxBusDomainBytes) + " printable ASCII characters, got '" +
                     Escape(domain->Text(), 80) + "'");
      }
      scene.bus_domain = domain->Text();
    }
  }
  if (auto d = root.Optional("description")) scene.description = d->Text();
  if (auto p = root.Optional("period")) {
    scene.period = p->PositiveNumber();
    if (scene.period < 1e-5 || scene.period > 1.0) p->Fail("expected a period from 1e-05 to 1 s, got " + p->Text());
  }
  const YamlReader instances = root.Required("instances");
  if (instances.Size() == 0) instances.Fail("expected at least one instance");
  std::set<std::string> names;
  UrdfFiles urdf(scene.file);
  for (std::size_t i = 0; i < instances.Size(); ++i) {
    scene.instances.push_back(ReadInstance(instances.At(i), scene.period, urdf));
    if (!names.insert(scene.instances.back().name).second) {
      instances.At(i).Required("name").Fail("duplicate instance name '" + scene.instances.back().name + "'");
    }
  }
  return scene;
}

}  // namespace

Scene LoadScene(const std::string& path) { return ReadScene(YamlReader::Load(path)); }

std::shared_ptr<const UrdfRobot> FixedBaseOf(const UrdfRobot& floating) {
  auto fixed = std::make_shared<UrdfRobot>(floating);
  fixed->tree.floating_base = false;
  fixed->tree.base = RigidBody{};
  return fixed;
}

RigidTree FloatingTreeOf(const FloatingBaseConfig& floating, const UrdfParams& params) {
  UrdfParams p = params;
  p.robot = floating.robot;
  RigidTree tree = MakeRigidTree(p);  // the joints' bodies scaled, the spec's gravity
  tree.base.mass *= params.mass_scale;
  tree.base.inertia *= params.mass_scale;
  return tree;
}

std::vector<const ControllerConfig*> ControllerConfigs(const InstanceConfig& config) {
  std::vector<const ControllerConfig*> all = {&config.controller};
  for (const ControllerConfig& c : config.alternates) all.push_back(&c);
  return all;
}

ExternalControllerRef ExternalControllerOf(const InstanceConfig& config) {
  const std::vector<const ControllerConfig*> all = ControllerConfigs(config);
  for (std::size_t k = 0; k < all.size(); ++k) {
    if (all[k]->type == ControllerType::kExternal) return {static_cast<int>(k), all[k]};
  }
  return {};
}

std::unique_ptr<Trajectory> MakeTrajectory(const InstanceConfig& c) {
  const TrajectoryConfig& t = c.setpoint;
  const int n = c.plant.num_dofs();
  switch (t.type) {
    case TrajectoryConfig::Type::kHold: return MakeHold(t.q.value_or(c.q0), !t.q.has_value());
    case TrajectoryConfig::Type::kStep: return MakeStep(c.q0, t.target, t.at);
    case TrajectoryConfig::Type::kSine:
      return MakeSine(t.center.value_or(c.q0), t.amplitude, t.frequency, !t.center.has_value());
    case TrajectoryConfig::Type::kMinimumJerk:
      return MakeMinimumJerk(c.q0, c.qd0, VectorXd::Zero(n), t.target, t.duration);
  }
  return MakeHold(c.q0);
}

Scene ParseScene(const std::string& yaml_text, const std::string& file_label) {
  return ReadScene(YamlReader::Parse(yaml_text, file_label));
}

}  // namespace lagrange
