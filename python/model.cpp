#include "python/bindings.hpp"

namespace lagrange::python {

void BindModel(pybind11::module_& /*m*/) {}

}  // namespace lagrange::python
