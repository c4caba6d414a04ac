// lagrange.simulate and lagrange.Instance: a scene run by the daemon's own
// Instance code (sim/instance.hpp) under its health rule
// (sim/health.hpp), prepared as lagrangectl simulate prepares it
// (PrepareOfflineScene, sim/offline.hpp). What simulate returns per row is
// what lagrangectl simulate writes per CSV row, the same doubles.

#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>

#include "base/escape.hpp"
#include "python/bindings.hpp"
#include "python/bus_arrays.hpp"
#include "python/paths.hpp"
#include "sim/health.hpp"
#include "sim/offline.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"

namespace lagrange::python {
namespace {

// A scene argument: a path (str or os.PathLike), or YAML text (a str holding
// a line break). ValueError for a scene the reader refuses, FileNotFoundError
// for a path that names no file, each with the reader's one line.
struct SceneSource {
  Scene scene;
  std::string label;  // the file, or "<scene text>"
};

SceneSource ReadSceneArgument(const py::handle& scene) {
  const bool path_like = py::isinstance<py::bytes>(scene) || py::hasattr(scene, "__fspath__");
  if (!path_like && !py::isinstance<py::str>(scene)) {
    throw py::type_error("scene: expected a path or YAML text (str), got " +
                         std::string(py::str(py::type::of(scene).attr("__name__"))));
  }
  // A str holding a line break is YAML text; any other argument names a file (its bytes, as open() takes it).
  const bool yaml_text = !path_like && PySequence_Contains(scene.ptr(), py::str("\n").ptr()) == 1;
  const std::string text = yaml_text ? scene.cast<std::string>() : FsPath(scene, "scene");
  const std::string label = yaml_text ? "<scene text>" : text;
  try {
    return {yaml_text ? ParseScene(text, label) : LoadScene(text), label};
  } catch (const ConfigError& e) {
    std::error_code ec;
    if (!yaml_text && !std::filesystem::exists(text, ec)) {
      PyErr_SetString(PyExc_FileNotFoundError, ValidUtf8(e.what()).c_str());
      throw py::error_already_set();
    }
    throw py::value_error(ValidUtf8(e.what()));
  }
}

// The offline scene, or ValueError with the CLI's line (refused offline, ticks that do not fit the period).
OfflineScene Prepare(const SceneSource& source, const std::function<bool(std::size_t)>& stepped = {}) {
  try {
    return PrepareOfflineScene(source.scene, source.label, stepped);
  } catch (const py::error_already_set&) {
    throw;
  } catch (const std::exception& e) {
    throw py::value_error(ValidUtf8(e.what()));
  }
}

// (tau or none) => one step of `inst`, as lagranged steps a running instance:
// without tau under its active controller and the scene's trajectory; with
// tau, under an active external controller as the latest streamed torque
// (its compensate_gravity and torque limits apply), else applied as given
// (no controller: only the plant's saturation effect limits it).
Instance::StepFailure StepOnce(Instance& inst, double period, const VectorXd* tau) {
  if (tau == nullptr) return inst.Step(period);
  if (ExternalController* external = inst.external_controller(inst.active_controller())) {
    external->SetTorque(*tau);
    return inst.Step(period);
  }
  return inst.StepWithTorque(period, *tau);
}

// ε, J: the energy balance's residual, nan when the instance keeps none (telemetry off).
double Residual(const Instance& inst) {
  return inst.accounting() ? inst.energy_balance().residual() : std::numeric_limits<double>::quiet_NaN();
}

// One instance's rows, as lagrangectl simulate writes them (t, q, qd, q_des,
// tau, T, V, and a floating base's columns: BaseRowOf) and ε; under a
// controller that moves a frame (`frame` not "") also its FILE.task.csv rows
// (TaskRowOf).
struct Recording {
  std::string name;
  std::vector<std::string> joint_names;
  int n = 0;
  std::vector<double> t, q, qd, q_des, tau, kinetic, potential, residual;
  std::optional<std::string> fault, mpc_failures;
  std::string frame;                                  // TaskFrameOf; "": no task rows
  std::vector<double> position, position_des, error;  // 3, 3 and 6 per row, with a `frame`
  bool floating = false;
  std::vector<double> base;  // kBaseStateWidth per row, with a floating base

  void Reserve(std::size_t rows) {
    for (std::vector<double>* v : {&t, &kinetic, &potential, &residual}) v->reserve(rows);
    for (std::vector<double>* v : {&q, &qd, &q_des, &tau}) v->reserve(rows * static_cast<std::size_t>(n));
    if (floating) base.reserve(rows * kBaseStateWidth);
    if (frame.empty()) return;
    for (std::vector<double>* v : {&position, &position_des}) v->reserve(rows * 3);
    error.reserve(rows * 6);
  }

  void Add(Instance& inst) {
    const bool computed = !t.empty();  // past the row at t = 0
    t.push_back(inst.t());
    for (const auto& [out, v] :
         {std::pair{&q, &inst.q()}, {&qd, &inst.qd()}, {&q_des, &inst.q_des()}, {&tau, &inst.tau()}}) {
      out->insert(out->end(), v->data(), v->data() + v->size());
    }
    kinetic.push_back(inst.KineticEnergy());
    potential.push_back(inst.PotentialEnergy());
    residual.push_back(Residual(inst));
    if (floating) {
      const BaseRow row = BaseRowOf(inst);
      base.insert(base.end(), row.begin(), row.end());
    }
    if (frame.empty()) return;
    const OfflineTaskRow row = TaskRowOf(inst, computed);
    position.insert(position.end(), row.position.data(), row.position.data() + 3);
    position_des.insert(position_des.end(), row.position_des.data(), row.position_des.data() + 3);
    error.insert(error.end(), row.error.data(), row.error.data() + 6);
  }
};

// SimulationResult.task: the frame a task-space controller (or an mpc with a frame) moved, one row per step.
struct TaskRows {
  std::string frame;
  py::array_t<double> position, position_des, error;
};

// SimulationResult.base: a floating base, one row per step (BaseColumns).
struct BaseRows {
  BaseArrays arrays;
};

// The result of lagrange.simulate for one instance: numpy arrays, one row per step.
struct SimulationResult {
  std::string name;
  std::vector<std::string> joint_names;
  py::array_t<double> t, q, qd, q_des, tau, kinetic_energy, potential_energy, energy_residual;
  std::optional<std::string> fault, mpc_failures;
  std::optional<TaskRows> task;
  std::optional<BaseRows> base;

  explicit SimulationResult(const Recording& r)
      : name(r.name),
        joint_names(r.joint_names),
        t(ToArray(r.t)),
        q(ToMatrix(r.q, static_cast<py::ssize_t>(r.t.size()), r.n)),
        qd(ToMatrix(r.qd, static_cast<py::ssize_t>(r.t.size()), r.n)),
        q_des(ToMatrix(r.q_des, static_cast<py::ssize_t>(r.t.size()), r.n)),
        tau(ToMatrix(r.tau, static_cast<py::ssize_t>(r.t.size()), r.n)),
        kinetic_energy(ToArray(r.kinetic)),
        potential_energy(ToArray(r.potential)),
        energy_residual(ToArray(r.residual)),
        fault(r.fault),
        mpc_failures(r.mpc_failures) {
    const auto rows = static_cast<py::ssize_t>(r.t.size());
    if (r.floating) base = BaseRows{BaseColumns(r.base, rows)};
    if (r.frame.empty()) return;
    task =
        TaskRows{r.frame, ToMatrix(r.position, rows, 3), ToMatrix(r.position_des, rows, 3), ToMatrix(r.error, rows, 6)};
  }
};

// Rows between two looks for a pending signal (KeyboardInterrupt) in a run.
constexpr std::int64_t kSignalCheckRows = 1 << 16;

// The most of this machine's physical memory a run's rows may take: simulate
// keeps every row, and holds them twice at the end (its vectors, then the
// numpy arrays), so a run that outgrew the memory would end in the kernel's
// OOM killer, not in a MemoryError.
constexpr double kRowsMemoryShare = 0.25;

// round(duration / period), or ValueError when the rows of that many steps
// would take more than kRowsMemoryShare of the memory (before anything runs).
std::int64_t StepsThatFit(double duration, double period, const std::vector<Instance>& instances) {
  double row_bytes = 0.0;  // t, T, V, ε and q, qd, q_des, tau, each instance's, and a floating base's
  for (const Instance& inst : instances) {
    row_bytes += sizeof(double) * (4.0 + 4.0 * inst.num_dofs() + (inst.floating_base() ? kBaseStateWidth : 0));
  }
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  const double memory = pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0x1p53;
  const double budget = kRowsMemoryShare * memory;
  const double steps = std::round(duration / period);
  const double most = std::min(std::floor(budget / row_bytes) - 1.0, 0x1p53);  // steps whose rows fit
  if (steps <= most) return static_cast<std::int64_t>(steps);
  const auto text = [](double x, const char* unit) {
    char buffer[48];
    std::snprintf(buffer, sizeof buffer, "%.4g%s", x, unit);
    return std::string(buffer);
  };
  throw py::value_error("duration: " + text(duration, " s") + " is " + text(steps, " steps") + " of " +
                        text(period, " s") + ", " + text((steps + 1.0) * row_bytes / 1e9, " GB") +
                        " of rows; a quarter of this machine's memory (" + text(budget / 1e9, " GB") + ") holds " +
                        text(std::max(most, 0.0) * period, " s") +
                        " of this scene: simulate it in shorter pieces, or step an Instance");
}

py::dict Simulate(const py::object& scene_arg, double duration, const py::object& controller) {
  if (!(std::isfinite(duration) && duration > 0.0)) {
    throw py::value_error("duration: expected a positive number of seconds, got " + FormatDouble(duration));
  }
  const SceneSource source = ReadSceneArgument(scene_arg);
  // Which instances a Python controller steps: a callable for a one-instance
  // scene, or a dict {instance name: callable}.
  std::map<std::string, py::object> laws;
  if (py::isinstance<py::dict>(controller)) {
    for (const auto& [key, law] : controller.cast<py::dict>())
      laws[py::str(key)] = py::reinterpret_borrow<py::object>(law);
  } else if (!controller.is_none()) {
    if (source.scene.instances.size() != 1) {
      throw py::value_error("controller: the scene has " + std::to_string(source.scene.instances.size()) +
                            " instances: give a dict {instance name: callable}");
    }
    laws[source.scene.instances[0].name] = controller;
  }
  for (const auto& [name, law] : laws) {
    bool known = false;
    for (const InstanceConfig& c : source.scene.instances) known = known || c.name == name;
    if (!known) throw py::value_error("controller: the scene has no instance '" + name + "'");
    if (!PyCallable_Check(law.ptr()))
      throw py::type_error("controller for '" + name + "': expected a callable (t, q, qd) -> tau");
  }
  std::vector<py::object> law_of(source.scene.instances.size());
  for (std::size_t i = 0; i < law_of.size(); ++i) {
    if (const auto it = laws.find(source.scene.instances[i].name); it != laws.end()) law_of[i] = it->second;
  }
  OfflineScene offline = Prepare(source, [&](std::size_t i) { return static_cast<bool>(law_of[i]); });
  std::vector<Instance>& instances = offline.instances;

  std::vector<Recording> recordings(instances.size());
  for (std::size_t i = 0; i < instances.size(); ++i) {
    recordings[i].name = instances[i].name();
    recordings[i].joint_names = instances[i].instance_model().joint_names;
    recordings[i].n = instances[i].num_dofs();
    recordings[i].floating = instances[i].floating_base();
    // The frame an instance's scene controller moves, as lagrangectl simulate writes it (a Python law bypasses
    // the controller: it computes nothing to record).
    if (!law_of[i]) recordings[i].frame = TaskFrameOf(instances[i]);
  }
  const std::int64_t steps = StepsThatFit(duration, offline.period, instances);
  for (Recording& r : recordings) r.Reserve(static_cast<std::size_t>(steps) + 1);
  // Ctrl-C reaches a long run: every kSignalCheckRows rows the GIL is taken back to look.
  std::int64_t rows = 0;
  const auto observe = [&](std::size_t i, Instance& inst) {
    recordings[i].Add(inst);
    if (++rows % kSignalCheckRows != 0) return;
    const bool released = PyGILState_Check() == 0;
    std::optional<py::gil_scoped_acquire> gil;
    if (released) gil.emplace();
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  };
  std::vector<OfflineFault> faults;
  if (laws.empty()) {
    // The scene's own controllers: the same run as lagrangectl simulate, without the GIL.
    py::gil_scoped_release release;
    faults = RunOfflineChecked(instances, offline.period, steps, observe);
  } else {
    // A Python law is called before each of its instance's steps with the
    // state it starts from; the run and its health rule are RunOfflineChecked's.
    std::vector<VectorXd> tau(instances.size());
    faults = RunOfflineChecked(instances, offline.period, steps, observe, [&](std::size_t i, Instance& inst) {
      if (!law_of[i]) return StepOnce(inst, offline.period, nullptr);
      const py::object out = law_of[i](inst.t(), ToArray(inst.q()), ToArray(inst.qd()));
      tau[i] = JointVector(out, inst.num_dofs(), ("controller for '" + inst.name() + "' returned tau").c_str());
      return StepOnce(inst, offline.period, &tau[i]);
    });
  }
  for (const OfflineFault& f : faults) {
    recordings[f.index].fault = OfflineFaultText(instances[f.index], f);
    PyErr_WarnEx(PyExc_RuntimeWarning, ("lagrange.simulate: " + *recordings[f.index].fault).c_str(), 1);
  }
  for (std::size_t i = 0; i < instances.size(); ++i) {
    recordings[i].mpc_failures = OfflineMpcFailureText(instances[i]);
    if (recordings[i].mpc_failures) {
      PyErr_WarnEx(PyExc_RuntimeWarning, ("lagrange.simulate: " + *recordings[i].mpc_failures).c_str(), 1);
    }
  }
  py::dict out;
  for (const Recording& r : recordings) out[py::str(r.name)] = SimulationResult(r);
  return out;
}

// lagrange.Instance: one scene instance stepped from Python.
class PyInstance {
 public:
  PyInstance(const py::object& scene_arg, const std::optional<std::string>& name) {
    const SceneSource source = ReadSceneArgument(scene_arg);
    const std::vector<InstanceConfig>& all = source.scene.instances;
    if (!name && all.size() != 1) {
      std::string names;
      for (const InstanceConfig& c : all) names += (names.empty() ? "" : ", ") + c.name;
      throw py::value_error(ValidUtf8(source.label + ": " + std::to_string(all.size()) + " instances (" + names +
                                      "): name the one to step"));
    }
    index_ = all.size();
    for (std::size_t i = 0; i < all.size(); ++i) index_ = (name && all[i].name == *name) || !name ? i : index_;
    if (index_ == all.size())
      throw py::value_error(ValidUtf8(source.label) + ": no instance '" + Escape(*name, 64) + "'");
    // The stepped instance's external controller takes its torques from step(tau).
    scene_ = Prepare(source, [&](std::size_t i) { return i == index_; });
    good_ = inst().MakeSaved();
  }

  Instance& inst() { return scene_.instances[index_]; }

  // One step; on a fault, back to the last healthy state and RuntimeError.
  void Step(const py::object& tau_arg) {
    std::optional<VectorXd> tau;
    if (!tau_arg.is_none())
      tau = JointVector(tau_arg, inst().num_dofs(), "tau");
    else if (inst().external_controller(inst().active_controller()) != nullptr && !torque_given_) {
      // As lagranged holds an external controller's instance until its first torque.
      throw py::value_error(inst().name() + " runs an external controller: step(tau) needs a torque (none given yet)");
    }
    torque_given_ = torque_given_ || tau.has_value();
    const Instance::StepFailure step = StepOnce(inst(), scene_.period, tau ? &*tau : nullptr);
    StepEnergies energies;
    if (const std::optional<OfflineFault> fault = CheckOfflineStep(index_, inst(), step, good_, energies)) {
      throw std::runtime_error(ValidUtf8(OfflineFaultText(inst(), *fault)) + "; the instance is back at t = " +
                               FormatDouble(inst().t()) + " s, the last healthy step");
    }
  }

  // (q or None, qd or None, base_q or None, base_v or None) => the instance there (Instance::SetState,
  // SetBaseState), the last healthy state. Every argument is checked before anything moves.
  void SetState(const py::object& q_arg, const py::object& qd_arg, const py::object& base_q_arg = py::none(),
                const py::object& base_v_arg = py::none()) {
    const int n = inst().num_dofs();
    const VectorXd q = q_arg.is_none() ? inst().q() : JointVector(q_arg, n, "q");
    const VectorXd qd = qd_arg.is_none() ? inst().qd() : JointVector(qd_arg, n, "qd");
    if (base_q_arg.is_none() && base_v_arg.is_none()) {
      inst().SetState(q, qd);
    } else {
      if (!inst().floating_base()) {
        throw py::value_error(std::string(base_q_arg.is_none() ? "base_v" : "base_q") +
                              ": this instance's base is fixed (a scene's floating_base: true frees it)");
      }
      VectorXd base_q = base_q_arg.is_none() ? VectorXd(inst().floating_q().head<kFreeFlyerNq>())
                                             : JointVector(base_q_arg, kFreeFlyerNq, "base_q");
      const VectorXd base_v = base_v_arg.is_none() ? VectorXd(inst().floating_v().head<kFreeFlyerNv>())
                                                   : JointVector(base_v_arg, kFreeFlyerNv, "base_v");
      if (!NormaliseBaseQuaternion(base_q)) {
        throw py::value_error("base_q: expected [px, py, pz, x, y, z, w] with a unit quaternion (x, y, z, w; within " +
                              FormatDouble(kQuaternionNormTolerance) + ", then normalised), got one of norm " +
                              FormatDouble(base_q.segment<4>(3).norm()));
      }
      inst().SetState(q, qd, base_q, base_v);
    }
    good_ = inst().MakeSaved();
  }

  void Reset() {
    inst().Reset();
    good_ = inst().MakeSaved();
    torque_given_ = false;
  }

  double period() const { return scene_.period; }

 private:
  OfflineScene scene_;
  std::size_t index_ = 0;
  Instance::Saved good_;
  bool torque_given_ = false;
};

// What each of a floating base's arrays holds (base_state_t's comments), in kBaseStateArrays' order.
constexpr const char* kBaseArrayDocs[] = {
    "the base frame's origin in the world, m",
    "its axes in the world, a unit quaternion (x, y, z, w)",
    "the base origin's velocity, base axes, m/s",
    "the base's angular velocity, base axes, rad/s",
    "the robot's centre of mass, world, m",
    "the robot's linear momentum, world axes, N·s (total mass × the centre of mass's velocity)",
    "the robot's angular momentum about its centre of mass, world axes, N·m·s",
};
static_assert(std::size(kBaseArrayDocs) == kNumBaseArrays);

// The base's arrays as read-only attributes of `cls`, named as log2csv's <NAME>_BASE columns; `shape` says
// each one's shape with W its width ("(W,)" or "(N, W)").
template <class T, class Arrays>
void DefBaseArrays(py::class_<T>& cls, Arrays T::*arrays, const std::string& shape) {
  for (std::size_t k = 0; k < kNumBaseArrays; ++k) {
    std::string doc = std::string(kBaseArrayDocs[k]) + ", shape " + shape;
    doc.replace(doc.find('W'), 1, std::to_string(kBaseStateArrays[k].width));
    cls.def_property_readonly(
        kBaseStateArrays[k].name, [arrays, k](const T& self) { return (self.*arrays)[k]; }, doc.c_str());
  }
}

}  // namespace

void BindSimulate(py::module_& m) {
  py::class_<BaseState> base_state(
      m, "BaseState",
      "A floating base at one instant: lagranged's base_state_t on <NAME>_BASE (Client.base_state), or an\n"
      "Instance's base now (Instance.base); the free-flyer's conventions (README, \"Floating base\").\n"
      "Arrays named as log2csv's <NAME>_BASE columns.");
  base_state.def_readonly("t", &BaseState::t, "Simulated time, s.")
      .def_readonly("utime", &BaseState::utime, "Wall clock of the tick, µs since the epoch (None offline).")
      .def_readonly("run_id", &BaseState::run_id, "The lagranged run that published it (None offline).")
      .def_readonly("tick", &BaseState::tick, "The tick of the state published with it (None offline).");
  DefBaseArrays(base_state, &BaseState::arrays, "(W,)");
  base_state.def("__repr__", [](const BaseState& b) {
    const double* p = b.arrays[0].data();
    return "<lagrange.BaseState t = " + FormatDouble(b.t) + " s at (" + FormatDouble(p[0]) + ", " + FormatDouble(p[1]) +
           ", " + FormatDouble(p[2]) + ") m>";
  });

  py::class_<BaseRows> base_rows(
      m, "BaseRows",
      "A floating base, one row per step of its SimulationResult: lagrangectl simulate's base columns, the same\n"
      "doubles (lagranged publishes them as base_state_t on <NAME>_BASE), arrays named as those columns.");
  DefBaseArrays(base_rows, &BaseRows::arrays, "(N, W)");
  base_rows.def("__repr__", [](const BaseRows& b) {
    return "<lagrange.BaseRows " + std::to_string(b.arrays[0].shape(0)) + " rows>";
  });

  py::class_<TaskRows>(m, "TaskRows",
                       "The frame a task-space controller (cartesian-impedance, operational-space) or an mpc\n"
                       "controller with a frame moved, one row\n"
                       "per step of its SimulationResult: lagrangectl simulate's FILE.task.csv, the same doubles\n"
                       "(lagranged publishes them as task_state_t). nan in the row at t = 0, before the first "
                       "control step.")
      .def_readonly("frame", &TaskRows::frame, "The frame's name (as frame_names gives it).")
      .def_readonly("position", &TaskRows::position, "Its origin, m, world frame, shape (N, 3).")
      .def_readonly("position_des", &TaskRows::position_des, "The commanded origin, m, shape (N, 3).")
      .def_readonly("error", &TaskRows::error,
                    "The pose error e = commanded ⊖ measured: position (m), then rotation (rad, world axes), "
                    "shape (N, 6).")
      .def("__repr__", [](const TaskRows& r) {
        return "<lagrange.TaskRows " + r.frame + ": " + std::to_string(r.position.shape(0)) + " rows>";
      });

  py::class_<SimulationResult>(m, "SimulationResult",
                               "One instance's run from lagrange.simulate: one row per step, the first at t = 0.\n"
                               "Each row holds what lagrangectl simulate writes in its CSV row, the same doubles.")
      .def_readonly("name", &SimulationResult::name, "The instance's name (as in the scene).")
      .def_readonly("joint_names", &SimulationResult::joint_names, "Joint names in q order (as the .joints.csv).")
      .def_readonly("t", &SimulationResult::t, "Simulated time, s, shape (N,).")
      .def_readonly("q", &SimulationResult::q, "Joint positions, rad or m, shape (N, n).")
      .def_readonly("qd", &SimulationResult::qd, "Joint velocities, rad/s or m/s, shape (N, n).")
      .def_readonly("q_des", &SimulationResult::q_des, "The setpoint's positions at each step, shape (N, n).")
      .def_readonly("tau", &SimulationResult::tau,
                    "Applied generalized force of the step that led to the row (after limits and saturation), "
                    "N·m or N, shape (N, n); zero at t = 0.")
      .def_readonly("kinetic_energy", &SimulationResult::kinetic_energy, "T, J, shape (N,).")
      .def_readonly("potential_energy", &SimulationResult::potential_energy,
                    "V, J, shape (N,) (zero at the base's height; joint limits' springs included).")
      .def_readonly("energy_residual", &SimulationResult::energy_residual,
                    "ε = E − E(0) − W, J, shape (N,): the energy balance's residual (telemetry_t.energy_residual); "
                    "nan when the scene keeps no balance (telemetry: false and no energy_balance).")
      .def_property_readonly(
          "epsilon", [](const SimulationResult& r) { return r.energy_residual; }, "Alias of energy_residual.")
      .def_property_readonly(
          "energies",
          [](const SimulationResult& r) {
            const py::ssize_t rows = r.t.shape(0);
            py::array_t<double> out({rows, py::ssize_t{2}});
            for (py::ssize_t k = 0; k < rows; ++k) {
              out.mutable_at(k, 0) = r.kinetic_energy.at(k);
              out.mutable_at(k, 1) = r.potential_energy.at(k);
            }
            return out;
          },
          "T and V side by side, J, shape (N, 2) (kinetic_energy, potential_energy).")
      .def_readonly("fault", &SimulationResult::fault,
                    "None, or the health check's line when the instance faulted: its rows then end at the last "
                    "healthy step.")
      .def_readonly("mpc_failures", &SimulationResult::mpc_failures,
                    "None, or the line saying how many of an mpc controller's solves failed and their statuses "
                    "(lagrangectl simulate's line): the last usable plan was followed meanwhile.")
      .def_readonly("task", &SimulationResult::task,
                    "TaskRows under a controller that moves a frame (a task-space controller, or an mpc with a "
                    "frame: the frame's position, target and error per row, as lagrangectl simulate's "
                    "FILE.task.csv); None for any other controller, or a Python law.")
      .def_readonly("base", &SimulationResult::base,
                    "BaseRows for a floating base (plant floating_base: true): its pose, twist, centre of mass and "
                    "momentum per row, as lagrangectl simulate's base columns; None for a fixed base. q, qd, q_des "
                    "and tau are the joints' alone.")
      .def("__repr__", [](const SimulationResult& r) {
        return "<lagrange.SimulationResult " + r.name + ": " + std::to_string(r.t.shape(0)) + " rows" +
               (r.fault ? ", faulted" : "") + ">";
      });

  m.def("simulate", &Simulate, py::arg("scene"), py::arg("duration"), py::kw_only(), py::arg("controller") = py::none(),
        R"(Run a scene offline with lagranged's Instance code, as fast as the machine goes.

scene       a scene file (str, bytes or os.PathLike), or YAML text (a str with a line break)
duration    simulated time, s (> 0): round(duration / period) steps after the row at t = 0
controller  None: every instance under its scene controller and trajectory (the rows are
            the doubles `lagrangectl simulate` writes, and the run releases the GIL);
            or a callable (t, q, qd) -> tau (N·m or N, shape (n,)) called before every step
            of a one-instance scene; or a dict {instance name: callable}. A Python law's tau
            is the latest streamed torque of an instance under `controller: external`
            (its compensate_gravity and torque limits apply, as in lagranged), and the
            applied force of any other instance (its controller bypassed).

Returns {instance name: SimulationResult} (a floating base's pose, twist, centre of mass and
momentum in its `base`; q, qd and a Python law's arguments and tau are the joints'). Each step passes lagranged's health check; an
instance that fails it stops at its last healthy row, its result's `fault` names why, and a
RuntimeWarning says so. Raises ValueError (a bad scene, one an offline run refuses: an
external plant, an external controller without a Python law; ticks that do not fit the
period; a duration whose rows would take more than a quarter of this machine's memory,
before anything runs), FileNotFoundError (no such scene file), with lagrangectl's
one-line messages.)");

  py::class_<PyInstance>(
      m, "Instance",
      R"(One scene instance stepped from Python: lagranged's Instance, its controllers and health check.

Instance(scene, name=None): scene as for simulate (a path or YAML text); name picks the
instance of a scene with several. A scene instance under `controller: external` takes
step(tau) as its streamed torque, as lagranged does; any other applies tau as given.)")
      .def(py::init<const py::object&, const std::optional<std::string>&>(), py::arg("scene"),
           py::arg("name") = py::none())
      .def("step", &PyInstance::Step, py::arg("tau") = py::none(),
           R"(Advance one period.

tau None: under the active controller and the scene's trajectory (lagrangectl simulate's step).
tau (n,) N·m or N: under an external controller, its streamed torque (+ G(q) with
compensate_gravity, within torque_limits); otherwise applied as given, no controller.
A step that fails lagranged's health check puts the instance back at its last healthy
state and raises RuntimeError naming why.)")
      .def("reset", &PyInstance::Reset, "Back to the scene's initial state at t = 0 (lagranged's reset).")
      .def_property_readonly("name", [](PyInstance& s) { return s.inst().name(); })
      .def_property_readonly("num_dofs", [](PyInstance& s) { return s.inst().num_dofs(); })
      .def_property_readonly("joint_names", [](PyInstance& s) { return s.inst().instance_model().joint_names; })
      .def_property_readonly("period", &PyInstance::period, "The scene's period, s: one step's length.")
      .def_property_readonly(
          "t", [](PyInstance& s) { return s.inst().t(); }, "Simulated time, s.")
      .def_property(
          "q", [](PyInstance& s) { return ToArray(s.inst().q()); },
          [](PyInstance& s, const py::object& q) { s.SetState(q, py::none()); },
          "Positions, shape (n,), rad or m (a copy). Assigning one moves the instance there (set_state).")
      .def_property(
          "qd", [](PyInstance& s) { return ToArray(s.inst().qd()); },
          [](PyInstance& s, const py::object& qd) { s.SetState(py::none(), qd); },
          "Velocities, shape (n,), rad/s or m/s (a copy). Assigning them sets them (set_state).")
      .def("set_state", &PyInstance::SetState, py::arg("q") = py::none(), py::arg("qd") = py::none(),
           py::arg("base_q") = py::none(), py::arg("base_v") = py::none(),
           R"(Put the instance at (q, qd) at the current time, as moving the robot by hand.

q       (n,) rad or m; None keeps the current positions
qd      (n,) rad/s or m/s; None keeps the current velocities
base_q  a floating base's pose (7,): p (m, world), then the unit quaternion x, y, z, w (within
        1e-6 of unit, then normalised); None keeps it. ValueError on a fixed base.
base_v  a floating base's twist (6,): v (m/s) then omega (rad/s), both in base axes; None keeps it
The next step starts there, under the same controller and trajectory (time runs on); qdd is
recomputed there under the last applied tau; the energy balance is re-based, so
energy_residual runs on (the jump in energy is no work done), and the state becomes the one a
faulting step returns to. ValueError for a wrong shape or a value that is not finite.)")
      .def_property_readonly(
          "qdd", [](PyInstance& s) { return ToArray(s.inst().qdd()); },
          "Accelerations at the current state under the last applied tau, shape (n,).")
      .def_property_readonly(
          "tau", [](PyInstance& s) { return ToArray(s.inst().tau()); },
          "The last step's applied force (after limits and saturation), shape (n,).")
      .def_property_readonly(
          "q_des", [](PyInstance& s) { return ToArray(s.inst().q_des()); },
          "The last step's setpoint positions, shape (n,).")
      .def_property_readonly(
          "kinetic_energy", [](PyInstance& s) { return s.inst().KineticEnergy(); }, "T, J.")
      .def_property_readonly(
          "potential_energy", [](PyInstance& s) { return s.inst().PotentialEnergy(); }, "V, J.")
      .def_property_readonly(
          "energy_residual", [](PyInstance& s) { return Residual(s.inst()); }, "ε, J (nan without an energy balance).")
      .def_property_readonly(
          "controller", [](PyInstance& s) { return std::string(s.inst().controller().name()); },
          "The active controller's type.")
      .def_property_readonly(
          "base",
          [](PyInstance& s) -> std::optional<BaseState> {
            if (!s.inst().floating_base()) return std::nullopt;
            const BaseRow row = BaseRowOf(s.inst());
            return BaseState(s.inst().t(), row.data());
          },
          "A floating base's pose, twist, centre of mass and momentum now (a BaseState, as lagranged publishes "
          "on <NAME>_BASE); None for a fixed base. q, qd and the rest are the joints' alone.")
      .def("__repr__", [](PyInstance& s) {
        return "<lagrange.Instance " + s.inst().name() + " at t = " + FormatDouble(s.inst().t()) + " s>";
      });
}

}  // namespace lagrange::python
