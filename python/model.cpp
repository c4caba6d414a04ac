// lagrange.Model: a plant's dynamics (plant/dynamics.hpp) and frame
// kinematics (plant/kinematics.hpp) from Python, built as lagrangectl eval
// builds them (tools/eval.cpp), so the numbers are the library's, bit for bit.
//
// Model and data apart: the Model holds the immutable Dynamics and Kinematics
// (a floating base's: one FloatingDynamics, q of nq and velocities of nv, and
// with method "lagrangian" a FloatingLagrangian for the dynamics)
// and one data object of each for single states, used under the GIL. A batch
// (N, n) runs with the GIL released, over `threads` threads, each with data
// objects of its own made for that call, so other Python threads may use the
// same Model meanwhile.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "base/escape.hpp"
#include "plant/floating_dynamics.hpp"
#include "plant/floating_lagrangian.hpp"
#include "plant/free_flyer.hpp"
#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "protocol/format.hpp"
#include "python/bindings.hpp"
#include "python/bus_arrays.hpp"
#include "python/model_arrays.hpp"
#include "python/paths.hpp"

namespace lagrange::python {
namespace py = pybind11;
namespace {

constexpr int kMaxThreads = 1024;

// Raises a Python exception of `type` with `message` (pybind11 has no
// FileNotFoundError of its own), valid UTF-8: a file name's bytes that are not
// are shown as \xHH (Python would otherwise drop the message).
[[noreturn]] void Raise(PyObject* type, const std::string& message) {
  PyErr_SetString(type, ValidUtf8(message).c_str());
  throw py::error_already_set();
}

// What one user of the model writes: its data objects and scratch. The
// Model's own serves single states (under the GIL); a batch makes one per thread.
struct Worker {
  Worker(const Dynamics& dynamics_model, const Kinematics& kinematics_model)
      : dynamics(dynamics_model.MakeData()),
        kinematics(kinematics_model.MakeData()),
        matrix(dynamics_model.num_dofs(), dynamics_model.num_dofs()) {
    for (auto& s : scratch) s.resize(static_cast<std::size_t>(dynamics_model.num_dofs()));
  }
  // A floating base's: q of nq, the rest nv; `lagrangian` when its dynamics are the Lagrangian path's.
  Worker(const FloatingDynamics& model, const FloatingLagrangian* lagrangian)
      : floating(model.MakeData()),
        floating_lagrangian(lagrangian ? lagrangian->MakeData() : nullptr),
        matrix(model.num_v(), model.num_v()),
        jacobian(6, model.num_v()),
        zero(VectorXd::Zero(model.num_v())) {
    for (auto& s : scratch) s.resize(static_cast<std::size_t>(model.num_q()));
  }
  std::unique_ptr<DynamicsData> dynamics;
  std::unique_ptr<KinematicsData> kinematics;
  std::unique_ptr<FloatingData> floating;      // a floating base's, in place of the two above
  std::unique_ptr<FloatingLagrangianData> floating_lagrangian;  // and its Lagrangian path's, when chosen
  std::array<std::vector<double>, 3> scratch;  // rows of strided arguments (q, qd, third)
  MatrixXd matrix;                             // M or C before it is laid out row-major
  MatrixXd jacobian;                           // (6 x nv) a floating base's frame Jacobian
  VectorXd zero;                               // (nv) zero velocity and acceleration, for G of a floating base
};

using VecMap = Eigen::Map<const VectorXd>;

// One output's shape for one state: a number (ndim 0), a vector or a matrix.
struct Shape {
  int ndim = 0;
  std::array<py::ssize_t, 2> dims{};
  py::ssize_t size() const { return ndim == 0 ? 1 : ndim == 1 ? dims[0] : dims[0] * dims[1]; }
};
constexpr Shape kNumber{};
Shape Vector(py::ssize_t n) { return {1, {n, 0}}; }
Shape Matrix(py::ssize_t rows, py::ssize_t cols) { return {2, {rows, cols}}; }

class Model {
 public:
  // `source`: what built it, all a pickle needs to build it again (SetState).
  Model(const PlantSpec& spec, Method method, py::tuple source)
      : type_(spec.type()),
        method_(method),
        dynamics_(MakeDynamics(spec, method)),
        kinematics_(std::make_shared<const Kinematics>(MakeRigidTree(spec))),
        joint_names_(JointNamesOf(spec)),
        own_(*dynamics_, *kinematics_),
        source_(std::move(source)) {}
  // A URDF robot on a floating base (FloatingDynamics; q of nq = nv + 1, v of
  // nv), its dynamics by FloatingLagrangian when `method` is kLagrangian.
  Model(RigidTree tree, Method method, py::tuple source)
      : type_(PlantType::kUrdf),
        method_(method),
        floating_(std::make_shared<const FloatingDynamics>(std::move(tree))),
        floating_lagrangian_(method == Method::kLagrangian
                                 ? std::make_shared<const FloatingLagrangian>(floating_->tree())
                                 : nullptr),
        joint_names_(DofNames(floating_->tree())),
        frame_names_(floating_->tree().frame_names()),
        own_(*floating_, floating_lagrangian_.get()),
        source_(std::move(source)) {}

  // `urdf`: URDF text (a str whose first character other than white space is
  // '<', as an XML document's is) or a file's path (anything else).
  static std::unique_ptr<Model> FromUrdf(const py::object& urdf, const py::object& gravity, const std::string& method,
                                         double mass_scale, bool floating_base);
  static std::unique_ptr<Model> Builtin(const std::string& name, const py::object& method, const py::kwargs& params);
  static std::unique_ptr<Model> FloatingFromUrdfText(const std::string& text, const std::string& name,
                                                     const py::object& gravity, const std::string& method,
                                                     double mass_scale);
  // (gx, gy, gz) in m/s², or ValueError.
  static std::vector<double> GravityArg(const py::object& gravity) {
    std::vector<double> g;
    try {
      g = py::cast<std::vector<double>>(gravity);
    } catch (const py::cast_error&) {
      throw py::value_error("gravity: expected (gx, gy, gz), 3 numbers in m/s²");
    }
    if (g.size() != 3) {
      throw py::value_error("gravity: expected (gx, gy, gz) (3 numbers, m/s²), got " + std::to_string(g.size()));
    }
    return g;
  }
  // The robot in URDF `text`, named `name` in messages (its file, or "<urdf text>").
  static std::unique_ptr<Model> FromUrdfText(const std::string& text, const std::string& name,
                                             const py::object& gravity, const std::string& method, double mass_scale,
                                             bool floating_base);

  // pickle: (kPickleVersion, "urdf", text, name, gravity, method, mass_scale, floating_base) or
  // (kPickleVersion, "builtin", name, method or None, {parameter: value}): the
  // URDF's text, not its path, so a process without the file unpickles it.
  py::tuple GetState() const { return source_; }
  static std::unique_ptr<Model> SetState(const py::tuple& state);
  static constexpr int kPickleVersion = 1;

  int num_dofs() const { return floating_ ? floating_->num_dofs() : dynamics_->num_dofs(); }
  // nq and nv: n for a fixed base; n + 7 and n + 6 for a floating one.
  int num_positions() const { return floating_ ? floating_->num_q() : num_dofs(); }
  int num_velocities() const { return floating_ ? floating_->num_v() : num_dofs(); }
  bool floating_base() const { return floating_ != nullptr; }
  const FloatingDynamics* floating() const { return floating_.get(); }
  // f(model, data) with a floating base's dynamics of the chosen method: FloatingLagrangian's or
  // FloatingDynamics' (the same calls), on `w`'s data.
  template <class F>
  decltype(auto) FloatingDynamicsCall(Worker& w, F f) const {
    if (floating_lagrangian_) return f(*floating_lagrangian_, *w.floating_lagrangian);
    return f(*floating_, *w.floating);
  }
  // The floating base's model, or ValueError naming `call`, which takes only one.
  const FloatingDynamics& RequireFloating(const char* call) const {
    if (!floating_) {
      throw py::value_error(std::string(call) + ": a floating-base Model's (from_urdf(..., floating_base=True)); "
                            "this one's base is fixed");
    }
    return *floating_;
  }
  const std::vector<std::string>& joint_names() const { return joint_names_; }
  const std::vector<std::string>& frame_names() const { return floating_ ? frame_names_ : kinematics_->frame_names(); }
  std::string method() const { return std::string(ToString(method_)); }
  std::string plant() const { return std::string(ToString(type_)); }
  PlantType type() const { return type_; }
  const Dynamics& dynamics() const { return *shared_dynamics(); }
  const std::shared_ptr<const Dynamics>& shared_dynamics() const {
    if (floating_) {
      throw py::value_error("model: a floating-base Model (floating_base=True) is not taken here yet (derivatives, "
                            "simulate and optimize_trajectory take a fixed base)");
    }
    return dynamics_;
  }
  const Kinematics& kinematics() const { return *kinematics_; }

  // The frame called `name`, or ValueError in eval --frame's words.
  int Frame(const std::string& name) const {
    std::optional<int> k;
    if (floating_) {
      const auto it = std::find(frame_names_.begin(), frame_names_.end(), name);
      if (it != frame_names_.end()) k = static_cast<int>(it - frame_names_.begin());
    } else {
      k = kinematics_->FrameIndex(name);
    }
    if (!k) throw py::value_error("frame: no frame '" + Escape(name, 64) + "' in this plant (frame_names lists them)");
    return *k;
  }
  // A frame by name or by its index in frame_names (frame_id's), or ValueError.
  int Frame(const std::variant<int, std::string>& frame) const {
    if (const std::string* name = std::get_if<std::string>(&frame)) return Frame(*name);
    const int k = std::get<int>(frame);
    const int count = static_cast<int>(frame_names().size());
    if (k < 0 || k >= count) {
      throw py::value_error("frame: expected an index 0.." + std::to_string(count - 1) + " (frame_names), got " +
                            std::to_string(k));
    }
    return k;
  }

  // Per-argument checks: q has nq entries, a velocity-like argument nv (both n for a fixed base).
  JointArray PositionArg(const char* name, const py::handle& value) const {
    return floating_ ? JointArray(name, value, num_positions(), "nq = nv + 1: p, quaternion x y z w, then the joints")
                     : JointArray(name, value, num_dofs());
  }
  JointArray VelocityArg(const char* name, const py::handle& value) const {
    return floating_ ? JointArray(name, value, num_velocities(), "nv: v_b, ω_b in base axes, then the joints")
                     : JointArray(name, value, num_dofs());
  }
  // A fresh worker for this model (a batch's thread).
  Worker MakeWorker() const {
    return floating_ ? Worker(*floating_, floating_lagrangian_.get()) : Worker(*dynamics_, *kinematics_);
  }

  // Evaluates `kernel` at one state or over a batch: `args` are the per-joint
  // arguments, `shapes` each output's shape for one state ({} a number).
  // kernel(worker, rows, outputs) computes one state from its argument rows
  // into its output slots and returns whether they are finite. One state:
  // the outputs as arrays (a float for shape {}), a tuple when several; a
  // batch: each with a leading axis N, computed without the GIL.
  // `out_array` (one output alone): an array the result is written into and returned as, or None for a new one.
  template <std::size_t kArgs, std::size_t kOuts, class Kernel>
  py::object Evaluate(const std::array<const JointArray*, kArgs>& args, const std::array<Shape, kOuts>& shapes,
                      int threads, const char* what, Kernel kernel, py::handle out_array = py::none());

  double TimeForwardDynamics(const py::handle& q, const py::handle& qd, const py::handle& tau, long iterations);
  // The data of single states (under the GIL): Evaluate's, and the fast path's (FastMethod).
  Worker& single_state_worker() { return own_; }

 private:
  PlantType type_;
  Method method_;
  static std::vector<std::string> DofNames(const RigidTree& tree) {
    std::vector<std::string> names;
    for (const TreeJoint& j : tree.joints) {
      if (j.mimic < 0) names.push_back(j.name);
    }
    return names;
  }

  std::shared_ptr<const Dynamics> dynamics_;        // null for a floating base
  std::shared_ptr<const Kinematics> kinematics_;    // null for a floating base
  std::shared_ptr<const FloatingDynamics> floating_;  // a floating base's, else null
  std::shared_ptr<const FloatingLagrangian> floating_lagrangian_;  // its dynamics with method lagrangian, else null
  std::vector<std::string> joint_names_;
  std::vector<std::string> frame_names_;  // a floating base's
  Worker own_;        // single states, under the GIL
  py::tuple source_;  // GetState's
};

// Pinocchio's names for the axes a frame's Jacobian and J̇ qd are given in
// (plant/kinematics.hpp, FrameAxes).
constexpr const char* kLocalWorldAligned = "local_world_aligned";
constexpr const char* kLocal = "local";

// The axes `reference` names, or ValueError.
FrameAxes ReferenceAxes(const std::string& reference) {
  if (reference == kLocalWorldAligned) return FrameAxes::kWorldAligned;
  if (reference == kLocal) return FrameAxes::kLocal;
  if (reference == "world") {
    throw py::value_error(
        "reference: 'world' (Pinocchio's WORLD: the motion of the point at the world's origin) is not given; "
        "'local_world_aligned' is the frame origin's motion in world axes, 'local' in the frame's own");
  }
  throw py::value_error("reference: expected 'local_world_aligned' or 'local', got '" + Escape(reference, 64) + "'");
}

// The method named by `method` (None: the plant's fastest exact path, as eval's default).
Method ChooseMethod(PlantType type, const py::object& method) {
  if (method.is_none()) return FastestMethod(type);
  const std::string name = py::str(method);
  const std::optional<Method> m = ParseMethod(name);
  if (!m)
    throw py::value_error("method: expected closed-form, lagrangian or recursive, got '" + Escape(name, 64) + "'");
  if (!HasMethod(type, *m)) {
    const std::string what = type == PlantType::kUrdf ? "a urdf robot" : std::string(ToString(type));
    throw py::value_error("method: " + what + " has no " + name + " path (use lagrangian or recursive)");
  }
  return *m;
}

// What messages call URDF text given as an argument (a file is called by its path).
constexpr const char* kUrdfTextName = "<urdf text>";

// Whether `urdf` is URDF text rather than a path: a str whose first character
// other than white space is '<' (an XML document's first; a file whose name
// begins with '<' is named by a pathlib.Path or bytes).
bool IsUrdfText(const py::handle& urdf) {
  // Asked of the str itself: a file name that is not UTF-8 comes as a str with surrogates, which has no UTF-8 text.
  return py::isinstance<py::str>(urdf) && py::cast<bool>(urdf.attr("lstrip")().attr("startswith")("<"));
}

// The robot in `text` (named `name` in messages) as a plant, or ValueError with the loader's line.
PlantSpec UrdfSpec(const std::string& text, const std::string& name) {
  try {
    return UrdfPlantSpec(std::make_shared<const UrdfRobot>(ParseUrdf(text, name)));
  } catch (const UrdfError& e) {  // one line, escaped by the loader (plant/urdf.hpp)
    Raise(PyExc_ValueError, e.what());
  } catch (const std::exception& e) {  // anything the parser below it throws
    Raise(PyExc_ValueError, name + ": " + Escape(e.what(), 400));
  }
}

std::unique_ptr<Model> Model::FromUrdf(const py::object& urdf, const py::object& gravity, const std::string& method,
                                       double mass_scale, bool floating_base) {
  std::string text, name;
  if (IsUrdfText(urdf)) {
    text = py::cast<std::string>(urdf);
    name = kUrdfTextName;
  } else {
    if (!py::isinstance<py::str>(urdf) && !py::isinstance<py::bytes>(urdf) && !py::hasattr(urdf, "__fspath__")) {
      throw py::type_error("urdf: expected a URDF file (str, bytes or os.PathLike) or URDF text (str), got " +
                           std::string(py::str(py::type::handle_of(urdf).attr("__name__"))) +
                           " (a built-in plant: Model.builtin)");
    }
    name = FsPath(urdf, "urdf");
    try {
      text = ReadUrdfFile(name);
    } catch (const UrdfError& e) {
      std::error_code ec;
      if (std::filesystem::exists(name, ec)) Raise(PyExc_ValueError, e.what());
      // A built-in plant's name is not a file: say where it is made.
      const std::optional<PlantType> builtin = ParsePlantType(name);
      if (builtin && *builtin != PlantType::kUrdf) {
        throw py::value_error("urdf: '" + name + "' is a built-in plant, not a URDF file: Model.builtin('" + name +
                              "', ...)");
      }
      Raise(PyExc_FileNotFoundError, e.what());
    }
  }
  return FromUrdfText(text, name, gravity, method, mass_scale, floating_base);
}

std::unique_ptr<Model> Model::FromUrdfText(const std::string& text, const std::string& name, const py::object& gravity,
                                           const std::string& method, double mass_scale, bool floating_base) {
  if (floating_base) return FloatingFromUrdfText(text, name, gravity, method, mass_scale);
  PlantSpec spec = UrdfSpec(text, name);
  const std::vector<double> g = GravityArg(gravity);
  std::string g_text;
  for (double x : g) {
    if (!g_text.empty()) g_text += ',';
    g_text += FormatDouble(x);
  }
  if (auto e = SetPlantParam(spec, "gravity", g_text)) throw py::value_error("gravity: " + e->message);
  if (auto e = SetPlantParam(spec, "mass_scale", FormatDouble(mass_scale))) {
    throw py::value_error("mass_scale: " + e->message);
  }
  if (auto e = ValidatePlantSpec(spec)) throw py::value_error(Escape(e->message, 400));
  const Method chosen = ChooseMethod(PlantType::kUrdf, py::str(method));
  py::tuple source = py::make_tuple(kPickleVersion, "urdf", py::bytes(text), py::bytes(name), py::tuple(py::cast(g)),
                                    std::string(ToString(chosen)), mass_scale, false);
  return std::make_unique<Model>(spec, chosen, std::move(source));
}

std::unique_ptr<Model> Model::FloatingFromUrdfText(const std::string& text, const std::string& name,
                                                   const py::object& gravity, const std::string& method,
                                                   double mass_scale) {
  const std::vector<double> g = GravityArg(gravity);
  const std::optional<Method> chosen = ParseMethod(method);
  if (!chosen || *chosen == Method::kClosedForm) {
    throw py::value_error("method: a floating base has the recursive and lagrangian paths, got '" +
                          Escape(method, 64) + "'");
  }
  if (mass_scale != 1.0) throw py::value_error("mass_scale: not with floating_base=True yet (the file's masses)");
  RigidTree tree;
  try {
    tree = ParseUrdf(text, name, UrdfOptions{.floating_base = true}).tree;
  } catch (const UrdfError& e) {  // one line, escaped by the loader (plant/urdf.hpp)
    Raise(PyExc_ValueError, e.what());
  }
  tree.gravity = Eigen::Vector3d(g[0], g[1], g[2]);
  if (!tree.gravity.allFinite()) throw py::value_error("gravity: expected finite numbers (m/s²)");
  py::tuple source = py::make_tuple(kPickleVersion, "urdf", py::bytes(text), py::bytes(name), py::tuple(py::cast(g)),
                                    method, mass_scale, true);
  try {
    return std::make_unique<Model>(std::move(tree), *chosen, std::move(source));
  } catch (const std::invalid_argument& e) {
    Raise(PyExc_ValueError, name + ": " + Escape(e.what(), 400));
  }
}

// A parameter's value as the text SetPlantParam reads: a string as it is, a
// number as the shortest text that reads back to the same double.
std::string ParamText(const std::string& name, const py::handle& value) {
  if (py::isinstance<py::str>(value)) return py::cast<std::string>(value);
  if (py::isinstance<py::bool_>(value)) return py::cast<bool>(value) ? "True" : "False";  // refused as a number
  try {
    return FormatDouble(py::cast<double>(value));
  } catch (const py::cast_error&) {
    throw py::value_error(name + ": expected a number or a string, got " +
                          std::string(py::str(py::type::handle_of(value).attr("__name__"))));
  }
}

// A chain's per-link list (one value per link), as eval's --param m=1,0.8,0.5.
void SetLinkParams(PlantSpec& spec, const std::string& name, const py::sequence& values) {
  if (spec.type() != PlantType::kChain) throw py::value_error(name + ": expected a single value, got a sequence");
  if (name == "links" || name == "g" || name == "base_angle") {
    throw py::value_error(name + ": expected a single value, got a sequence");
  }
  const int links = spec.num_dofs();
  if (static_cast<int>(values.size()) != links) {
    throw py::value_error(name + ": expected " + std::to_string(links) + " values (one per link), got " +
                          std::to_string(values.size()));
  }
  for (int i = 0; i < links; ++i) {
    const std::string item = name + "[" + std::to_string(i) + "]";
    if (auto e = SetPlantParam(spec, name, ParamText(item, values[static_cast<std::size_t>(i)]), i)) {
      throw py::value_error(e->key + "[" + std::to_string(i) + "]: " + e->message);
    }
  }
}

std::unique_ptr<Model> Model::Builtin(const std::string& name, const py::object& method, const py::kwargs& params) {
  const std::optional<PlantType> type = ParsePlantType(name);
  if (!type || *type == PlantType::kUrdf) {
    throw py::value_error("name: expected one of pendulum|arm2|cartpole|chain, got '" + Escape(name, 64) +
                          "' (a URDF robot: Model.from_urdf)");
  }
  PlantSpec spec = DefaultPlantSpec(*type);
  // The chain's link count first, so per-link lists are checked against it (as eval and a scene do).
  std::vector<std::pair<std::string, py::handle>> items;
  for (const auto& [key, value] : params) items.emplace_back(py::cast<std::string>(key), value);
  std::stable_partition(items.begin(), items.end(), [](const auto& item) { return item.first == "links"; });
  for (const auto& [key, value] : items) {
    if (!py::isinstance<py::str>(value) && py::isinstance<py::sequence>(value)) {
      SetLinkParams(spec, key, py::reinterpret_borrow<py::sequence>(value));
    } else if (auto e = SetPlantParam(spec, key, ParamText(key, value))) {
      throw py::value_error(e->key + ": " + e->message);
    }
  }
  if (auto e = ValidatePlantSpec(spec)) throw py::value_error(e->key + ": " + e->message);
  py::dict kept;  // the parameters as given (sequences as lists), for pickle
  for (const auto& [key, value] : params) {
    kept[key] = !py::isinstance<py::str>(value) && py::isinstance<py::sequence>(value)
                    ? py::list(py::reinterpret_borrow<py::sequence>(value))
                    : py::reinterpret_borrow<py::object>(value);
  }
  py::tuple source = py::make_tuple(kPickleVersion, "builtin", name, method, kept);
  return std::make_unique<Model>(spec, ChooseMethod(*type, method), std::move(source));
}

std::unique_ptr<Model> Model::SetState(const py::tuple& state) {
  const auto bad = [] { return py::value_error("Model.__setstate__: not a pickled lagrange.Model"); };
  if (state.size() < 2 || !py::isinstance<py::int_>(state[0]) || py::cast<int>(state[0]) != kPickleVersion) throw bad();
  const std::string kind = py::str(state[1]);
  if (kind == "urdf" && (state.size() == 7 || state.size() == 8)) {
    // The text as the file held it, parsed as from_urdf parsed it, under the same name.
    return FromUrdfText(py::cast<std::string>(state[2]), py::cast<std::string>(state[3]), state[4],
                        py::cast<std::string>(state[5]), py::cast<double>(state[6]),
                        state.size() == 8 && py::cast<bool>(state[7]));
  }
  if (kind == "builtin" && state.size() == 5) {
    return Builtin(py::cast<std::string>(state[2]), state[3], py::kwargs(py::dict(state[4])));
  }
  throw bad();
}

template <std::size_t kArgs, std::size_t kOuts, class Kernel>
py::object Model::Evaluate(const std::array<const JointArray*, kArgs>& args, const std::array<Shape, kOuts>& shapes,
                           int threads, const char* what, Kernel kernel, py::handle out_array) {
  if (threads < 1 || threads > kMaxThreads) {
    throw py::value_error("threads: expected 1.." + std::to_string(kMaxThreads) + ", got " + std::to_string(threads));
  }
  py::ssize_t rows = -1;
  if constexpr (kArgs == 1) rows = BatchRows({args[0]});
  if constexpr (kArgs == 2) rows = BatchRows({args[0], args[1]});
  if constexpr (kArgs == 3) rows = BatchRows({args[0], args[1], args[2]});

  // The outputs, each (N, shape...) for a batch; one state's number is a double. Fixed-size arrays: a single
  // state's call allocates nothing but its result arrays (bench/python_bench.py times it).
  std::array<py::object, kOuts> arrays;
  std::array<double, kOuts> numbers{};
  std::array<double*, kOuts> outputs{};
  std::array<py::ssize_t, kOuts> sizes{};
  for (std::size_t o = 0; o < kOuts; ++o) {
    const Shape& shape = shapes[o];
    sizes[o] = shape.size();
    if (rows < 0 && shape.ndim == 0) {
      outputs[o] = &numbers[o];
      continue;
    }
    std::array<py::ssize_t, 3> dims{};
    int ndim = 0;
    if (rows >= 0) dims[static_cast<std::size_t>(ndim++)] = rows;
    for (int d = 0; d < shape.ndim; ++d)
      dims[static_cast<std::size_t>(ndim++)] = shape.dims[static_cast<std::size_t>(d)];
    if (kOuts == 1 && !out_array.is_none()) {
      outputs[o] = ResultArrayData(out_array.ptr(), ndim, dims.data());
      if (!outputs[o]) {
        std::string shape_text = "(";
        for (int d = 0; d < ndim; ++d) shape_text += (d ? ", " : "") + std::to_string(dims[static_cast<std::size_t>(d)]);
        throw py::value_error("out: expected a writeable C-contiguous float64 array of shape " + shape_text +
                              (ndim == 1 ? ",)" : ")") + " (the result's)");
      }
      arrays[o] = py::reinterpret_borrow<py::object>(out_array);
      continue;
    }
    py::array_t<double> array = NewArray(ndim, dims.data());
    outputs[o] = array.mutable_data();
    arrays[o] = std::move(array);
  }

  // Rows [begin, end) with `worker`; returns the first state whose outputs are not finite, or end.
  auto run = [&](Worker& worker, py::ssize_t begin, py::ssize_t end) {
    std::array<const double*, kArgs> row;
    std::array<double*, kOuts> out;
    for (py::ssize_t i = begin; i < end; ++i) {
      for (std::size_t a = 0; a < kArgs; ++a) row[a] = args[a]->Row(i, worker.scratch[a]);
      for (std::size_t o = 0; o < kOuts; ++o) out[o] = outputs[o] + (rows < 0 ? 0 : i * sizes[o]);
      if (!kernel(worker, row, out)) return i;
    }
    return end;
  };

  if (rows < 0) {
    if (run(own_, 0, 1) != 1) throw std::runtime_error(std::string(what) + " not finite at this state");
  } else {
    const py::ssize_t first = RunBatch(rows, threads, [&](py::ssize_t begin, py::ssize_t end) {
      Worker worker = MakeWorker();
      return run(worker, begin, end);
    });
    if (first < rows) throw std::runtime_error(std::string(what) + " not finite at state " + std::to_string(first));
  }

  auto result = [&](std::size_t o) -> py::object {
    if (rows < 0 && shapes[o].ndim == 0) return py::float_(numbers[o]);
    return std::move(arrays[o]);
  };
  if constexpr (kOuts == 1) {
    return result(0);
  } else {
    py::tuple tuple(kOuts);
    for (std::size_t o = 0; o < kOuts; ++o) tuple[o] = result(o);
    return tuple;
  }
}

// The C++ call alone, `iterations` times: at one state, or cycling through the rows of a batch (the same states a
// batched call of the same arguments evaluates). What a call from Python costs beyond it (bench/python_bench.py).
double Model::TimeForwardDynamics(const py::handle& q_arg, const py::handle& qd_arg, const py::handle& tau_arg,
                                  long iterations) {
  if (floating_) throw py::value_error("model: _time_forward_dynamics takes a fixed base");
  const int n = num_dofs();
  const JointArray aq("q", q_arg, n), aqd("qd", qd_arg, n), atau("tau", tau_arg, n);
  const py::ssize_t rows = BatchRows({&aq, &aqd, &atau});
  if (rows == 0) throw py::value_error("q: expected at least one state");
  if (iterations < 1)
    throw py::value_error("iterations: expected a positive number, got " + std::to_string(iterations));
  Worker worker(*dynamics_, *kinematics_);
  const py::ssize_t states = std::max<py::ssize_t>(rows, 1);
  std::vector<double> scratch(static_cast<std::size_t>(n));
  MatrixXd q(n, states), qd(n, states), tau(n, states);
  for (py::ssize_t i = 0; i < states; ++i) {
    q.col(i) = VecMap(aq.Row(i, scratch), n);
    qd.col(i) = VecMap(aqd.Row(i, scratch), n);
    tau.col(i) = VecMap(atau.Row(i, scratch), n);
  }
  VectorXd qdd(n);
  py::gil_scoped_release release;
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0, k = 0; i < iterations; ++i, k = k + 1 == states ? 0 : k + 1) {
    dynamics_->ComputeForwardDynamics(*worker.dynamics, q.col(k), qd.col(k), tau.col(k), DynamicsTerms{}, qdd);
    asm volatile("" : : "r"(qdd.data()) : "memory");  // the result is used: the call is not optimised away
  }
  const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
  return elapsed.count() / static_cast<double>(iterations);
}

// --- docstrings -------------------------------------------------------------

constexpr const char* kModelDoc = R"(A plant's rigid-body dynamics and frame kinematics.

    tau = M(q) qdd + C(q, qd) qd + G(q)

Built once (Model(urdf) or Model.from_urdf for a URDF robot, Model.builtin for
a planar one), then immutable. A Model pickles (copy, multiprocessing) as what
built it: a URDF's text (not its path) or a built-in plant's parameters. Units SI: q in
rad (revolute) or m (prismatic), qd in rad/s or m/s, qdd in rad/s² or m/s²,
tau in N·m or N, energies in J. n = num_dofs.

Arguments are float64 arrays (any layout; lists and other real dtypes are
converted): one state (n,), or a batch (N, n) whose results gain a leading
axis N. In one call, batched arguments share N and a single state is used for
every row. A batch runs in C++ without the GIL, over `threads` threads, each
with its own data (the model is shared, read-only). Wrong shapes and
non-finite input raise ValueError with lagrangectl eval's messages; a result
that is not finite raises RuntimeError naming the first such state.

mass_matrix, gravity, forward_dynamics, inverse_dynamics and frame_jacobian take out=: a
writeable C-contiguous float64 array of the result's shape, written in place
and returned (no allocation). One state given as float64 (n,) arrays,
positionally (frame_jacobian: after a frame_id), takes a fast path past the
argument conversion (issue 37).

The numbers are the C++ library's, bit for bit (the same as
`lagrangectl eval`, whose JSON prints the shortest text of each double).
)";

constexpr const char* kFromUrdfDoc = R"(A robot from URDF (a fixed base): a file, or its text.

urdf:       the .urdf file (str, bytes or os.PathLike, as open() takes it), or
            the URDF's text: a str whose first character other than white
            space is '<' is text (an XML document begins so), any other
            argument a path (a file whose name begins with '<': pathlib.Path)
gravity:    (gx, gy, gz), m/s², in the root link's (world) frame
method:     "recursive" (RNEA, ABA, CRBA; the default) or "lagrangian"
            (automatic differentiation of T and V), for cross-checks
mass_scale: every link's mass and inertia × this (> 0)
floating_base: the root link is a free base (Pinocchio's buildModel(urdf,
            JointModelFreeFlyer())): q = (p, qx, qy, qz, qw, joints) of nq = n + 7,
            qd = (v_b, ω_b in base axes, joint rates) of nv = n + 6; every
            call takes q of nq and velocity-like arguments of nv (the README's
            "Floating base"); method "recursive" or "lagrangian" (the
            Euler–Poincaré form), mass_scale 1; center_of_mass,
            centroidal_momentum_matrix and centroidal_momentum_bias are its own

Raises FileNotFoundError when the file does not exist, ValueError when it is
not a robot lagrange reads (one line: "FILE: ELEMENT: reason", FILE
"<urdf text>" for text), TypeError for an argument that is neither.
)";

constexpr const char* kIntegrateDoc = R"((q, v, dt) => q ⊕ dt v, on the configuration manifold (Pinocchio's integrate):
a floating base moves by SE(3)'s exponential of its body twist dt (v_b, ω_b), the
joints by q + dt qd; a fixed base's q + dt v.

q        (nq,) | (N, nq)
v        (nv,) | (N, nv)
dt       float, s
returns  (nq,) | (N, nq))";

constexpr const char* kDifferenceDoc = R"((q0, q1) => v with integrate(q0, v, 1) = q1 (Pinocchio's difference): the
base by SE(3)'s logarithm (the shorter rotation), the joints q1 − q0.

q0, q1   (nq,) | (N, nq)
returns  (nv,) | (N, nv))";

constexpr const char* kInitDoc = R"(Model(urdf, *, gravity=(0, 0, -9.81), method="recursive", mass_scale=1.0, floating_base=False):
a robot from a URDF file (or its text), as Model.from_urdf (and pinocchio.buildModelFromUrdf).

A built-in planar plant: Model.builtin(name, ...).
)";

constexpr const char* kBuiltinDoc = R"(A built-in planar plant, with the parameters of scenes and `lagrangectl eval`.

name:    pendulum | arm2 | cartpole | chain
method:  None (the fastest exact path: closed-form for pendulum, arm2,
         cartpole; recursive for chain), "closed-form", "lagrangian" or
         "recursive"
params:  SI units, defaults as the README's conventions
  pendulum  m (kg), L (m), g (m/s²), body ("point" | "rod")
  arm2      m1, m2 (kg), L1, L2 (m), g; defaults 1.0, 0.8, 0.6, 0.5, 9.81
  cartpole  mc, mp (kg), l (m), I (kg·m²), g
  chain     links, m, L, com, I, joints ("revolute" | "prismatic"),
            base_angle (rad), g; m, L, com, I and joints take one value for
            every link or a sequence with one per link: m=[1, 0.8, 0.5]

Raises ValueError naming the parameter: "m1: expected a positive number (kg), got -1".
)";

constexpr const char* kMassMatrixDoc = R"(q => M(q), the mass matrix: symmetric positive definite, M = ∂²T/∂qd².

q        (n,) | (N, n)     rad (revolute), m (prismatic)
returns  (n, n) | (N, n, n)  kg·m² (revolute rows and columns), kg (prismatic))";

constexpr const char* kCoriolisMatrixDoc =
    R"((q, qd) => C(q, qd), the Christoffel factorisation: C qd is the Coriolis and centrifugal force, Ṁ − 2C is skew.

q        (n,) | (N, n)     rad or m
qd       (n,) | (N, n)     rad/s or m/s
returns  (n, n) | (N, n, n)  C qd in N·m or N)";

constexpr const char* kGravityDoc = R"(q => G(q) = ∂V/∂q, the generalized gravity force (tau = G holds the plant still).

q        (n,) | (N, n)  rad or m
returns  (n,) | (N, n)  N·m or N)";

constexpr const char* kForwardDynamicsDoc = R"((q, qd, tau) => qdd = M⁻¹ (tau − C qd − G).

q        (n,) | (N, n)  rad or m
qd       (n,) | (N, n)  rad/s or m/s
tau      (n,) | (N, n)  N·m or N
returns  (n,) | (N, n)  qdd, rad/s² or m/s²)";

constexpr const char* kInverseDynamicsDoc = R"((q, qd, qdd) => tau = M qdd + C qd + G.

q        (n,) | (N, n)  rad or m
qd       (n,) | (N, n)  rad/s or m/s
qdd      (n,) | (N, n)  rad/s² or m/s²
returns  (n,) | (N, n)  tau, N·m or N)";

constexpr const char* kKineticEnergyDoc = R"((q, qd) => T = ½ qdᵀ M(q) qd.

q        (n,) | (N, n)  rad or m
qd       (n,) | (N, n)  rad/s or m/s
returns  float | (N,)   J)";

constexpr const char* kPotentialEnergyDoc =
    R"(q => V(q): zero at the base's height (planar plants: V = Σ m g y_com), or with
every centre of mass at the world origin (URDF: V = −Σ m gᵀ p_com).

q        (n,) | (N, n)  rad or m
returns  float | (N,)   J)";

constexpr const char* kFramePoseDoc =
    R"((frame, q) => (R, p): the frame's axes and origin in the world (root link) frame.

frame    one of frame_names
q        (n,) | (N, n)            rad or m
returns  R (3, 3) | (N, 3, 3)     its x, y, z axes as columns, world coordinates
         p (3,) | (N, 3)          its origin, m)";

constexpr const char* kFrameJacobianDoc =
    R"((frame, q) => J: (ṗ, ω) = J qd, ṗ the velocity of the frame's origin, ω its angular velocity.

frame      one of frame_names
q          (n,) | (N, n)        rad or m
reference  in which axes (Pinocchio's reference frames):
           "local_world_aligned" (the default; as lagrangectl eval --frame): the world's axes
           "local": the frame's own axes, J_local = blockdiag(Rᵀ, Rᵀ) J, R from frame_pose
returns    (6, n) | (N, 6, n)   rows 0..2 linear (m/s), rows 3..5 angular (rad/s) per unit joint velocity)";

constexpr const char* kFrameBiasAccelerationDoc =
    R"((frame, q, qd) => J̇ qd (eval --frame's jdot_qdot): the frame origin's acceleration and its
angular acceleration at qdd = 0, so (p̈, ω̇) = J qdd + J̇ qd.

frame      one of frame_names
q          (n,) | (N, n)   rad or m
qd         (n,) | (N, n)   rad/s or m/s
reference  "local_world_aligned" (the default): in world axes; "local": the same physical
           acceleration in the frame's own axes, blockdiag(Rᵀ, Rᵀ) times the world-aligned one
           (Pinocchio's classical acceleration in LOCAL, not d/dt(J_local) qd)
returns    (6,) | (N, 6)   m/s², then rad/s²)";

constexpr const char* kCenterOfMassDoc =
    R"(q => (c, J_c): the centre of mass in the world and its Jacobian, ċ = J_c qd (a floating-base Model's).

q        (nq,) | (N, nq)
returns  c (3,) | (N, 3)              m, world axes
         J_c (3, nv) | (N, 3, nv)     m/s per unit velocity)";

constexpr const char* kCentroidalMomentumMatrixDoc =
    R"(q => A_G, the centroidal momentum matrix (Orin et al.; Pinocchio's ccrba): h_G = A_G qd, the
linear momentum then the angular momentum about the centre of mass, world axes (a floating-base Model's).

q        (nq,) | (N, nq)
returns  (6, nv) | (N, 6, nv)   rows 0..2 N·s, rows 3..5 N·m·s per unit velocity)";

constexpr const char* kCentroidalMomentumBiasDoc =
    R"((q, qd) => Ȧ_G qd: the centroidal momentum's rate at qdd = 0, so ḣ_G = A_G qdd + Ȧ_G qd
(the drift term of Pinocchio's dccrba; a floating-base Model's).

q        (nq,) | (N, nq)
qd       (nv,) | (N, nv)
returns  (6,) | (N, 6)   N (linear), then N·m about the centre of mass; world axes)";

}  // namespace

// The Model object `model` holds, or TypeError.
const Model& AsModel(py::handle model) {
  if (!py::isinstance<Model>(model)) {
    throw py::type_error("model: expected a lagrange.Model, got " +
                         std::string(py::str(py::type::handle_of(model).attr("__name__"))));
  }
  return py::cast<const Model&>(model);
}

std::shared_ptr<const Dynamics> ModelDynamics(py::handle model) { return AsModel(model).shared_dynamics(); }
PlantType ModelPlantType(py::handle model) { return AsModel(model).type(); }

// --- the fast path (issue 37) -------------------------------------------------
// A single state passed positionally as float64 arrays of shape (n,), contiguous,
// aligned and finite (what the C++ call reads in place), to a fixed base's
// mass_matrix, gravity, forward_dynamics or inverse_dynamics (or to
// frame_jacobian after a frame's index, world-aligned), skips pybind11's
// dispatch and JointArray: a METH_FASTCALL method on Model reads the arrays where
// they are and returns a new result array, or writes into out= (an array of the
// result's shape, C-contiguous, writeable) and returns it. Every other call (a batch, a list,
// a keyword, a wrong size, a non-finite value or result, a floating base) goes
// to the pybind11 function the fast method stands in front of, unchanged: the
// same results (the same C++ call on the same data), the same errors.

struct FastCall {
  const char* name;
  bool frame;                     // a frame's index (an int) before the arrays
  int arrays;                     // per-joint arguments, all n long
  Shape (*shape)(py::ssize_t n);  // the result's
  // (model, its single-state worker, the frame, the arrays' values) => the result into `out`; whether it is finite.
  bool (*kernel)(const Model& model, Worker& w, int frame, const double* const* x, double* out);
};

using Map = Eigen::Map<VectorXd>;
constexpr std::array<FastCall, 5> kFastCalls = {{
    {"mass_matrix", false, 1, [](py::ssize_t n) { return Matrix(n, n); },
     [](const Model& m, Worker& w, int, const double* const* x, double* out) {
       const int n = m.num_dofs();
       m.dynamics().ComputeMassMatrix(*w.dynamics, VecMap(x[0], n), w.matrix);
       CopyRowMajor(w.matrix, out);
       return w.matrix.allFinite();
     }},
    {"gravity", false, 1, [](py::ssize_t n) { return Vector(n); },
     [](const Model& m, Worker& w, int, const double* const* x, double* out) {
       const int n = m.num_dofs();
       Map G(out, n);
       m.dynamics().ComputeGravityForce(*w.dynamics, VecMap(x[0], n), G);
       return G.allFinite();
     }},
    {"forward_dynamics", false, 3, [](py::ssize_t n) { return Vector(n); },
     [](const Model& m, Worker& w, int, const double* const* x, double* out) {
       const int n = m.num_dofs();
       Map qdd(out, n);
       m.dynamics().ComputeForwardDynamics(*w.dynamics, VecMap(x[0], n), VecMap(x[1], n), VecMap(x[2], n),
                                           DynamicsTerms{}, qdd);
       return qdd.allFinite();
     }},
    {"inverse_dynamics", false, 3, [](py::ssize_t n) { return Vector(n); },
     [](const Model& m, Worker& w, int, const double* const* x, double* out) {
       const int n = m.num_dofs();
       Map tau(out, n);
       m.dynamics().ComputeInverseDynamics(*w.dynamics, VecMap(x[0], n), VecMap(x[1], n), VecMap(x[2], n),
                                           DynamicsTerms{}, tau);
       return tau.allFinite();
     }},
    {"frame_jacobian", true, 1, [](py::ssize_t n) { return Matrix(6, n); },
     [](const Model& m, Worker& w, int frame, const double* const* x, double* out) {
       m.kinematics().ComputeFrameJacobian(*w.kinematics, VecMap(x[0], m.num_dofs()), frame, FrameAxes::kWorldAligned);
       const Matrix6Xd& J = w.kinematics->jacobian(frame, FrameAxes::kWorldAligned);
       CopyRowMajor(J, out);
       return J.allFinite();
     }},
}};

// The pybind11 functions behind the fast methods (owned references, kept for the process's life).
std::array<PyObject*, kFastCalls.size()> g_general{};

// The call as pybind11 takes it: self, then the arguments and keywords as given.
PyObject* GeneralCall(std::size_t index, PyObject* self, PyObject* const* args, Py_ssize_t nargs, PyObject* kwnames) {
  const Py_ssize_t total = nargs + (kwnames ? PyTuple_GET_SIZE(kwnames) : 0);
  std::vector<PyObject*> stack(static_cast<std::size_t>(total) + 1);
  stack[0] = self;
  std::copy(args, args + total, stack.begin() + 1);
  return PyObject_Vectorcall(g_general[index], stack.data(), static_cast<std::size_t>(nargs) + 1, kwnames);
}

// The Model `self` holds, or null: the method's descriptor has checked that
// self is a Model, whose pybind11 instance holds its one value in place.
Model* FastSelf(PyObject* self) {
  auto* instance = reinterpret_cast<py::detail::instance*>(self);
  if (!instance->simple_layout || !instance->simple_holder_constructed) return nullptr;
  return static_cast<Model*>(instance->simple_value_holder[0]);
}

// Whether the keywords are out= alone.
bool OutAlone(PyObject* kwnames) {
  return PyTuple_GET_SIZE(kwnames) == 1 && PyUnicode_CompareWithASCIIString(PyTuple_GET_ITEM(kwnames, 0), "out") == 0;
}

template <std::size_t kIndex>
PyObject* FastMethod(PyObject* self, PyObject* const* args, Py_ssize_t nargs, PyObject* kwnames) {
  constexpr FastCall call = kFastCalls[kIndex];
  Model* fast_self = FastSelf(self);
  const int first = call.frame ? 1 : 0;  // the first array's argument
  if (fast_self && nargs == first + call.arrays && (!kwnames || OutAlone(kwnames))) {
    try {
      Model& model = *fast_self;
      const py::ssize_t n = model.num_dofs();
      std::array<const double*, 3> x{};
      bool fast = !model.floating_base();
      int frame = -1;
      if (call.frame) {  // an int (not a bool, not a name) in range; else the general path
        const long k = fast && PyLong_CheckExact(args[0]) ? PyLong_AsLong(args[0]) : -1;
        if (k == -1 && PyErr_Occurred()) PyErr_Clear();
        fast = fast && k >= 0 && k < static_cast<long>(model.frame_names().size());
        frame = static_cast<int>(k);
      }
      for (int a = 0; fast && a < call.arrays; ++a) {
        x[static_cast<std::size_t>(a)] = ContiguousFiniteVector(args[first + a], n);
        fast = x[static_cast<std::size_t>(a)] != nullptr;
      }
      const Shape shape = call.shape(n);
      PyObject* out = kwnames ? args[nargs] : nullptr;
      double* out_data = fast && out ? ResultArrayData(out, shape.ndim, shape.dims.data()) : nullptr;
      if (fast && out_data) {
        if (call.kernel(model, model.single_state_worker(), frame, x.data(), out_data)) return Py_NewRef(out);
      } else if (fast && !out) {
        py::array_t<double> result = NewArray(shape.ndim, shape.dims.data());
        if (call.kernel(model, model.single_state_worker(), frame, x.data(), result.mutable_data())) {
          return result.release().ptr();
        }
      }
    } catch (py::error_already_set& e) {
      e.restore();
      return nullptr;
    }
  }
  return GeneralCall(kIndex, self, args, nargs, kwnames);
}

// Puts FastMethod<k> in front of each kFastCalls[k]'s pybind11 method, with its docstring.
template <std::size_t... kIndex>
void InstallFastPath(py::class_<Model>& model, std::index_sequence<kIndex...>) {
  static std::array<std::string, kFastCalls.size()> docs;
  static std::array<PyMethodDef, kFastCalls.size()> defs;
  const std::array<_PyCFunctionFastWithKeywords, kFastCalls.size()> functions = {&FastMethod<kIndex>...};
  for (std::size_t k = 0; k < kFastCalls.size(); ++k) {
    py::object general = model.attr(kFastCalls[k].name);
    docs[k] = py::cast<std::string>(general.attr("__doc__"));
    g_general[k] = general.release().ptr();
    defs[k] = {kFastCalls[k].name, reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(functions[k])),
               METH_FASTCALL | METH_KEYWORDS, docs[k].c_str()};
    PyObject* descriptor = PyDescr_NewMethod(reinterpret_cast<PyTypeObject*>(model.ptr()), &defs[k]);
    if (!descriptor) throw py::error_already_set();
    model.attr(kFastCalls[k].name) = py::reinterpret_steal<py::object>(descriptor);
  }
}

void BindModel(py::module_& m) {
  py::class_<Model> model(m, "Model", kModelDoc);
  const std::vector<double> standard_gravity = {0.0, 0.0, -kStandardGravity};
  model
      .def(py::init(&Model::FromUrdf), kInitDoc, py::arg("urdf"), py::kw_only(),
           py::arg("gravity") = standard_gravity, py::arg("method") = "recursive", py::arg("mass_scale") = 1.0,
           py::arg("floating_base") = false)
      .def_static("from_urdf", &Model::FromUrdf, kFromUrdfDoc, py::arg("urdf"), py::arg("gravity") = standard_gravity,
                  py::arg("method") = "recursive", py::arg("mass_scale") = 1.0, py::arg("floating_base") = false)
      .def_static("builtin", &Model::Builtin, kBuiltinDoc, py::arg("name"), py::arg("method") = py::none())
      .def_property_readonly("num_dofs", &Model::num_dofs,
                             "n: the joints' degrees of freedom (q's length for a fixed base).")
      .def_property_readonly("num_positions", &Model::num_positions,
                             "nq: q's length; n for a fixed base, n + 7 for a floating one (p, quaternion x y z w).")
      .def_property_readonly("num_velocities", &Model::num_velocities,
                             "nv: the length of qd, qdd, tau; n for a fixed base, n + 6 for a floating one (v_b, ω_b).")
      .def_property_readonly("floating_base", &Model::floating_base,
                             "Whether the robot's root link is a free base (from_urdf(..., floating_base=True)).")
      .def_property_readonly("joint_names", &Model::joint_names,
                             "The joints' names in q order (list of n str): a URDF's own; pendulum theta, arm2 q1 q2, "
                             "cartpole x theta, chain q1..qn.")
      .def_property_readonly("frame_names", &Model::frame_names,
                             "The frames frame_pose and frame_jacobian take (list of str): a URDF's links; the planar "
                             "plants' links and tip.")
      .def_property_readonly("method", &Model::method, "How M, C, G are derived: closed-form, lagrangian or recursive.")
      .def_property_readonly("plant", &Model::plant, "The plant type: pendulum, arm2, cartpole, chain or urdf.")
      .def("__repr__",
           [](const Model& self) {
             return "<lagrange.Model " + self.plant() + (self.floating_base() ? " on a floating base" : "") + ", " +
                    std::to_string(self.num_dofs()) + " dofs, method " + self.method() + ">";
           })
      // What built it (a URDF's text, or a built-in plant's parameters), so pickle, copy and multiprocessing take it.
      .def(py::pickle([](const Model& self) { return self.GetState(); },
                      [](const py::tuple& state) { return Model::SetState(state); }));

  using Row1 = std::array<const double*, 1>;
  using Row2 = std::array<const double*, 2>;
  using Row3 = std::array<const double*, 3>;

  model.def(
      "mass_matrix",
      [](Model& self, ArrayArg q, int threads, py::object out_array) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value);
        const FloatingDynamics* fb = self.floating();
        return ArrayResult{
            self.Evaluate<1, 1>({&aq}, {Matrix(nv, nv)}, threads, "M is", [&](Worker& w, const Row1& r, auto& out) {
              if (fb) {
                self.FloatingDynamicsCall(
                    w, [&](const auto& fm, auto& d) { fm.ComputeMassMatrix(d, VecMap(r[0], nq), w.matrix); });
              } else {
                self.dynamics().ComputeMassMatrix(*w.dynamics, VecMap(r[0], nq), w.matrix);
              }
              CopyRowMajor(w.matrix, out[0]);
              return w.matrix.allFinite();
            }, out_array)};
      },
      BatchDoc(kMassMatrixDoc).c_str(), py::arg("q"), py::kw_only(), py::arg("threads") = 1, py::arg("out") = py::none());
  model.def(
      "coriolis_matrix",
      [](Model& self, ArrayArg q, ArrayArg qd, int threads) {
        if (self.floating_base()) {
          throw py::value_error("coriolis_matrix: a floating base has no C matrix here (C v: inverse_dynamics at "
                                "qdd = 0 less gravity)");
        }
        const int n = self.num_dofs();
        const JointArray aq("q", q.value, n), aqd("qd", qd.value, n);
        return ArrayResult{
            self.Evaluate<2, 1>({&aq, &aqd}, {Matrix(n, n)}, threads, "C is", [&](Worker& w, const Row2& r, auto& out) {
              self.dynamics().ComputeCoriolisMatrix(*w.dynamics, VecMap(r[0], n), VecMap(r[1], n), w.matrix);
              CopyRowMajor(w.matrix, out[0]);
              return w.matrix.allFinite();
            })};
      },
      BatchDoc(kCoriolisMatrixDoc).c_str(), py::arg("q"), py::arg("qd"), py::kw_only(), py::arg("threads") = 1);
  model.def(
      "gravity",
      [](Model& self, ArrayArg q, int threads, py::object out_array) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value);
        const FloatingDynamics* fb = self.floating();
        return ArrayResult{
            self.Evaluate<1, 1>({&aq}, {Vector(nv)}, threads, "G is", [&](Worker& w, const Row1& r, auto& out) {
              Eigen::Map<VectorXd> G(out[0], nv);
              if (fb) {  // the generalized force that holds it still: ID at v = a = 0, gravity alone
                self.FloatingDynamicsCall(w, [&](const auto& fm, auto& d) {
                  fm.ComputeInverseDynamics(d, VecMap(r[0], nq), w.zero, w.zero, {.gravity = true, .coriolis = false},
                                           G);
                });
              } else {
                self.dynamics().ComputeGravityForce(*w.dynamics, VecMap(r[0], nq), G);
              }
              return G.allFinite();
            }, out_array)};
      },
      BatchDoc(kGravityDoc).c_str(), py::arg("q"), py::kw_only(), py::arg("threads") = 1, py::arg("out") = py::none());
  model.def(
      "forward_dynamics",
      [](Model& self, ArrayArg q, ArrayArg qd, ArrayArg tau, int threads, py::object out_array) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value), aqd = self.VelocityArg("qd", qd.value),
                         atau = self.VelocityArg("tau", tau.value);
        const FloatingDynamics* fb = self.floating();
        return ArrayResult{self.Evaluate<3, 1>(
            {&aq, &aqd, &atau}, {Vector(nv)}, threads, "qdd is", [&](Worker& w, const Row3& r, auto& out) {
              Eigen::Map<VectorXd> qdd(out[0], nv);
              if (fb) {
                self.FloatingDynamicsCall(w, [&](const auto& fm, auto& d) {
                  fm.ComputeForwardDynamics(d, VecMap(r[0], nq), VecMap(r[1], nv), VecMap(r[2], nv), DynamicsTerms{},
                                           qdd);
                });
              } else {
                self.dynamics().ComputeForwardDynamics(*w.dynamics, VecMap(r[0], nq), VecMap(r[1], nv),
                                                       VecMap(r[2], nv), DynamicsTerms{}, qdd);
              }
              return qdd.allFinite();
            }, out_array)};
      },
      BatchDoc(kForwardDynamicsDoc).c_str(), py::arg("q"), py::arg("qd"), py::arg("tau"), py::kw_only(),
      py::arg("threads") = 1, py::arg("out") = py::none());
  model.def(
      "inverse_dynamics",
      [](Model& self, ArrayArg q, ArrayArg qd, ArrayArg qdd, int threads, py::object out_array) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value), aqd = self.VelocityArg("qd", qd.value),
                         aqdd = self.VelocityArg("qdd", qdd.value);
        const FloatingDynamics* fb = self.floating();
        return ArrayResult{self.Evaluate<3, 1>(
            {&aq, &aqd, &aqdd}, {Vector(nv)}, threads, "tau is", [&](Worker& w, const Row3& r, auto& out) {
              Eigen::Map<VectorXd> tau(out[0], nv);
              if (fb) {
                self.FloatingDynamicsCall(w, [&](const auto& fm, auto& d) {
                  fm.ComputeInverseDynamics(d, VecMap(r[0], nq), VecMap(r[1], nv), VecMap(r[2], nv), DynamicsTerms{},
                                           tau);
                });
              } else {
                self.dynamics().ComputeInverseDynamics(*w.dynamics, VecMap(r[0], nq), VecMap(r[1], nv),
                                                       VecMap(r[2], nv), DynamicsTerms{}, tau);
              }
              return tau.allFinite();
            }, out_array)};
      },
      BatchDoc(kInverseDynamicsDoc).c_str(), py::arg("q"), py::arg("qd"), py::arg("qdd"), py::kw_only(),
      py::arg("threads") = 1, py::arg("out") = py::none());
  model.def(
      "kinetic_energy",
      [](Model& self, ArrayArg q, ArrayArg qd, int threads) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value), aqd = self.VelocityArg("qd", qd.value);
        const FloatingDynamics* fb = self.floating();
        return NumberResult{
            self.Evaluate<2, 1>({&aq, &aqd}, {kNumber}, threads, "T is", [&](Worker& w, const Row2& r, auto& out) {
              *out[0] = fb ? self.FloatingDynamicsCall(w,
                                                       [&](const auto& fm, auto& d) {
                                                         return fm.ComputeKineticEnergy(d, VecMap(r[0], nq),
                                                                                       VecMap(r[1], nv));
                                                       })
                           : self.dynamics().ComputeKineticEnergy(*w.dynamics, VecMap(r[0], nq), VecMap(r[1], nv));
              return std::isfinite(*out[0]);
            })};
      },
      BatchDoc(kKineticEnergyDoc).c_str(), py::arg("q"), py::arg("qd"), py::kw_only(), py::arg("threads") = 1);
  model.def(
      "potential_energy",
      [](Model& self, ArrayArg q, int threads) {
        const int nq = self.num_positions();
        const JointArray aq = self.PositionArg("q", q.value);
        const FloatingDynamics* fb = self.floating();
        return NumberResult{
            self.Evaluate<1, 1>({&aq}, {kNumber}, threads, "V is", [&](Worker& w, const Row1& r, auto& out) {
              *out[0] = fb ? self.FloatingDynamicsCall(
                                 w, [&](const auto& fm, auto& d) { return fm.ComputePotentialEnergy(d, VecMap(r[0], nq)); })
                           : self.dynamics().ComputePotentialEnergy(*w.dynamics, VecMap(r[0], nq));
              return std::isfinite(*out[0]);
            })};
      },
      BatchDoc(kPotentialEnergyDoc).c_str(), py::arg("q"), py::kw_only(), py::arg("threads") = 1);

  model.def(
      "frame_pose",
      [](Model& self, const std::variant<int, std::string>& frame, ArrayArg q, int threads) {
        const int nq = self.num_positions();
        const int k = self.Frame(frame);
        const JointArray aq = self.PositionArg("q", q.value);
        const FloatingDynamics* fb = self.floating();
        return PoseResult{self.Evaluate<1, 2>(
            {&aq}, {Matrix(3, 3), Vector(3)}, threads, "the frame is", [&](Worker& w, const Row1& r, auto& out) {
              if (fb) {
                fb->ComputeFramePlacements(*w.floating, VecMap(r[0], nq));
              } else {
                self.kinematics().ComputeFramePlacement(*w.kinematics, VecMap(r[0], nq), k);
              }
              const Eigen::Matrix3d& R = fb ? w.floating->frame_rotation(k) : w.kinematics->rotation(k);
              const Eigen::Vector3d& p = fb ? w.floating->frame_position(k) : w.kinematics->position(k);
              CopyRowMajor(R, out[0]);
              Eigen::Map<Eigen::Vector3d> p_out(out[1]);
              p_out = p;
              return R.allFinite() && p.allFinite();
            })};
      },
      BatchDoc(kFramePoseDoc).c_str(), py::arg("frame"), py::arg("q"), py::kw_only(), py::arg("threads") = 1);
  model.def(
      "frame_jacobian",
      [](Model& self, const std::variant<int, std::string>& frame, ArrayArg q, const std::string& reference,
         int threads, py::object out_array) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const int k = self.Frame(frame);
        const FrameAxes axes = ReferenceAxes(reference);
        const JointArray aq = self.PositionArg("q", q.value);
        const FloatingDynamics* fb = self.floating();
        return ArrayResult{self.Evaluate<1, 1>(
            {&aq}, {Matrix(6, nv)}, threads, "the frame is", [&](Worker& w, const Row1& r, auto& out) {
              if (fb) {  // world-aligned; local: blockdiag(Rᵀ, Rᵀ) J
                fb->ComputeFrameJacobian(*w.floating, VecMap(r[0], nq), k, w.jacobian);
                if (axes == FrameAxes::kLocal) {
                  const Eigen::Matrix3d Rt = w.floating->frame_rotation(k).transpose();
                  w.jacobian.topRows<3>() = Rt * w.jacobian.topRows<3>();
                  w.jacobian.bottomRows<3>() = Rt * w.jacobian.bottomRows<3>();
                }
                CopyRowMajor(w.jacobian, out[0]);
                return w.jacobian.allFinite();
              }
              self.kinematics().ComputeFrameJacobian(*w.kinematics, VecMap(r[0], nq), k, axes);
              const Matrix6Xd& J = w.kinematics->jacobian(k, axes);
              CopyRowMajor(J, out[0]);
              return J.allFinite();
            }, out_array)};
      },
      BatchDoc(kFrameJacobianDoc).c_str(), py::arg("frame"), py::arg("q"), py::kw_only(),
      py::arg("reference") = kLocalWorldAligned, py::arg("threads") = 1, py::arg("out") = py::none());
  model.def(
      "frame_bias_acceleration",
      [](Model& self, const std::variant<int, std::string>& frame, ArrayArg q, ArrayArg qd,
         const std::string& reference, int threads) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const int k = self.Frame(frame);
        const FrameAxes axes = ReferenceAxes(reference);
        const JointArray aq = self.PositionArg("q", q.value), aqd = self.VelocityArg("qd", qd.value);
        const FloatingDynamics* fb = self.floating();
        return ArrayResult{self.Evaluate<2, 1>(
            {&aq, &aqd}, {Vector(6)}, threads, "the frame is", [&](Worker& w, const Row2& r, auto& out) {
              Eigen::Map<Vector6d> b_out(out[0]);
              if (fb) {
                fb->ComputeFrameAccelerationBias(*w.floating, VecMap(r[0], nq), VecMap(r[1], nv), k, b_out);
                if (axes == FrameAxes::kLocal) {
                  const Eigen::Matrix3d Rt = w.floating->frame_rotation(k).transpose();
                  b_out.head<3>() = Rt * b_out.head<3>();
                  b_out.tail<3>() = Rt * b_out.tail<3>();
                }
                return b_out.allFinite();
              }
              self.kinematics().ComputeFrameBiasAcceleration(*w.kinematics, VecMap(r[0], nq), VecMap(r[1], nv), k,
                                                             axes);
              const Vector6d& b = w.kinematics->bias_acceleration(k, axes);
              b_out = b;
              return b.allFinite();
            })};
      },
      BatchDoc(kFrameBiasAccelerationDoc).c_str(), py::arg("frame"), py::arg("q"), py::arg("qd"), py::kw_only(),
      py::arg("reference") = kLocalWorldAligned, py::arg("threads") = 1);
  model.def(
      "frame_id", [](const Model& self, const std::string& name) { return self.Frame(name); },
      "name => its index in frame_names (Pinocchio's getFrameId): frame_pose, frame_jacobian and "
      "frame_bias_acceleration take it in place of the name, without looking the name up.\n\nValueError for a name "
      "the model has not.",
      py::arg("name"));
  model.def(
      "center_of_mass",
      [](Model& self, ArrayArg q, int threads) {
        const FloatingDynamics& fb = self.RequireFloating("center_of_mass");
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value);
        return PoseResult{self.Evaluate<1, 2>(
            {&aq}, {Vector(3), Matrix(3, nv)}, threads, "the centre of mass is",
            [&](Worker& w, const Row1& r, auto& out) {
              Eigen::Map<Eigen::Vector3d> c(out[0]);
              auto Jc = w.jacobian.topRows<3>();
              c = fb.ComputeCenterOfMass(*w.floating, VecMap(r[0], nq), Jc);
              CopyRowMajor(Jc, out[1]);
              return c.allFinite() && Jc.allFinite();
            })};
      },
      BatchDoc(kCenterOfMassDoc).c_str(), py::arg("q"), py::kw_only(), py::arg("threads") = 1);
  model.def(
      "centroidal_momentum_matrix",
      [](Model& self, ArrayArg q, int threads) {
        const FloatingDynamics& fb = self.RequireFloating("centroidal_momentum_matrix");
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value);
        return ArrayResult{self.Evaluate<1, 1>(
            {&aq}, {Matrix(6, nv)}, threads, "A_G is", [&](Worker& w, const Row1& r, auto& out) {
              fb.ComputeCentroidalMomentumMatrix(*w.floating, VecMap(r[0], nq), w.jacobian);
              CopyRowMajor(w.jacobian, out[0]);
              return w.jacobian.allFinite();
            })};
      },
      BatchDoc(kCentroidalMomentumMatrixDoc).c_str(), py::arg("q"), py::kw_only(), py::arg("threads") = 1);
  model.def(
      "centroidal_momentum_bias",
      [](Model& self, ArrayArg q, ArrayArg qd, int threads) {
        const FloatingDynamics& fb = self.RequireFloating("centroidal_momentum_bias");
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value), aqd = self.VelocityArg("qd", qd.value);
        return ArrayResult{self.Evaluate<2, 1>(
            {&aq, &aqd}, {Vector(6)}, threads, "the centroidal momentum bias is",
            [&](Worker& w, const Row2& r, auto& out) {
              Eigen::Map<Vector6d> b(out[0]);
              fb.ComputeCentroidalMomentumBias(*w.floating, VecMap(r[0], nq), VecMap(r[1], nv), b);
              return b.allFinite();
            })};
      },
      BatchDoc(kCentroidalMomentumBiasDoc).c_str(), py::arg("q"), py::arg("qd"), py::kw_only(),
      py::arg("threads") = 1);
  model.def(
      "integrate",
      [](Model& self, ArrayArg q, ArrayArg v, double dt, int threads) {
        if (!std::isfinite(dt)) throw py::value_error("dt: expected a finite number (s)");
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray aq = self.PositionArg("q", q.value), av = self.VelocityArg("v", v.value);
        const bool fb = self.floating_base();
        return ArrayResult{
            self.Evaluate<2, 1>({&aq, &av}, {Vector(nq)}, threads, "q is", [&](Worker&, const Row2& r, auto& out) {
              Eigen::Map<VectorXd> next(out[0], nq);
              if (fb) {
                Integrate(VecMap(r[0], nq), VecMap(r[1], nv), dt, next);
              } else {
                next = VecMap(r[0], nq) + dt * VecMap(r[1], nv);
              }
              return next.allFinite();
            })};
      },
      BatchDoc(kIntegrateDoc).c_str(), py::arg("q"), py::arg("v"), py::arg("dt"), py::kw_only(),
      py::arg("threads") = 1);
  model.def(
      "difference",
      [](Model& self, ArrayArg q0, ArrayArg q1, int threads) {
        const int nq = self.num_positions(), nv = self.num_velocities();
        const JointArray a0 = self.PositionArg("q0", q0.value), a1 = self.PositionArg("q1", q1.value);
        const bool fb = self.floating_base();
        return ArrayResult{
            self.Evaluate<2, 1>({&a0, &a1}, {Vector(nv)}, threads, "v is", [&](Worker&, const Row2& r, auto& out) {
              Eigen::Map<VectorXd> v(out[0], nv);
              if (fb) {
                Difference(VecMap(r[0], nq), VecMap(r[1], nq), v);
              } else {
                v = VecMap(r[1], nq) - VecMap(r[0], nq);
              }
              return v.allFinite();
            })};
      },
      BatchDoc(kDifferenceDoc).c_str(), py::arg("q0"), py::arg("q1"), py::kw_only(), py::arg("threads") = 1);

  InstallFastPath(model, std::make_index_sequence<kFastCalls.size()>{});

  model.def("_time_forward_dynamics", &Model::TimeForwardDynamics,
            "Seconds per C++ forward-dynamics call, `iterations` in a loop at one state or cycling through a batch's "
            "rows (bench/python_bench.py).",
            py::arg("q"), py::arg("qd"), py::arg("tau"), py::arg("iterations"));
}

}  // namespace lagrange::python
