#include "python/bindings.hpp"

namespace lagrange::python {

void BindBus(pybind11::module_& /*m*/) {}

}  // namespace lagrange::python
