// The native module behind `import lagrange` (python/lagrange/__init__.py).
#include "python/bindings.hpp"

PYBIND11_MODULE(_lagrange, m) {
  m.doc() = "lagrange: rigid-body dynamics, the simulator and the lagranged bus (native part).";
  m.attr("python_executable") = LAGRANGE_PYTHON_EXECUTABLE;
  m.attr("python_version") = LAGRANGE_PYTHON_VERSION;
  lagrange::python::BindModel(m);
  lagrange::python::BindDerivatives(m);
  lagrange::python::BindTrajectory(m);
  lagrange::python::BindSimulate(m);
  lagrange::python::BindBus(m);
}
