#include "python/bindings.hpp"

namespace lagrange::python {

void BindSimulate(pybind11::module_& /*m*/) {}

}  // namespace lagrange::python
