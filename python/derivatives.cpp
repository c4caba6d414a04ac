// lagrange.Model's derivative calls: the exact first derivatives of forward
// and inverse dynamics (plant/dynamics.hpp) and of one integrator step
// (StepDerivatives, plant/integrators.hpp), registered on the Model class that
// model.cpp binds. Arrays in and out as every Model call: one state (n,), or
// a batch (N, n) giving a leading axis N, run without the GIL over `threads`
// threads, each with data of its own (the model is shared, read-only).

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/escape.hpp"
#include "plant/dynamics.hpp"
#include "plant/integrators.hpp"
#include "plant/plant_model.hpp"
#include "protocol/format.hpp"
#include "python/bindings.hpp"
#include "python/model_arrays.hpp"

namespace lagrange::python {

// What help() says the calls return: a tuple of three arrays, or of two.
struct ArrayTriple {
  pybind11::object value;
};
struct ArrayPair {
  pybind11::object value;
};

}  // namespace lagrange::python

namespace pybind11::detail {

template <>
struct type_caster<lagrange::python::ArrayTriple> : named_result_caster<lagrange::python::ArrayTriple> {
  PYBIND11_TYPE_CASTER(lagrange::python::ArrayTriple,
                       const_name("tuple[numpy.ndarray[numpy.float64], numpy.ndarray[numpy.float64], "
                                  "numpy.ndarray[numpy.float64]]"));
  using named_result_caster<lagrange::python::ArrayTriple>::cast;
  using named_result_caster<lagrange::python::ArrayTriple>::load;
};
template <>
struct type_caster<lagrange::python::ArrayPair> : named_result_caster<lagrange::python::ArrayPair> {
  PYBIND11_TYPE_CASTER(lagrange::python::ArrayPair,
                       const_name("tuple[numpy.ndarray[numpy.float64], numpy.ndarray[numpy.float64]]"));
  using named_result_caster<lagrange::python::ArrayPair>::cast;
  using named_result_caster<lagrange::python::ArrayPair>::load;
};

}  // namespace pybind11::detail

namespace lagrange::python {
namespace py = pybind11;
namespace {

constexpr int kMaxThreads = 1024;  // as model.cpp's calls
using VecMap = Eigen::Map<const VectorXd>;
using Rows = std::array<const double*, 3>;

// One thread's data: the model's data and every buffer a call writes; a plant
// (the bare dynamics, gravity and Coriolis on) and the step's derivatives
// when the call integrates.
struct Worker {
  Worker(const std::shared_ptr<const Dynamics>& dynamics, std::optional<IntegratorType> integrator)
      : data(dynamics->MakeData()), qdd(dynamics->num_dofs()) {
    const int n = dynamics->num_dofs();
    for (MatrixXd& m : matrices) m.resize(n, n);
    for (auto& s : scratch) s.resize(static_cast<std::size_t>(n));
    if (integrator) {
      plant.emplace(dynamics, EffectsConfig{});
      step.emplace(*integrator, n);
      A.resize(2 * n, 2 * n);
      B.resize(2 * n, n);
    }
  }
  std::unique_ptr<DynamicsData> data;
  VectorXd qdd;
  std::array<MatrixXd, 3> matrices;  // (n x n) results before they are laid out row-major
  std::array<std::vector<double>, 3> scratch;  // rows of strided arguments
  std::optional<PlantModel> plant;
  std::optional<StepDerivatives> step;
  MatrixXd A, B;  // (2n x 2n), (2n x n)
};

struct Shape {
  py::ssize_t rows, cols;
};

// kernel(worker, rows, outputs) computes one state's outputs (row-major
// matrices of `shapes`) from its argument rows and says whether they are
// finite. One state: a tuple of arrays; a batch: each with a leading axis N,
// computed without the GIL over `threads` threads.
template <std::size_t kOuts, class Kernel>
py::tuple Evaluate(const std::shared_ptr<const Dynamics>& dynamics, std::optional<IntegratorType> integrator,
                   const std::array<const JointArray*, 3>& args, const std::array<Shape, kOuts>& shapes, int threads,
                   Kernel kernel) {
  if (threads < 1 || threads > kMaxThreads) {
    throw py::value_error("threads: expected 1.." + std::to_string(kMaxThreads) + ", got " + std::to_string(threads));
  }
  const py::ssize_t rows = BatchRows({args[0], args[1], args[2]});
  std::array<py::array_t<double>, kOuts> arrays;
  std::array<double*, kOuts> outputs{};
  for (std::size_t o = 0; o < kOuts; ++o) {
    const std::array<py::ssize_t, 3> dims = rows < 0 ? std::array<py::ssize_t, 3>{shapes[o].rows, shapes[o].cols, 0}
                                                     : std::array<py::ssize_t, 3>{rows, shapes[o].rows, shapes[o].cols};
    arrays[o] = NewArray(rows < 0 ? 2 : 3, dims.data());
    outputs[o] = arrays[o].mutable_data();
  }
  // Rows [begin, end) with one worker; returns the first state whose outputs are not finite, or end.
  auto run = [&](py::ssize_t begin, py::ssize_t end) {
    Worker worker(dynamics, integrator);
    Rows row;
    std::array<double*, kOuts> out;
    for (py::ssize_t i = begin; i < end; ++i) {
      for (std::size_t a = 0; a < 3; ++a) row[a] = args[a]->Row(i, worker.scratch[a]);
      for (std::size_t o = 0; o < kOuts; ++o) out[o] = outputs[o] + (rows < 0 ? 0 : i * shapes[o].rows * shapes[o].cols);
      if (!kernel(worker, row, out)) return i;
    }
    return end;
  };
  if (rows < 0) {
    if (run(0, 1) != 1) throw std::runtime_error("the derivatives are not finite at this state");
  } else {
    const py::ssize_t first = RunBatch(rows, threads, run);
    if (first < rows) throw std::runtime_error("the derivatives are not finite at state " + std::to_string(first));
  }
  py::tuple result(kOuts);
  for (std::size_t o = 0; o < kOuts; ++o) result[o] = std::move(arrays[o]);
  return result;
}

constexpr const char* kForwardDoc =
    R"((q, qd, tau) => (dqdd_dq, dqdd_dqd, dqdd_dtau): the exact derivatives of forward dynamics
qdd = M⁻¹ (tau − C qd − G), element [i, j] = ∂qdd_i/∂x_j; dqdd_dtau = M⁻¹.

By the model's own method (recursive: analytic sweeps; lagrangian: nested dual
numbers of T and V; closed-form: by hand), through the identity
∂qdd/∂(q, qd) = −M⁻¹ ∂tau/∂(q, qd) at qdd (Carpentier and Mansard, RSS 2018).

q        (n,) | (N, n)   rad or m
qd       (n,) | (N, n)   rad/s or m/s
tau      (n,) | (N, n)   N·m or N
returns  three (n, n) | (N, n, n): 1/s² (per rad or m), 1/s, and per (kg·m² or kg))";

constexpr const char* kInverseDoc =
    R"((q, qd, qdd) => (dtau_dq, dtau_dqd, dtau_dqdd): the exact derivatives of inverse dynamics
tau = M qdd + C qd + G, element [i, j] = ∂tau_i/∂x_j; dtau_dqdd = M.

q        (n,) | (N, n)   rad or m
qd       (n,) | (N, n)   rad/s or m/s
qdd      (n,) | (N, n)   rad/s² or m/s²
returns  three (n, n) | (N, n, n): N·m per rad (or N per m, ...), N·m·s per rad, kg·m² (or kg))";

constexpr const char* kStepDoc =
    R"((q, qd, tau, dt, integrator="rk4") => (A, B): the exact derivatives of one integrator step
x⁺ = Φ(x, tau, dt), x = (q, qd) stacked (2n), tau held over the step:
A = ∂x⁺/∂x (2n, 2n), B = ∂x⁺/∂tau (2n, n), by the chain rule through the
integrator's stages (not by differencing the step). The plant is this model
alone: gravity and Coriolis, no scene effects (lagrange.simulate runs those).

q, qd, tau  (n,) | (N, n)   rad or m, rad/s or m/s, N·m or N
dt          s, > 0: the step
integrator  "explicit-euler", "semi-implicit-euler" or "rk4" (the others, adaptive
            or implicit, have none: ValueError naming these three)
returns     A (2n, 2n) | (N, 2n, 2n), B (2n, n) | (N, 2n, n))";

}  // namespace

IntegratorType StepIntegrator(const std::string& name) {
  const std::optional<IntegratorType> type = ParseIntegratorType(name);
  if (!type) {
    throw py::value_error("integrator: expected explicit-euler, semi-implicit-euler or rk4, got '" +
                          Escape(name, 64) + "'");
  }
  if (const char* reason = NoStepDerivativesReason(*type)) throw py::value_error(std::string("integrator: ") + reason);
  return *type;
}

void BindDerivatives(py::module_& m) {
  py::object model = m.attr("Model");
  const auto def = [&model](const char* name, auto&& f, const std::string& doc, auto... extra) {
    model.attr(name) = py::cpp_function(std::forward<decltype(f)>(f), py::name(name), py::is_method(model),
                                        py::sibling(py::getattr(model, name, py::none())), doc.c_str(), extra...);
  };

  def(
      "forward_dynamics_derivatives",
      [](py::handle self, ArrayArg q, ArrayArg qd, ArrayArg tau, int threads) {
        const std::shared_ptr<const Dynamics> dynamics = ModelDynamics(self);
        const int n = dynamics->num_dofs();
        const JointArray aq("q", q.value, n), aqd("qd", qd.value, n), atau("tau", tau.value, n);
        return ArrayTriple{Evaluate<3>(
            dynamics, std::nullopt, {&aq, &aqd, &atau}, {Shape{n, n}, Shape{n, n}, Shape{n, n}}, threads,
            [&](Worker& w, const Rows& r, const std::array<double*, 3>& out) {
              auto& [dq, dqd, dtau] = w.matrices;
              dynamics->ComputeForwardDynamicsDerivatives(*w.data, VecMap(r[0], n), VecMap(r[1], n), VecMap(r[2], n),
                                                          DynamicsTerms{}, w.qdd, dq, dqd, dtau);
              for (std::size_t o = 0; o < 3; ++o) CopyRowMajor(w.matrices[o], out[o]);
              return dq.allFinite() && dqd.allFinite() && dtau.allFinite();
            })};
      },
      BatchDoc(kForwardDoc), py::arg("q"), py::arg("qd"), py::arg("tau"), py::kw_only(), py::arg("threads") = 1);

  def(
      "inverse_dynamics_derivatives",
      [](py::handle self, ArrayArg q, ArrayArg qd, ArrayArg qdd, int threads) {
        const std::shared_ptr<const Dynamics> dynamics = ModelDynamics(self);
        const int n = dynamics->num_dofs();
        const JointArray aq("q", q.value, n), aqd("qd", qd.value, n), aqdd("qdd", qdd.value, n);
        return ArrayTriple{Evaluate<3>(
            dynamics, std::nullopt, {&aq, &aqd, &aqdd}, {Shape{n, n}, Shape{n, n}, Shape{n, n}}, threads,
            [&](Worker& w, const Rows& r, const std::array<double*, 3>& out) {
              auto& [dq, dqd, M] = w.matrices;
              dynamics->ComputeInverseDynamicsDerivatives(*w.data, VecMap(r[0], n), VecMap(r[1], n), VecMap(r[2], n),
                                                          DynamicsTerms{}, dq, dqd, M);
              for (std::size_t o = 0; o < 3; ++o) CopyRowMajor(w.matrices[o], out[o]);
              return dq.allFinite() && dqd.allFinite() && M.allFinite();
            })};
      },
      BatchDoc(kInverseDoc), py::arg("q"), py::arg("qd"), py::arg("qdd"), py::kw_only(), py::arg("threads") = 1);

  def(
      "step_derivatives",
      [](py::handle self, ArrayArg q, ArrayArg qd, ArrayArg tau, double dt, const std::string& integrator,
         int threads) {
        const std::shared_ptr<const Dynamics> dynamics = ModelDynamics(self);
        const int n = dynamics->num_dofs();
        const IntegratorType type = StepIntegrator(integrator);
        if (!(std::isfinite(dt) && dt > 0.0)) {
          throw py::value_error("dt: expected a positive number of seconds, got " + FormatDouble(dt));
        }
        const JointArray aq("q", q.value, n), aqd("qd", qd.value, n), atau("tau", tau.value, n);
        return ArrayPair{Evaluate<2>(dynamics, type, {&aq, &aqd, &atau}, {Shape{2 * n, 2 * n}, Shape{2 * n, n}},
                                       threads, [&](Worker& w, const Rows& r, const std::array<double*, 2>& out) {
                                         w.step->Step(*w.plant, 0.0, dt, VecMap(r[0], n), VecMap(r[1], n),
                                                      VecMap(r[2], n), w.A, w.B);
                                         CopyRowMajor(w.A, out[0]);
                                         CopyRowMajor(w.B, out[1]);
                                         return w.A.allFinite() && w.B.allFinite();
                                       })};
      },
      BatchDoc(kStepDoc), py::arg("q"), py::arg("qd"), py::arg("tau"), py::arg("dt"), py::arg("integrator") = "rk4",
      py::kw_only(), py::arg("threads") = 1);
}

}  // namespace lagrange::python
