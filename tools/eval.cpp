// lagrangectl eval: M, C, G, qdd, T and V of a plant at one state, as JSON:
// a built-in plant (--plant) or a robot from a URDF file (--urdf); with
// --frame NAME, that frame's pose, Jacobian and J̇ qd (plant/kinematics.hpp,
// world-aligned axes); with --frames, the plant's frame names alone; with
// --derivatives, the exact derivatives of forward and inverse dynamics at the
// state (plant/dynamics.hpp). With --floating-base, a URDF robot on a free
// base (plant/floating_dynamics.hpp; q of nq = nv + 1, v of nv, Pinocchio's
// conventions: plant/rigid_tree.hpp), by the recursive path (the default) or
// the Lagrangian one (--method lagrangian: plant/floating_lagrangian.hpp).

#include <algorithm>
#include <nlohmann/json.hpp>

#include "base/escape.hpp"
#include "plant/floating_dynamics.hpp"
#include "plant/floating_lagrangian.hpp"
#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "protocol/format.hpp"
#include "sim/scene.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {
namespace {

// "a,b,c" => {"a", "b", "c"}
std::vector<std::string> SplitCommas(const std::string& text) {
  std::vector<std::string> items;
  std::size_t start = 0;
  for (std::size_t comma; (comma = text.find(',', start)) != std::string::npos; start = comma + 1) {
    items.push_back(text.substr(start, comma - start));
  }
  items.push_back(text.substr(start));
  return items;
}

// --param NAME=VALUE; for a chain, VALUE may be a comma-separated list with one value per link.
void SetParam(PlantSpec& spec, const std::string& name, const std::string& value) {
  if (spec.type() != PlantType::kChain || value.find(',') == std::string::npos) {
    if (auto e = SetPlantParam(spec, name, value)) throw UsageError("--param " + e->key + ": " + e->message);
    return;
  }
  if (name == "links" || name == "g" || name == "base_angle") {
    throw UsageError("--param " + name + ": expected a single value, got '" + value + "'");
  }
  const std::vector<std::string> items = SplitCommas(value);
  const int links = spec.num_dofs();
  if (static_cast<int>(items.size()) != links) {
    throw UsageError("--param " + name + ": expected " + std::to_string(links) + " values (one per link), got " +
                     std::to_string(items.size()));
  }
  for (int i = 0; i < links; ++i) {
    if (auto e = SetPlantParam(spec, name, items[static_cast<std::size_t>(i)], i)) {
      throw UsageError("--param " + e->key + "[" + std::to_string(i) + "]: " + e->message);
    }
  }
}

// A vector as a list of numbers.
std::vector<double> JsonList(const VectorXd& v) { return {v.begin(), v.end()}; }

// A matrix as a list of rows.
std::vector<std::vector<double>> JsonRows(const MatrixXd& m) {
  std::vector<std::vector<double>> rows;
  for (int i = 0; i < m.rows(); ++i) rows.push_back(JsonList(m.row(i).transpose()));
  return rows;
}

// The frames named by --frame at (q, qd), world-aligned: {NAME: {position,
// rotation, jacobian, jdot_qdot}}. An unknown name is bad input.
nlohmann::ordered_json FramesJson(const PlantSpec& spec, const std::vector<std::string>& names, const VectorXd& q,
                                  const VectorXd& qd) {
  const Kinematics model(MakeRigidTree(spec));
  const std::unique_ptr<KinematicsData> data = model.MakeData();
  std::vector<int> frames;
  for (const std::string& name : names) {
    const std::optional<int> k = model.FrameIndex(name);
    if (!k) throw UsageError("--frame: no frame '" + Escape(name, 64) + "' in this plant (--frames lists them)");
    frames.push_back(*k);
  }
  model.ComputeFrameKinematics(*data, q, qd);
  nlohmann::ordered_json json = nlohmann::ordered_json::object();
  for (std::size_t i = 0; i < names.size(); ++i) {
    const int k = frames[i];
    const FrameAxes axes = FrameAxes::kWorldAligned;
    if (!data->jacobian(k, axes).allFinite() || !data->bias_acceleration(k, axes).allFinite() ||
        !data->position(k).allFinite()) {
      throw std::runtime_error("the frame '" + Escape(names[i], 64) + "' is not finite at this state");
    }
    json[names[i]] = {{"position", JsonList(data->position(k))},
                      {"rotation", JsonRows(data->rotation(k))},
                      {"jacobian", JsonRows(data->jacobian(k, axes))},
                      {"jdot_qdot", JsonList(data->bias_acceleration(k, axes))}};
  }
  return json;
}

// ∂qdd/∂(q, qd, tau) at (q, qd, tau) and ∂tau/∂(q, qd) at (q, qd, qdd), the
// model's exact derivatives: {NAME: rows}. Not finite is an error (JSON has no nan).
nlohmann::ordered_json DerivativesJson(const Dynamics& dynamics, DynamicsData& data, const VectorXd& q,
                                       const VectorXd& qd, const VectorXd& tau, const VectorXd& qdd) {
  const int n = dynamics.num_dofs();
  VectorXd qdd_again(n);
  MatrixXd dqdd_dq(n, n), dqdd_dqd(n, n), dqdd_dtau(n, n), dtau_dq(n, n), dtau_dqd(n, n), M(n, n);
  dynamics.ComputeForwardDynamicsDerivatives(data, q, qd, tau, DynamicsTerms{}, qdd_again, dqdd_dq, dqdd_dqd,
                                             dqdd_dtau);
  dynamics.ComputeInverseDynamicsDerivatives(data, q, qd, qdd, DynamicsTerms{}, dtau_dq, dtau_dqd, M);
  for (const MatrixXd* m : {&dqdd_dq, &dqdd_dqd, &dqdd_dtau, &dtau_dq, &dtau_dqd}) {
    if (!m->allFinite()) throw std::runtime_error("the derivatives are not finite at this state");
  }
  return {{"dqdd_dq", JsonRows(dqdd_dq)},
          {"dqdd_dqd", JsonRows(dqdd_dqd)},
          {"dqdd_dtau", JsonRows(dqdd_dtau)},
          {"dtau_dq", JsonRows(dtau_dq)},
          {"dtau_dqd", JsonRows(dtau_dqd)}};
}

// One JSON object on one line. A URDF's names are the file's bytes: JSON
// escapes control characters, and replaces invalid UTF-8.
int PrintJson(std::ostream& out, const nlohmann::ordered_json& json) {
  out << json.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace) << "\n";
  return 0;
}

// A floating base's quaternion may be off unit by this much, as typed
// with four digits (0.7071,0,0,0.7071: 1e-5 off); it is then normalised.
// Beyond it, refused: a typing error, not rounding.
constexpr double kQuaternionNormTolerance = 1e-4;

// --q of a floating-base robot: nq = nv + 1 numbers (n degrees of freedom:
// a mimic joint has none), the quaternion within kQuaternionNormTolerance of
// unit, returned normalised.
VectorXd FloatingPositions(const std::vector<double>& values, int dofs) {
  const int nq = dofs + kFreeFlyerNq;
  if (static_cast<int>(values.size()) != nq) {
    throw UsageError("--q: expected " + std::to_string(nq) + " values (nq = nv + 1: the base's x,y,z, its quaternion " +
                     "qx,qy,qz,qw, then " + std::to_string(dofs) + " joints), got " + std::to_string(values.size()));
  }
  VectorXd q = Eigen::Map<const VectorXd>(values.data(), nq);
  const double norm = q.segment<4>(3).norm();
  if (!(std::abs(norm - 1.0) <= kQuaternionNormTolerance)) {
    throw UsageError("--q: the quaternion qx,qy,qz,qw (values 4 to 7) has norm " + FormatDouble(norm) +
                     "; expected a unit quaternion (to 1e-04, then normalised)");
  }
  q.segment<4>(3) /= norm;
  return q;
}

// --qd or --tau of a floating-base robot: nv numbers.
VectorXd FloatingVelocities(std::string_view option, const std::vector<double>& values, int dofs) {
  const int nv = dofs + kFreeFlyerNv;
  if (static_cast<int>(values.size()) != nv) {
    throw UsageError(std::string(option) + ": expected " + std::to_string(nv) +
                     " values (nv: the base's linear then angular entries, in base axes, then " +
                     std::to_string(dofs) + " joints), got " + std::to_string(values.size()));
  }
  return Eigen::Map<const VectorXd>(values.data(), nv);
}

// What eval prints of a floating-base robot at (q, v, tau), by either path.
struct FloatingTerms {
  MatrixXd M;        // (nv x nv)
  VectorXd Cv, G, a;  // (nv)
  double T = 0.0, V = 0.0;
};

// (q, v, tau) => M, C v, G, a, T, V by `Model` (FloatingDynamics or
// FloatingLagrangian: the same calls); not finite is an error.
template <class Model>
FloatingTerms ComputeFloatingTerms(const Model& model, ConstVecRef q, ConstVecRef v, ConstVecRef tau) {
  const int nv = model.num_v();
  const VectorXd zero = VectorXd::Zero(nv);
  const auto data = model.MakeData();
  FloatingTerms t{MatrixXd(nv, nv), VectorXd(nv), VectorXd(nv), VectorXd(nv)};
  model.ComputeMassMatrix(*data, q, t.M);
  model.ComputeInverseDynamics(*data, q, v, zero, DynamicsTerms{.gravity = false, .coriolis = true}, t.Cv);
  model.ComputeInverseDynamics(*data, q, zero, zero, DynamicsTerms{.gravity = true, .coriolis = false}, t.G);
  model.ComputeForwardDynamics(*data, q, v, tau, DynamicsTerms{}, t.a);
  t.T = model.ComputeKineticEnergy(*data, q, v);
  t.V = model.ComputePotentialEnergy(*data, q);
  if (!t.M.allFinite() || !t.Cv.allFinite() || !t.G.allFinite() || !t.a.allFinite() || !std::isfinite(t.T) ||
      !std::isfinite(t.V)) {
    throw std::runtime_error("the dynamics are not finite at this state");
  }
  return t;
}

// The frames named by --frame of a floating-base robot at (q, v): {NAME: {position,
// rotation, jacobian (6 x nv), jdot_qdot (J̇ v)}}, world axes, as a fixed
// base's frames (FramesJson). An unknown name is bad input.
nlohmann::ordered_json FloatingFramesJson(const FloatingDynamics& model, FloatingData& data,
                                          const std::vector<std::string>& names, const VectorXd& q, const VectorXd& v) {
  const std::vector<std::string> all = model.tree().frame_names();
  nlohmann::ordered_json json = nlohmann::ordered_json::object();
  MatrixXd J(6, model.num_v());
  for (const std::string& name : names) {
    const auto it = std::find(all.begin(), all.end(), name);
    if (it == all.end()) {
      throw UsageError("--frame: no frame '" + Escape(name, 64) + "' in this plant (--frames lists them)");
    }
    const int k = static_cast<int>(it - all.begin());
    Vector6d jdot_v;
    model.ComputeFrameAccelerationBias(data, q, v, k, jdot_v);
    model.ComputeFrameJacobian(data, q, k, J);
    if (!J.allFinite() || !jdot_v.allFinite() || !data.frame_position(k).allFinite()) {
      throw std::runtime_error("the frame '" + Escape(name, 64) + "' is not finite at this state");
    }
    json[name] = {{"position", JsonList(data.frame_position(k))},
                  {"rotation", JsonRows(data.frame_rotation(k))},
                  {"jacobian", JsonRows(J)},
                  {"jdot_qdot", JsonList(jdot_v)}};
  }
  return json;
}

class EvalCommand final : public Command {
 public:
  explicit EvalCommand(CLI::App& parent)
      : Command(parent.add_subcommand("eval", "Evaluate M, C, G, qdd, T and V at one state (JSON)")) {
    auto* plant = app_->add_option("--plant", plant_, "Plant type: pendulum|arm2|cartpole|chain (or --urdf)");
    auto* urdf = app_->add_option("--urdf", urdf_, "A robot from a URDF file instead of --plant");
    plant->excludes(urdf);
    app_->add_option("--gravity", gravity_,
                     "With --urdf: gravity gx,gy,gz in the root link's frame (m/s²); default 0,0,-9.81")
        ->delimiter(',')
        ->allow_extra_args(false)
        ->check(FiniteNumber());
    app_->add_option("--links", links_, "Number of links (chain)");
    app_->add_option("--param", params_,
                     "NAME=VALUE, repeatable (m1, m2, L1, L2, mc, mp, l, I, m, L, g, ...; mass_scale with --urdf); a "
                     "chain's m, L, com, I and joints (revolute|prismatic) take one value for every link or a list: "
                     "m=1,0.8,0.5");
    // Required unless --frames (checked in Run).
    AddNumberList(*app_, "--q", q_, "Positions a,b,.. (rad or m); required");
    AddNumberList(*app_, "--qd", qd_, "Velocities c,d,.. (rad/s or m/s); required");
    AddNumberList(*app_, "--tau", tau_, "Generalized forces e,f,.. (N·m or N); default zeros");
    app_->add_option("--method", method_,
                     "closed-form|lagrangian|recursive; default the fastest exact path (recursive or lagrangian "
                     "with --floating-base)");
    auto* frame = app_->add_option("--frame", frames_,
                                   "NAME, repeatable: add the frame's position, rotation, Jacobian (6 x n) and "
                                   "J̇ qd, world-aligned axes, under \"frames\"");
    auto* frames = app_->add_flag("--frames", list_frames_, "Print the plant's frame names (no state needed)");
    frames->excludes(frame);
    app_->add_flag("--derivatives", derivatives_,
                   "Add the exact derivatives under \"derivatives\": dqdd_dq, dqdd_dqd, dqdd_dtau at (q, qd, tau) and "
                   "dtau_dq, dtau_dqd at (q, qd, qdd) with the printed qdd (rows per output, joint order of \"joints\")")
        ->excludes(frames);
    app_->add_flag("--floating-base", floating_base_,
                   "With --urdf: the root link is a free base (a <joint type=\"floating\"> from the root link: its "
                   "child). --q is nq = nv + 1 values: the base's position x,y,z (m, world), its orientation as a unit "
                   "quaternion in the order qx,qy,qz,qw (w last, Pinocchio's; within 1e-4 of unit, then normalised), "
                   "then the joints; --qd and --tau are nv: the base's linear velocity (m/s) then angular velocity "
                   "(rad/s), both in base axes (force N, moment N·m for --tau), then the joints (a mimic joint has no "
                   "entry). Prints M (nv x nv), Cv (the Coriolis and centrifugal forces C v), G, qdd (v̇), T, V and "
                   "frames' Jacobians (6 x nv) and jdot_qdot (J̇ v); --method recursive (default) or lagrangian (the "
                   "Euler–Poincaré form); --param mass_scale=S scales the base too; not with --derivatives yet");
  }

  int Run(std::ostream& out, std::ostream&) override {
    if (floating_base_) return RunFloating(out);
    PlantSpec spec = Spec();
    const PlantType type = spec.type();
    if (list_frames_) {
      return PrintJson(out, {{"plant", ToString(type)}, {"frame_names", MakeRigidTree(spec).frame_names()}});
    }
    if (q_.empty()) throw UsageError("--q is required");
    if (qd_.empty()) throw UsageError("--qd is required");
    const std::string what = type == PlantType::kUrdf ? "a urdf robot" : plant_;

    Method method = FastestMethod(type);
    if (method_) {
      const std::optional<Method> m = ParseMethod(*method_);
      if (!m) throw UsageError("--method: expected closed-form, lagrangian or recursive, got '" + *method_ + "'");
      if (!HasMethod(type, *m)) {
        throw UsageError("--method: " + what + " has no " + *method_ + " path (use lagrangian or recursive)");
      }
      method = *m;
    }

    const int n = spec.num_dofs();
    const VectorXd q = JointValues("--q", q_, n);
    const VectorXd qd = JointValues("--qd", qd_, n);
    const VectorXd tau = tau_.empty() ? VectorXd::Zero(n) : JointValues("--tau", tau_, n);

    const std::unique_ptr<Dynamics> dynamics = MakeDynamics(spec, method);
    const std::unique_ptr<DynamicsData> data = dynamics->MakeData();
    MatrixXd M(n, n), C(n, n);
    VectorXd G(n), qdd(n);
    dynamics->ComputeMassMatrix(*data, q, M);
    dynamics->ComputeCoriolisMatrix(*data, q, qd, C);
    dynamics->ComputeGravityForce(*data, q, G);
    dynamics->ComputeForwardDynamics(*data, q, qd, tau, DynamicsTerms{}, qdd);
    const double T = dynamics->ComputeKineticEnergy(*data, q, qd);
    const double V = dynamics->ComputePotentialEnergy(*data, q);
    // Every value printed is finite (JSON has no inf or nan).
    if (!M.allFinite() || !C.allFinite() || !G.allFinite() || !qdd.allFinite() || !std::isfinite(T) ||
        !std::isfinite(V)) {
      throw std::runtime_error("the dynamics are not finite at this state");
    }

    // ordered_json keeps the keys in the order written; dump() prints the shortest text that reads back to each double.
    nlohmann::ordered_json json = {{"plant", ToString(type)},
                                   {"method", ToString(method)},
                                   {"num_dofs", n},
                                   {"num_positions", n},
                                   {"num_velocities", n},
                                   {"joints", JointNamesOf(spec)},
                                   {"M", JsonRows(M)},
                                   {"C", JsonRows(C)},
                                   {"G", JsonList(G)},
                                   {"qdd", JsonList(qdd)},
                                   {"T", T},
                                   {"V", V}};
    if (!frames_.empty()) json["frames"] = FramesJson(spec, frames_, q, qd);
    if (derivatives_) json["derivatives"] = DerivativesJson(*dynamics, *data, q, qd, tau, qdd);
    return PrintJson(out, json);
  }

 private:
  // --floating-base: the robot of --urdf on a free base, by FloatingDynamics
  // or (--method lagrangian) FloatingLagrangian; frames by FloatingDynamics.
  int RunFloating(std::ostream& out) const {
    const Method method = FloatingMethod();
    const FloatingDynamics model(FloatingTree());
    if (list_frames_) {
      return PrintJson(out, {{"plant", "urdf"}, {"floating_base", true}, {"frame_names", model.tree().frame_names()}});
    }
    if (q_.empty()) throw UsageError("--q is required");
    if (qd_.empty()) throw UsageError("--qd is required");
    const int n = model.num_dofs(), nv = model.num_v();
    const VectorXd q = FloatingPositions(q_, n);
    const VectorXd v = FloatingVelocities("--qd", qd_, n);
    const VectorXd tau = tau_.empty() ? VectorXd::Zero(nv) : FloatingVelocities("--tau", tau_, n);
    const FloatingTerms t = method == Method::kLagrangian
                                ? ComputeFloatingTerms(FloatingLagrangian(model.tree()), q, v, tau)
                                : ComputeFloatingTerms(model, q, v, tau);
    nlohmann::ordered_json json = {{"plant", "urdf"},
                                   {"method", ToString(method)},
                                   {"floating_base", true},
                                   {"num_dofs", n},
                                   {"num_positions", model.num_q()},
                                   {"num_velocities", nv},
                                   {"joints", model.tree().joint_names()},
                                   {"M", JsonRows(t.M)},
                                   {"Cv", JsonList(t.Cv)},
                                   {"G", JsonList(t.G)},
                                   {"qdd", JsonList(t.a)},
                                   {"T", t.T},
                                   {"V", t.V}};
    if (!frames_.empty()) {
      const std::unique_ptr<FloatingData> data = model.MakeData();
      json["frames"] = FloatingFramesJson(model, *data, frames_, q, v);
    }
    return PrintJson(out, json);
  }

  // --method with --floating-base: recursive (the default) or lagrangian.
  Method FloatingMethod() const {
    if (!method_) return Method::kRecursive;
    const std::optional<Method> m = ParseMethod(*method_);
    if (!m || *m == Method::kClosedForm) {
      throw UsageError("--method: a floating base has the recursive and lagrangian paths, got '" +
                       Escape(*method_, 64) + "'");
    }
    return *m;
  }

  // The tree of --urdf read with a floating base, with --gravity and --param
  // mass_scale (the base's mass and inertia scaled too, as a scene's
  // `params` do: sim/scene.hpp's FloatingTreeOf); what a floating base does
  // not take yet refused in one line.
  RigidTree FloatingTree() const {
    if (urdf_.empty()) throw UsageError("--floating-base: only with --urdf FILE (a built-in plant's base is fixed)");
    if (derivatives_) throw UsageError("--derivatives: not with --floating-base yet (its derivatives are not built)");
    FloatingBaseConfig floating;
    floating.robot = LoadRobot(UrdfOptions{.floating_base = true});
    const PlantSpec spec = UrdfSpec(FixedBaseOf(*floating.robot), false);
    RigidTree tree = FloatingTreeOf(floating, std::get<UrdfParams>(spec.params));
    if (auto e = ValidateFloatingTree(tree)) throw UsageError("--param mass_scale: " + Escape(*e, 400));
    return tree;
  }

  // --gravity gx,gy,gz (each finite: FiniteNumber).
  Eigen::Vector3d Gravity() const {
    if (gravity_.size() != 3) {
      throw UsageError("--gravity: expected gx,gy,gz (3 numbers, m/s²), got " + std::to_string(gravity_.size()));
    }
    return {gravity_[0], gravity_[1], gravity_[2]};
  }

  // The plant from --urdf, or from --plant, --links and --param.
  PlantSpec Spec() const {
    if (urdf_.empty() && plant_.empty()) throw UsageError("expected --plant TYPE or --urdf FILE");
    if (!urdf_.empty()) return UrdfSpec(LoadRobot());
    if (!gravity_.empty()) throw UsageError("--gravity: only with --urdf (a planar plant's gravity is --param g=..)");
    const std::optional<PlantType> type = ParsePlantType(plant_);
    if (!type || *type == PlantType::kUrdf) {
      throw UsageError("--plant: expected one of pendulum|arm2|cartpole|chain, got '" + plant_ + "' (or --urdf FILE)");
    }
    PlantSpec spec = DefaultPlantSpec(*type);
    if (links_) {
      if (*type != PlantType::kChain) throw UsageError("--links: only a chain has links");
      if (auto e = SetChainLinks(spec, *links_)) throw UsageError("--links: " + e->message);
    }
    // The chain's link count first, so per-link lists are checked against it (as a scene does).
    std::vector<std::string> params = params_;
    std::stable_partition(params.begin(), params.end(), [](const std::string& p) { return p.starts_with("links="); });
    for (const std::string& p : params) {
      const std::size_t eq = p.find('=');
      if (eq == std::string::npos) throw UsageError("--param: expected NAME=VALUE, got '" + p + "'");
      SetParam(spec, p.substr(0, eq), p.substr(eq + 1));
    }
    if (auto e = ValidatePlantSpec(spec)) throw UsageError("--param " + e->key + ": " + e->message);
    return spec;
  }

  // The robot of --urdf; the file's problems are bad input.
  std::shared_ptr<const UrdfRobot> LoadRobot(UrdfOptions options = {}) const {
    try {
      return std::make_shared<const UrdfRobot>(LoadUrdf(urdf_, options));
    } catch (const UrdfError& e) {  // one line, escaped by the loader (plant/urdf.hpp)
      throw UsageError("--urdf: " + std::string(e.what()));
    } catch (const std::exception& e) {  // anything the parser below it throws
      throw UsageError("--urdf: " + Escape(e.what(), 400));
    }
  }

  // --urdf FILE [--gravity gx,gy,gz] [--param mass_scale=S], of `robot` (the
  // file's robot, or a floating robot's joints: FixedBaseOf, which may have
  // none, so not `validate`d as a fixed plant: FloatingTree checks its tree).
  PlantSpec UrdfSpec(std::shared_ptr<const UrdfRobot> robot, bool validate = true) const {
    if (links_) throw UsageError("--links: a urdf robot has the joints its file gives");
    PlantSpec spec = UrdfPlantSpec(std::move(robot));
    if (!gravity_.empty()) {
      const Eigen::Vector3d g3 = Gravity();
      std::string text;
      for (double g : g3) text += (text.empty() ? "" : ",") + FormatDouble(g);
      if (auto e = SetPlantParam(spec, "gravity", text)) throw UsageError("--gravity: " + e->message);
    }
    for (const std::string& p : params_) {
      const std::size_t eq = p.find('=');
      if (eq == std::string::npos) throw UsageError("--param: expected NAME=VALUE, got '" + p + "'");
      if (p.substr(0, eq) == "gravity")
        throw UsageError("--param gravity: a urdf robot's gravity is --gravity gx,gy,gz");
      if (auto e = SetPlantParam(spec, p.substr(0, eq), p.substr(eq + 1))) {
        throw UsageError("--param " + e->key + ": " + e->message);
      }
    }
    if (!validate) return spec;
    if (auto e = ValidatePlantSpec(spec)) throw UsageError("--urdf: " + Escape(e->message, 400));
    return spec;
  }

  std::string plant_, urdf_;
  std::vector<double> gravity_;
  std::optional<int> links_;
  std::vector<std::string> params_;
  std::vector<double> q_, qd_, tau_;
  std::optional<std::string> method_;
  std::vector<std::string> frames_;
  bool list_frames_ = false;
  bool derivatives_ = false;
  bool floating_base_ = false;
};

}  // namespace

std::unique_ptr<Command> MakeEvalCommand(CLI::App& parent) { return std::make_unique<EvalCommand>(parent); }

}  // namespace lagrange::cli
