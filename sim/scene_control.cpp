#include "sim/scene_control.hpp"

#include "protocol/channels.hpp"

#include <algorithm>
#include <filesystem>
#include <tuple>

#include "base/escape.hpp"
#include "base/number_text.hpp"

namespace lagrange {

namespace {

// A square matrix of size k: a list of k numbers (its diagonal) or k lists of k.
MatrixXd ReadSquareMatrix(const YamlReader& node, int k) {
  const std::string shape =
      std::to_string(k) + " diagonal values or " + std::to_string(k) + " rows of " + std::to_string(k);
  if (!node.IsSequence()) node.Fail("expected " + shape);
  if (static_cast<int>(node.Size()) != k) {
    node.Fail("expected " + shape + ", got " + std::to_string(node.Size()) + " values");
  }
  if (node.At(0).IsScalar()) return node.Vector(k).asDiagonal();
  MatrixXd m(k, k);
  for (int i = 0; i < k; ++i) m.row(i) = node.At(static_cast<std::size_t>(i)).Vector(k).transpose();
  return m;
}

// A urdf plant's model: its robot, or another file's with the same joints (the
// plant's gravity, its own masses: mass_scale 1), then params.
PlantSpec ReadUrdfModel(const YamlReader& node, const PlantSpec& plant, UrdfFiles& urdf) {
  PlantSpec model = plant;
  if (auto file = node.Optional("file")) {
    auto& p = std::get<UrdfParams>(model.params);
    p.robot = urdf.Load(*file);
    p.file = p.robot->file;
    p.mass_scale = 1.0;  // another file's own masses; only the plant's gravity carries over
    const int n = plant.num_dofs(), m = model.num_dofs();
    if (m != n) {
      file->Fail(Escape(p.file) + " has " + std::to_string(m) + (m == 1 ? " moving joint" : " moving joints") +
                 "; expected " + std::to_string(n) + " like the plant's");
    }
    if (JointTypesOf(model) != JointTypesOf(plant)) {
      file->Fail(Escape(p.file) + ": expected the plant's joint types in order (revolute or prismatic)");
    }
  }
  if (auto params = node.Optional("params")) {
    for (const auto& [key, value] : params->Entries()) SetUrdfParam(model, key, value);
  }
  return model;
}

void ReadModel(const YamlReader& node, const PlantSpec& plant, ControllerConfig& c, UrdfFiles& urdf) {
  if (plant.type() == PlantType::kUrdf) {
    node.ExpectKeys({"file", "params", "method"});
    if (node.Has("file") || node.Has("params")) c.model = ReadUrdfModel(node, plant, urdf);
  } else {
    node.ExpectKeys({"params", "method"});
  }
  if (auto params = node.Optional("params"); params && plant.type() != PlantType::kUrdf) {
    PlantSpec model = plant;
    for (const auto& [key, value] : params->Entries()) {
      if (key == "links") value.Fail("the controller's model has the plant's links");
      if (value.IsSequence()) {
        for (std::size_t i = 0; i < value.Size(); ++i) {
          if (auto err = SetPlantParam(model, key, value.At(i).Text(), static_cast<int>(i)))
            value.At(i).Fail(err->message);
        }
      } else if (auto err = SetPlantParam(model, key, value.Text())) {
        value.Fail(err->message);
      }
    }
    c.model = model;
  }
  if (auto m = node.Optional("method")) {
    const std::optional<Method> method = ParseMethod(m->Text());
    if (!method) m->Fail("expected " + MethodNames() + ", got '" + m->Text() + "'");
    c.model_method = method;
  }
}

// Gains per task axis (x, y, z, rx, ry, rz): one number for all six, a list
// of six, or {translational: a number or [x, y, z], rotational: a number or [rx, ry, rz]}.
VectorXd ReadTaskAxes(const YamlReader& node) {
  if (!node.IsMap()) {
    if (node.IsSequence() && node.Size() != kTaskDims) {
      node.Fail("expected 6 values (x, y, z, rx, ry, rz), one for all, or {translational: ..., rotational: ...}, got " +
                std::to_string(node.Size()) + " values");
    }
    return node.NumberOrVector(kTaskDims);
  }
  node.ExpectKeys({"translational", "rotational"});
  VectorXd v(kTaskDims);
  v.head<3>() = node.Required("translational").NumberOrVector(3);
  v.tail<3>() = node.Required("rotational").NumberOrVector(3);
  return v;
}

// {position: [x, y, z] (m), orientation: [w, x, y, z]}; the orientation
// defaults to none (identity: the world's axes).
Pose ReadPose(const YamlReader& node) {
  node.ExpectKeys({"position", "orientation"});
  Pose p;
  p.position = node.Required("position").Vector(3);
  if (auto o = node.Optional("orientation")) {
    const VectorXd q = o->Vector(4);
    p.orientation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  }
  return p;
}

// trajectory: {type: hold|min-jerk|circle, target: POSE, duration: s, center: [3], normal: [3], frequency: Hz, ramp: s}
PoseTrajectoryConfig ReadPoseTrajectory(const YamlReader& node) {
  PoseTrajectoryConfig t;
  const std::string type = node.Has("type") ? node.Required("type").Text() : "hold";
  if (type == "hold") {
    node.ExpectKeys({"type", "target"});
  } else if (type == "min-jerk") {
    node.ExpectKeys({"type", "target", "duration"});
    t.type = PoseTrajectory::Type::kMinimumJerk;
    t.duration = node.Required("duration").PositiveNumber();
    node.Required("target");
  } else if (type == "circle") {
    node.ExpectKeys({"type", "center", "normal", "frequency", "ramp"});
    t.type = PoseTrajectory::Type::kCircle;
    t.center = node.Required("center").Vector(3);
    if (auto n = node.Optional("normal")) t.normal = n->Vector(3);
    t.frequency = node.Required("frequency").PositiveNumber();
    if (auto r = node.Optional("ramp")) t.ramp = r->NonNegativeNumber();
  } else {
    node.Required("type").Fail("expected hold, min-jerk or circle, got '" + Escape(type, 60) + "'");
  }
  if (auto target = node.Optional("target")) t.target = ReadPose(*target);
  return t;
}

// The task-space keys: frame, stiffness/damping/damping_ratio (impedance) or
// kp/kd (operational space), null_space, singularity, trajectory.
void ReadTaskSpace(const YamlReader& node, int n, ControllerConfig& c) {
  TaskSpaceOptions& t = c.task;
  if (auto f = node.Optional("frame")) {
    t.frame = f->Text();
    if (t.frame.empty()) f->Fail("expected the name of one of the robot's frames, got ''");
  }
  const bool impedance = c.type == ControllerType::kCartesianImpedance;
  const char* kp_key = impedance ? "stiffness" : "kp";
  c.gains.kp = ReadTaskAxes(node.Required(kp_key));
  if (auto d = node.Optional(impedance ? "damping" : "kd")) {
    if (impedance && node.Has("damping_ratio")) d->Fail("expected damping or damping_ratio, not both");
    c.gains.kd = ReadTaskAxes(*d);
  } else if (!impedance) {
    node.Fail("missing key 'kd'");
  }
  if (auto z = node.Optional("damping_ratio")) t.damping_ratio = z->PositiveNumber();
  if (auto ns = node.Optional("null_space")) {
    ns->ExpectKeys({"kp", "kd", "posture"});
    if (auto v = ns->Optional("kp")) t.null_space.kp = v->NumberOrVector(n);
    if (auto v = ns->Optional("kd")) t.null_space.kd = v->NumberOrVector(n);
    if (auto v = ns->Optional("posture")) t.null_space.posture = v->Vector(n);
  }
  if (auto s = node.Optional("singularity")) {
    s->ExpectKeys({"threshold", "max_damping"});
    if (auto v = s->Optional("threshold")) t.singularity.threshold = v->PositiveNumber();
    if (auto v = s->Optional("max_damping")) t.singularity.max_damping = v->PositiveNumber();
  }
  if (auto tr = node.Optional("trajectory")) t.trajectory = ReadPoseTrajectory(*tr);
}

// A cartesian-impedance config's gains are its stiffness and damping in the
// file: the library's "kp[3]: ..." names them so.
std::string SceneKey(const ControllerConfig& c, const YamlReader& node, const std::string& key) {
  if (c.type != ControllerType::kCartesianImpedance) return key;
  if (key.rfind("kp", 0) == 0) return "stiffness" + key.substr(2);
  if (key.rfind("kd", 0) == 0) return (node.Has("damping") ? "damping" : "damping_ratio") + key.substr(2);
  return key;
}

}  // namespace

UrdfFiles::UrdfFiles(const std::string& scene_file) : dir_(std::filesystem::path(scene_file).parent_path().string()) {}

std::shared_ptr<const UrdfRobot> UrdfFiles::Load(const YamlReader& node, const UrdfOptions& options) {
  const std::string name = node.Text();
  if (name.empty()) node.Fail("expected the path of a URDF file, got ''");
  const std::filesystem::path path = std::filesystem::path(dir_) / name;  // an absolute name replaces dir_
  const std::string resolved = path.lexically_normal().string();
  const std::pair<std::string, bool> key{resolved, options.floating_base};
  if (auto it = loaded_.find(key); it != loaded_.end()) return it->second;
  try {
    auto robot = std::make_shared<const UrdfRobot>(LoadUrdf(resolved, options));
    loaded_.emplace(key, robot);
    return robot;
  } catch (const UrdfError& e) {  // one line, escaped by the loader (plant/urdf.hpp)
    node.Fail(e.what());
  } catch (const std::exception& e) {  // anything the parser below it throws
    node.Fail(Escape(e.what(), 400));
  }
}

void SetUrdfParam(PlantSpec& spec, const std::string& key, const YamlReader& value) {
  std::string text;
  if (key == "gravity") {
    if (!value.IsSequence() || value.Size() != 3) value.Fail("expected [gx, gy, gz] (three finite numbers, m/s²)");
    for (std::size_t i = 0; i < 3; ++i) {
      if (i > 0) text += ',';
      text += FormatDouble(value.At(i).Number());
    }
  } else {
    text = value.Text();
  }
  if (auto err = SetPlantParam(spec, key, text)) value.Fail(err->message);
}

namespace {

// The keys a controller of `type` takes; any other is refused, named.
void ExpectControllerKeys(const YamlReader& node, ControllerType type) {
  switch (type) {
    case ControllerType::kNone: node.ExpectKeys({"type", "continuous"}); break;
    case ControllerType::kPd:
      node.ExpectKeys({"type", "kp", "kd", "velocity_feedforward", "acceleration_feedforward", "model", "continuous",
                       "gravity_compensation", "feet", "contact_height"});
      break;
    case ControllerType::kGravityCompensation:
      node.ExpectKeys({"type", "kp", "kd", "velocity_feedforward", "acceleration_feedforward", "model", "continuous"});
      break;
    case ControllerType::kComputedTorque: node.ExpectKeys({"type", "kp", "kd", "model", "continuous"}); break;
    case ControllerType::kCartPolePd: node.ExpectKeys({"type", "kp", "kd", "continuous"}); break;
    case ControllerType::kLqr:
      node.ExpectKeys({"type", "equilibrium", "actuated", "Q", "R", "design", "model", "continuous"});
      break;
    case ControllerType::kSwingUp:
      node.ExpectKeys({"type", "equilibrium", "actuated", "Q", "R", "design", "model", "energy_gain", "max_accel",
                       "cart_gain", "cart_damping", "switch_angle", "switch_rate", "continuous"});
      break;
    case ControllerType::kExternal:
      node.ExpectKeys({"type", "torque_timeout", "torque_channel", "fallback", "compensate_gravity", "model"});
      break;
    case ControllerType::kCartesianImpedance:
      node.ExpectKeys({"type", "frame", "stiffness", "damping", "damping_ratio", "null_space", "singularity",
                       "trajectory", "model", "continuous"});
      break;
    case ControllerType::kOperationalSpace:
      node.ExpectKeys({"type", "frame", "kp", "kd", "null_space", "singularity", "trajectory", "model", "continuous"});
      break;
    case ControllerType::kMpc:
      node.ExpectKeys({"type", "horizon", "dt", "integrator", "iterations", "replan_period", "actuated", "weights",
                       "fallback", "model", "frame", "pose_weight", "pose_terminal_weight", "trajectory"});
      break;
  }
}

// kp and kd: the task-space gains, or one number or n per joint (gravity compensation's default to zero).
void ReadGains(const YamlReader& node, int n, ControllerConfig& c) {
  const bool gains_optional = c.type == ControllerType::kGravityCompensation;
  if (IsTaskSpace(c.type)) {
    ReadTaskSpace(node, n, c);
  } else if (HasGains(c.type)) {
    for (const auto& [key, out] : {std::pair{"kp", &c.gains.kp}, std::pair{"kd", &c.gains.kd}}) {
      if (auto g = node.Optional(key))
        *out = g->NumberOrVector(n);
      else if (gains_optional)
        *out = VectorXd::Zero(n);
      else
        node.Fail(std::string("missing key '") + key + "'");
    }
  }
}

// pd's gravity_compensation: stance (a floating base standing on its feet), feet, contact_height.
void ReadStance(const YamlReader& node, ControllerConfig& c) {
  if (auto v = node.Optional("gravity_compensation")) {
    const std::string g = v->Text();
    if (g != "stance" && g != "none") {
      v->Fail("expected stance (G balanced by the feet in contact, on a floating base) or none, got '" + Escape(g, 60) +
              "'");
    }
    c.stance.on = g == "stance";
  }
  if (auto v = node.Optional("feet")) {
    if (!v->IsSequence()) v->Fail("expected a list of the robot's foot frames");
    for (std::size_t i = 0; i < v->Size(); ++i) c.stance.feet.push_back(v->At(i).Text());
  }
  if (auto v = node.Optional("contact_height")) c.stance.contact_height = v->PositiveNumber();
}

// LQR (and swing-up's LQR near the top): equilibrium, actuated, Q, design, R.
void ReadLqr(const YamlReader& node, const PlantSpec& plant, int n, ControllerConfig& c) {
  if (auto v = node.Optional("equilibrium")) c.lqr.equilibrium = v->Vector(n);
  if (auto v = node.Optional("actuated")) {
    std::vector<int> act;
    for (std::size_t i = 0; i < v->Size(); ++i) act.push_back(v->At(i).Integer(0, n - 1));
    c.lqr.actuated = act;
  }
  if (auto v = node.Optional("Q")) c.lqr.Q = ReadSquareMatrix(*v, 2 * n);
  if (auto v = node.Optional("design")) {
    const std::string design = v->Text();
    if (design != "continuous" && design != "discrete") {
      v->Fail("expected continuous or discrete, got '" + Escape(design, 60) + "'");
    }
    c.lqr.discrete = design == "discrete";
  }
  if (auto v = node.Optional("R")) {
    const int m =
        c.lqr.actuated ? static_cast<int>(c.lqr.actuated->size()) : (plant.type() == PlantType::kCartPole ? 1 : n);
    c.lqr.R = ReadSquareMatrix(*v, m);
  }
}

// Swing-up's energy pump and its switch to LQR.
void ReadSwingUp(const YamlReader& node, ControllerConfig& c) {
  SwingUpOptions& s = c.swing_up;
  for (const auto& [key, out] :
       {std::pair{"energy_gain", &s.energy_gain}, std::pair{"max_accel", &s.max_accel},
        std::pair{"switch_angle", &s.switch_angle}, std::pair{"switch_rate", &s.switch_rate}}) {
    if (auto v = node.Optional(key)) *out = v->PositiveNumber();
  }
  for (const auto& [key, out] : {std::pair{"cart_gain", &s.cart_gain}, std::pair{"cart_damping", &s.cart_damping}}) {
    if (auto v = node.Optional(key)) *out = v->NonNegativeNumber();
  }
}

// The external controller: its torque stream's timeout and channel, the fallback, gravity compensation.
void ReadExternal(const YamlReader& node, double period, ControllerConfig& c) {
  if (auto v = node.Optional("torque_timeout")) {
    c.external.torque_timeout = v->PositiveNumber();
    if (c.external.torque_timeout < 2.0 * period) {
      v->Fail("expected at least two ticks (" + FormatDouble(2.0 * period) + " s): a torque is held over a tick");
    }
  }
  if (auto v = node.Optional("torque_channel")) {
    c.external.torque_channel = v->Text();
    if (const std::string why = CheckChannelName(c.external.torque_channel); !why.empty()) v->Fail(why);
  }
  if (auto v = node.Optional("fallback")) c.external.fallback = v->Text();
  if (auto v = node.Optional("compensate_gravity")) c.external.compensate_gravity = v->Bool();
}

// mpc: the plan's horizon (knots), dt, the optimiser's integrator, iterations per solve, replan_period, the
// actuated joints, the weights {q, qd, tau, q_terminal, qd_terminal} (one number or one per joint; tau one per
// actuated joint), the fallback, and a frame's pose error: frame, pose_weight and pose_terminal_weight
// ([position, rotation]), trajectory (the task-space controllers' key). Ranges: ValidateMpc
// (controllers/mpc.hpp), through Validate below.
void ReadMpc(const YamlReader& node, const PlantSpec& plant, int n, ControllerConfig& c) {
  if (c.type != ControllerType::kMpc) return;
  MpcOptions& o = c.mpc;
  if (auto v = node.Optional("horizon")) o.horizon = v->Integer(1, kMaxMpcHorizon);
  if (auto v = node.Optional("dt")) o.dt = v->PositiveNumber();
  if (auto v = node.Optional("integrator")) {
    const std::optional<IntegratorType> type = ParseIntegratorType(v->Text());
    if (!type || NoStepDerivativesReason(*type) != nullptr) {
      v->Fail("expected explicit-euler, semi-implicit-euler or rk4 (an integrator with step derivatives), got '" +
              Escape(v->Text(), 60) + "'");
    }
    o.integrator = *type;
  }
  if (auto v = node.Optional("iterations")) o.iterations = v->Integer(1, kMaxMpcIterations);
  if (auto v = node.Optional("replan_period")) o.replan_period = v->NonNegativeNumber();
  if (auto v = node.Optional("actuated")) {
    std::vector<int> act;
    for (std::size_t i = 0; i < v->Size(); ++i) act.push_back(v->At(i).Integer(0, n - 1));
    o.actuated = act;
  }
  if (auto w = node.Optional("weights")) {
    w->ExpectKeys({"q", "qd", "tau", "q_terminal", "qd_terminal"});
    const int m = static_cast<int>(MpcActuated(o, n, plant.type() == PlantType::kCartPole).size());
    for (const auto& [key, out, size] :
         {std::tuple{"q", &o.q, n}, std::tuple{"qd", &o.qd, n}, std::tuple{"tau", &o.tau, m},
          std::tuple{"q_terminal", &o.q_terminal, n}, std::tuple{"qd_terminal", &o.qd_terminal, n}}) {
      if (auto v = w->Optional(key)) *out = v->NumberOrVector(size);
    }
  }
  if (auto v = node.Optional("fallback")) o.fallback = v->Text();
  if (auto f = node.Optional("frame")) {
    o.frame = f->Text();
    if (o.frame.empty()) f->Fail("expected the name of one of the robot's frames, got ''");
  }
  if (auto v = node.Optional("pose_weight")) o.pose_weight = v->Vector(2);
  if (auto v = node.Optional("pose_terminal_weight")) o.pose_terminal_weight = v->Vector(2);
  if (auto tr = node.Optional("trajectory")) o.trajectory = ReadPoseTrajectory(*tr);
}

// The controller library's verdict on `c`; a refusal names the key in the file when there is one.
void Validate(const YamlReader& node, const PlantSpec& plant, const ControllerConfig& c) {
  if (auto err = ValidateController(c, plant)) {
    // "key: message" from the controller library; point at that key when it is in the file.
    const std::size_t colon = err->find(": ");
    const std::string key = colon == std::string::npos ? "" : SceneKey(c, node, err->substr(0, colon));
    const std::string first = key.substr(0, key.find_first_of(",.[ "));
    if (!key.empty() && node.Has(first)) node.Fail(key, err->substr(colon + 2));
    node.Fail(*err);
  }
}

}  // namespace

ControllerConfig ReadController(const YamlReader& node, const PlantSpec& plant, double period, const VectorXd& q0,
                                const IntegratorConfig& integrator, UrdfFiles& urdf) {
  const int n = plant.num_dofs();
  const YamlReader type_node = node.Required("type");
  const std::optional<ControllerType> type = ParseControllerType(type_node.Text());
  if (!type) type_node.Fail("expected one of " + ControllerTypeNames() + ", got '" + type_node.Text() + "'");
  ControllerConfig c;
  c.type = *type;
  c.period = period;
  c.q0 = q0;
  c.integrator = integrator;
  ExpectControllerKeys(node, c.type);
  ReadGains(node, n, c);
  if (auto v = node.Optional("velocity_feedforward")) c.pd.velocity_feedforward = v->Bool();
  if (auto v = node.Optional("acceleration_feedforward")) c.pd.acceleration_feedforward = v->Bool();
  ReadStance(node, c);
  if (auto m = node.Optional("model")) ReadModel(*m, plant, c, urdf);
  if (auto v = node.Optional("continuous")) c.continuous = v->Bool();
  ReadLqr(node, plant, n, c);
  ReadSwingUp(node, c);
  if (c.type == ControllerType::kExternal) ReadExternal(node, period, c);
  ReadMpc(node, plant, n, c);
  Validate(node, plant, c);
  return c;
}

TrajectoryConfig ReadTrajectory(const YamlReader& node, int n) {
  TrajectoryConfig t;
  const std::string type = node.Has("type") ? node.Required("type").Text() : "hold";
  if (type == "hold") {
    node.ExpectKeys({"type", "q"});
    if (auto q = node.Optional("q")) t.q = q->Vector(n);
  } else if (type == "step") {
    node.ExpectKeys({"type", "target", "at"});
    t.type = TrajectoryConfig::Type::kStep;
    t.target = node.Required("target").Vector(n);
    if (auto at = node.Optional("at")) t.at = at->NonNegativeNumber();
  } else if (type == "sine") {
    node.ExpectKeys({"type", "amplitude", "frequency", "center"});
    t.type = TrajectoryConfig::Type::kSine;
    t.amplitude = node.Required("amplitude").NumberOrVector(n);
    t.frequency = node.Required("frequency").NumberOrVector(n);
    if ((t.frequency.array() < 0.0).any()) node.Required("frequency").Fail("expected frequencies >= 0 Hz");
    if (auto c = node.Optional("center")) t.center = c->Vector(n);
  } else if (type == "min-jerk") {
    node.ExpectKeys({"type", "target", "duration"});
    t.type = TrajectoryConfig::Type::kMinimumJerk;
    t.target = node.Required("target").Vector(n);
    t.duration = node.Required("duration").PositiveNumber();
  } else {
    node.Required("type").Fail("expected hold, step, sine or min-jerk, got '" + type + "'");
  }
  return t;
}

}  // namespace lagrange
