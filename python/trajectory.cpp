// lagrange.optimize_trajectory: offline trajectory optimisation by the solver
// model-predictive control plans with (controllers/ddp.hpp: box-constrained
// DDP in Gauss–Newton form on the plant's exact step derivatives). The
// problem is a DdpModel built from the call's arguments, validated by it
// (its refusals in the call's words); the solve runs once, cold, without the
// GIL, in a DdpData of its own (Ctrl-C stops it within a knot of its passes); the
// result is its nominal trajectory, gains and record as numpy arrays.

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/number_text.hpp"
#include "controllers/ddp.hpp"
#include "controllers/mpc.hpp"
#include "plant/plant_factory.hpp"
#include "python/bindings.hpp"
#include "python/model_arrays.hpp"

namespace lagrange::python {
namespace py = pybind11;
namespace {

// The result of optimize_trajectory: the nominal trajectory of the last
// iteration, its affine policy, and the solver's record.
struct TrajectoryResult {
  py::array_t<double> t, q, qd, tau, K, cost_history;
  std::vector<int> actuated;
  std::string status;
  int iterations = 0;
  double cost = 0.0, expected_decrease = 0.0, regularization = 0.0;
};

std::string Values(int n) { return std::to_string(n) + (n == 1 ? " value" : " values"); }

// A number or a 1-D array as float64 (NaN and inf kept: DdpModel judges them), or ValueError naming `name`.
py::array_t<double> Numbers(const std::string& name, py::handle value, const std::string& expected) {
  py::object converted;  // None and text are not numbers (numpy would read "10" as 10)
  if (!value.is_none() && !py::isinstance<py::str>(value) && !py::isinstance<py::bytes>(value)) {
    converted = py::array_t<double, py::array::forcecast>::ensure(value);
  }
  if (!converted) {
    PyErr_Clear();
    throw py::value_error(name + ": expected " + expected + ", got " +
                          std::string(py::str(py::type::handle_of(value).attr("__name__"))));
  }
  auto a = py::reinterpret_steal<py::array_t<double>>(converted.release());
  if (a.ndim() > 1) {
    throw py::value_error(name + ": expected " + expected + ", got an array of " + std::to_string(a.ndim()) +
                          " dimensions");
  }
  return a;
}

// A number (on every one of `size` entries) or `size` values.
VectorXd PerEntry(const std::string& name, py::handle value, int size, const char* per) {
  const std::string expected = "a number or " + Values(size) + " (one per " + per + ")";
  const py::array_t<double> a = Numbers(name, value, expected);
  if (a.ndim() == 0) return VectorXd::Constant(size, *a.data());
  if (a.shape(0) != size) {
    throw py::value_error(name + ": expected " + expected + ", got " + Values(static_cast<int>(a.shape(0))));
  }
  VectorXd v(size);
  for (int i = 0; i < size; ++i) v[i] = a.at(i);
  return v;
}

// A limit on the actuated joints: a number, m values, or n values (those of the actuated joints taken).
VectorXd Limit(const std::string& name, py::handle value, const std::vector<int>& actuated, int n) {
  const int m = static_cast<int>(actuated.size());
  const std::string expected = "a number, " + Values(m) + " (one per actuated joint)" +
                               (m == n ? std::string() : " or " + Values(n) + " (one per joint)");
  const py::array_t<double> a = Numbers(name, value, expected);
  VectorXd v(m);
  if (a.ndim() == 0) {
    v.setConstant(*a.data());
  } else if (a.shape(0) == m) {
    for (int j = 0; j < m; ++j) v[j] = a.at(j);
  } else if (a.shape(0) == n) {
    for (int j = 0; j < m; ++j) v[j] = a.at(actuated[static_cast<std::size_t>(j)]);
  } else {
    throw py::value_error(name + ": expected " + expected + ", got " + Values(static_cast<int>(a.shape(0))));
  }
  if (v.hasNaN()) throw py::value_error(name + ": expected numbers (inf allowed), got nan");
  return v;
}

// tau_limits: None (unbounded), a tuple (lower, upper), or a symmetric bound ±limit (each limit >= 0).
void ReadLimits(py::handle value, const std::vector<int>& actuated, int n, DdpConfig& c) {
  if (value.is_none()) return;
  if (py::isinstance<py::tuple>(value) && py::len(value) == 2) {
    const py::tuple pair = py::reinterpret_borrow<py::tuple>(value);
    c.tau_lower = Limit("tau_limits[0] (lower)", pair[0], actuated, n);
    c.tau_upper = Limit("tau_limits[1] (upper)", pair[1], actuated, n);
    for (Eigen::Index j = 0; j < c.tau_lower.size(); ++j) {
      if (!(c.tau_lower[j] <= c.tau_upper[j]) || (std::isinf(c.tau_lower[j]) && c.tau_lower[j] > 0) ||
          (std::isinf(c.tau_upper[j]) && c.tau_upper[j] < 0)) {
        throw py::value_error("tau_limits: expected lower <= upper (lower < inf, upper > -inf) on every actuated "
                              "joint, got [" + FormatDouble(c.tau_lower[j]) + ", " + FormatDouble(c.tau_upper[j]) +
                              "] on joint " + std::to_string(actuated[static_cast<std::size_t>(j)]));
      }
    }
    return;
  }
  const VectorXd limit = Limit("tau_limits", value, actuated, n);
  if ((limit.array() < 0.0).any()) {
    throw py::value_error("tau_limits: expected limits >= 0 (the bound ±limit), or a tuple (lower, upper)");
  }
  c.tau_upper = limit;
  c.tau_lower = -limit;
}

// actuated: None (the mpc scene key's default: a cart-pole's cart, else every joint) or joint indices.
std::vector<int> ReadActuated(py::handle value, int n, bool cart_pole) {
  MpcOptions o;
  if (!value.is_none()) {
    std::vector<int> joints;
    try {
      joints = value.cast<std::vector<int>>();
    } catch (const py::cast_error&) {
      throw py::value_error("actuated: expected a sequence of joint indices, got " +
                            std::string(py::str(py::type::handle_of(value).attr("__name__"))));
    }
    if (joints.empty()) throw py::value_error("actuated: expected at least one joint index");
    o.actuated = std::move(joints);
  }
  return MpcActuated(o, n, cart_pole);  // ranges: DdpModel's
}

// Weights and references from `cost` (a mapping: q, qd, tau, q_terminal, qd_terminal, q_ref, qd_ref).
constexpr const char* kCostKeys[] = {"q", "qd", "tau", "q_terminal", "qd_terminal", "q_ref", "qd_ref"};

struct CostArgs {
  py::object weight[5];       // q, qd, tau, q_terminal, qd_terminal (None: MpcWeights' default)
  py::object q_ref, qd_ref;   // None: zero
};

CostArgs ReadCost(py::handle cost) {
  CostArgs out;
  for (py::object& w : out.weight) w = py::none();
  out.q_ref = out.qd_ref = py::none();
  if (cost.is_none()) return out;
  const py::object mapping = py::module_::import("collections.abc").attr("Mapping");
  if (!py::isinstance<py::dict>(cost) && !py::isinstance(cost, mapping)) {
    throw py::value_error("cost: expected a dict of weights and references (q, qd, tau, q_terminal, qd_terminal, "
                          "q_ref, qd_ref), got " + std::string(py::str(py::type::handle_of(cost).attr("__name__"))));
  }
  for (const py::handle key : py::reinterpret_borrow<py::object>(cost)) {
    const std::string name = py::isinstance<py::str>(key) ? key.cast<std::string>() : std::string(py::repr(key));
    std::size_t i = 0;
    while (i < std::size(kCostKeys) && name != kCostKeys[i]) ++i;
    if (i == std::size(kCostKeys)) {
      throw py::value_error("cost: unknown key " + std::string(py::repr(key)) +
                            " (expected q, qd, tau, q_terminal, qd_terminal, q_ref, qd_ref)");
    }
    const py::object value = py::reinterpret_borrow<py::object>(cost)[key];
    if (i < 5) out.weight[i] = value;
    else (i == 5 ? out.q_ref : out.qd_ref) = value;
  }
  return out;
}

// A reference: None (zero), one state (n,) held over the horizon, or (N+1, n), one per knot.
void ReadReference(const char* name, const py::object& value, MatrixXd& ref) {
  if (value.is_none()) return;
  const int n = static_cast<int>(ref.rows()), knots = static_cast<int>(ref.cols());
  const JointArray a(name, value, n);
  std::vector<double> scratch(static_cast<std::size_t>(n));
  if (a.batched() && a.rows() != knots) {
    throw py::value_error(std::string(name) + ": expected (" + std::to_string(n) + ",) or (horizon + 1, " +
                          std::to_string(n) + ") = (" + std::to_string(knots) + ", " + std::to_string(n) +
                          "), one row per knot, got " + std::to_string(a.rows()) + " rows");
  }
  for (int k = 0; k < knots; ++k) ref.col(k) = Eigen::Map<const VectorXd>(a.Row(k, scratch), n);
}

// One state (n,) of a per-joint argument, or ValueError.
VectorXd State(const char* name, py::handle value, int n) {
  const JointArray a(name, value, n);
  if (a.batched()) {
    throw py::value_error(std::string(name) + ": expected one state (" + std::to_string(n) + ",), got a batch of " +
                          std::to_string(a.rows()));
  }
  std::vector<double> scratch(static_cast<std::size_t>(n));
  return Eigen::Map<const VectorXd>(a.Row(0, scratch), n);
}

// DdpModel's refusal "ddp: FIELD: expected ..." in the call's words: weights.X is cost['X'], options.X is X.
std::string CallWords(std::string message) {
  const auto replace_prefix = [&message](const std::string& from, const std::string& to) {
    if (message.rfind(from, 0) != 0) return false;
    message.replace(0, from.size(), to);
    return true;
  };
  replace_prefix("ddp: ", "");
  for (const char* key : {"q_terminal", "qd_terminal", "qd", "q", "tau"}) {
    if (replace_prefix(std::string("weights.") + key + ":", std::string("cost['") + key + "']:")) break;
  }
  replace_prefix("options.", "");
  replace_prefix("tau_lower, tau_upper:", "tau_limits:");
  return message;
}

// How often a solve's caller looks for a pending signal (Ctrl-C).
constexpr std::chrono::milliseconds kSignalCheck{50};

// SolveDdp without the GIL on a thread of its own while the calling thread looks for a pending signal every
// kSignalCheck: one (KeyboardInterrupt) stops the solve within a knot of its passes (DdpData::stop) and is raised.
void Solve(const DdpModel& problem, DdpData& data, const VectorXd& q0, const VectorXd& qd0) {
  std::atomic<bool> stop{false};
  data.stop = &stop;
  std::future<void> solve = std::async(std::launch::async, [&] { SolveDdp(problem, data, q0, qd0); });
  for (;;) {
    std::future_status status;
    {
      py::gil_scoped_release release;
      status = solve.wait_for(kSignalCheck);
    }
    if (status == std::future_status::ready) break;
    if (PyErr_CheckSignals() != 0) {
      stop = true;
      solve.wait();
      throw py::error_already_set();
    }
  }
  solve.get();
}

py::array_t<double> Array(std::initializer_list<py::ssize_t> dims) {
  return NewArray(static_cast<int>(dims.size()), std::data(dims));
}

TrajectoryResult Optimize(py::handle model_arg, py::handle q0_arg, py::handle qd0_arg, int horizon, double dt,
                          py::handle cost_arg, py::handle limits_arg, const std::string& integrator,
                          py::handle actuated_arg, int max_iterations, double tolerance) {
  const std::shared_ptr<const Dynamics> dynamics = ModelDynamics(model_arg);
  const int n = dynamics->num_dofs();
  const VectorXd q0 = State("q0", q0_arg, n), qd0 = State("qd0", qd0_arg, n);
  DdpConfig c;
  c.integrator = StepIntegrator(integrator);
  c.horizon = horizon;
  c.dt = dt;
  c.actuated = ReadActuated(actuated_arg, n, ModelPlantType(model_arg) == PlantType::kCartPole);
  const int m = static_cast<int>(c.actuated.size());
  ReadLimits(limits_arg, c.actuated, n, c);
  const CostArgs cost = ReadCost(cost_arg);
  MpcOptions weights;  // given weights; MpcWeights fills in the mpc scene key's defaults
  VectorXd* slots[] = {&weights.q, &weights.qd, &weights.tau, &weights.q_terminal, &weights.qd_terminal};
  for (int i = 0; i < 5; ++i) {
    if (cost.weight[i].is_none()) continue;
    *slots[i] = PerEntry(std::string("cost['") + kCostKeys[i] + "']", cost.weight[i], i == 2 ? m : n,
                         i == 2 ? "actuated joint" : "joint");
  }
  c.weights = MpcWeights(weights, n, m);
  c.options.max_iterations = max_iterations;
  c.options.tolerance = tolerance;
  std::unique_ptr<DdpModel> problem;
  try {
    problem = std::make_unique<DdpModel>(dynamics, std::move(c));
  } catch (const std::invalid_argument& e) {
    throw py::value_error(CallWords(e.what()));
  }
  DdpData data(*problem);
  ReadReference("cost['q_ref']", cost.q_ref, data.q_ref);
  ReadReference("cost['qd_ref']", cost.qd_ref, data.qd_ref);
  Solve(*problem, data, q0, qd0);
  const DdpResult& r = data.result();
  if (r.status == DdpStatus::kDiverged) {
    throw std::runtime_error("optimize_trajectory: diverged: the first rollout (tau = 0 from q0, qd0) left the "
                             "finite numbers; a smaller dt or a more accurate integrator may keep it finite");
  }
  TrajectoryResult out;
  const int N = horizon;
  out.t = Array({N + 1});
  out.q = Array({N + 1, n});
  out.qd = Array({N + 1, n});
  out.tau = Array({N, n});
  out.K = Array({N, m, 2 * n});
  out.cost_history = Array({r.iterations + 1});
  for (int k = 0; k <= N; ++k) {
    out.t.mutable_at(k) = k * dt;
    for (int i = 0; i < n; ++i) {
      out.q.mutable_at(k, i) = data.x()(i, k);
      out.qd.mutable_at(k, i) = data.x()(n + i, k);
    }
  }
  std::fill_n(out.tau.mutable_data(), static_cast<std::size_t>(N) * n, 0.0);
  for (int k = 0; k < N; ++k) {
    for (int j = 0; j < m; ++j) {
      out.tau.mutable_at(k, problem->actuated()[static_cast<std::size_t>(j)]) = data.u()(j, k);
    }
    CopyRowMajor(data.K(k), out.K.mutable_data(k));
  }
  std::copy_n(r.cost_history.data(), r.iterations + 1, out.cost_history.mutable_data());
  out.actuated = problem->actuated();
  out.status = std::string(ToString(r.status));
  out.iterations = r.iterations;
  out.cost = r.cost;
  out.expected_decrease = r.expected_decrease;
  out.regularization = r.regularization;
  return out;
}

constexpr const char* kOptimizeDoc =
    R"((model, q0, qd0, horizon, dt, cost=None, tau_limits=None, integrator="rk4", actuated=None,
max_iterations=50, tolerance=1e-8) => TrajectoryResult: an optimal trajectory from (q0, qd0)

Offline trajectory optimisation by the solver lagranged's mpc controller plans
with: box-constrained DDP (iLQR with control limits; Tassa, Mansard & Todorov,
ICRA 2014) on the model's exact step derivatives, from tau = 0, once:

  minimise  Σ_{k<N} ½|q_k − q_ref,k|²_Wq + ½|qd_k − qd_ref,k|²_Wqd + ½|u_k|²_Wtau
            + ½|q_N − q_ref,N|²_WqN + ½|qd_N − qd_ref,N|²_WqdN
  s.t.      x_{k+1} = Φ(x_k, S u_k) (one integrator step of dt, tau held), lower <= u_k <= upper

model       a lagrange.Model (its dynamics alone: gravity and Coriolis, no scene effects)
q0, qd0     (n,) rad or m, rad/s or m/s: x_0
horizon     N knots, 1..100000
dt          s per knot, > 0
cost        a dict, every key optional: weights q, qd, q_terminal, qd_terminal (a number or
            n values >= 0), tau (a number or m values > 0), defaults the mpc scene key's
            (1, 0.01, 100, 1, 0.01); references q_ref, qd_ref: (n,) held, or (N+1, n) per
            knot (default 0)
tau_limits  None (unbounded), a symmetric bound (a number, m or n values >= 0: ±limit),
            or a tuple (lower, upper) of those (inf allowed); on the actuated joints
integrator  "explicit-euler", "semi-implicit-euler" or "rk4"
actuated    the joints that take a force, ascending (m of them); None: the mpc scene
            key's default, a cart-pole's cart, else every joint
max_iterations, tolerance: DdpOptions' (1..10000; converged when the expected
            decrease <= tolerance · J)

The result's tau (N, n) is S u_k (0 on the joints not actuated), its K (N, m, 2n)
the feedback of u_k = clamp(u_k + K_k (x − x_k)) about the plan's x_k = (q_k, qd_k).
The cost never increases from one iteration to the next (cost_history) and no
u_k is outside the limits. Runs without the GIL; Ctrl-C (KeyboardInterrupt) stops
it within a knot of its passes. ValueError naming the argument
and what was expected for a bad one; RuntimeError when the first rollout (tau = 0)
is not finite.)";

}  // namespace

void BindTrajectory(py::module_& m) {
  py::class_<TrajectoryResult>(m, "TrajectoryResult",
                               "An optimised trajectory of N knots (optimize_trajectory): the plan, its affine "
                               "policy and the solver's record.")
      .def_readonly("t", &TrajectoryResult::t, "Knot times from the start, s, shape (N+1,): k dt.")
      .def_readonly("q", &TrajectoryResult::q, "Planned positions q_k, rad or m, shape (N+1, n); q[0] = q0.")
      .def_readonly("qd", &TrajectoryResult::qd, "Planned velocities qd_k, rad/s or m/s, shape (N+1, n).")
      .def_readonly("tau", &TrajectoryResult::tau,
                    "Planned forces S u_k held over [t_k, t_k+1), N·m or N, shape (N, n); 0 on joints not actuated.")
      .def_readonly("K", &TrajectoryResult::K,
                    "Feedback gains, shape (N, m, 2n): u = clamp(u_k + K_k (x − x_k)), x = (q, qd); 0 rows where "
                    "a limit is active.")
      .def_readonly("actuated", &TrajectoryResult::actuated, "The actuated joints (m), the rows of K.")
      .def_readonly("status", &TrajectoryResult::status,
                    "converged, max-iterations, line-search-failed or not-positive-definite (controllers/ddp.hpp).")
      .def_readonly("iterations", &TrajectoryResult::iterations, "Backward passes followed by a line search.")
      .def_readonly("cost", &TrajectoryResult::cost, "J of the returned trajectory.")
      .def_readonly("cost_history", &TrajectoryResult::cost_history,
                    "J before the first iteration (the tau = 0 rollout), then after each: shape (iterations + 1,), "
                    "never increasing.")
      .def_readonly("expected_decrease", &TrajectoryResult::expected_decrease,
                    "The last backward pass's predicted decrease ΔJ(1).")
      .def_readonly("regularization", &TrajectoryResult::regularization, "μ at the end.")
      .def_property_readonly(
          "converged", [](const TrajectoryResult& r) { return r.status == "converged"; },
          "status == 'converged': the expected decrease fell to tolerance · J.")
      .def("__repr__", [](const TrajectoryResult& r) {
        return "<TrajectoryResult " + r.status + ": " + std::to_string(r.iterations) + " iterations, cost " +
               FormatDouble(r.cost) + ", " + std::to_string(r.q.shape(0) - 1) + " knots>";
      });
  m.def("optimize_trajectory", &Optimize, kOptimizeDoc, py::arg("model"), py::arg("q0"), py::arg("qd0"),
        py::arg("horizon"), py::arg("dt"), py::kw_only(), py::arg("cost") = py::none(),
        py::arg("tau_limits") = py::none(), py::arg("integrator") = "rk4", py::arg("actuated") = py::none(),
        py::arg("max_iterations") = DdpOptions{}.max_iterations, py::arg("tolerance") = DdpOptions{}.tolerance);
}

}  // namespace lagrange::python
