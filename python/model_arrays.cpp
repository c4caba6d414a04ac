#include "python/model_arrays.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace lagrange::python {
namespace py = pybind11;

namespace {

std::string Shape(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) text += (d ? ", " : "") + std::to_string(a.shape(d));
  return text + (a.ndim() == 1 ? ",)" : ")");
}

std::string Values(int n) { return std::to_string(n) + (n == 1 ? " value" : " values"); }

}  // namespace

JointArray::JointArray(const char* name, py::handle value, int n) : name_(name), n_(n) {
  // (messages only: nothing is formatted on the good path)
  const auto shapes = [n] { return "(" + std::to_string(n) + ",) or (N, " + std::to_string(n) + ")"; };
  // np.asarray(None, float) is a 0-d nan: say what it was instead.
  if (value.is_none()) throw py::value_error(std::string(name) + ": expected an array of shape " + shapes() + ", got None");
  // A float64 array is read where it is; anything else is converted (np.asarray(value, float64)).
  using Array = py::array_t<double, py::array::forcecast>;
  array_ = Array::check_(value) ? py::reinterpret_borrow<Array>(value) : Array::ensure(value);
  if (!array_) {
    PyErr_Clear();
    throw py::value_error(std::string(name) + ": expected numbers, an array of shape " + shapes() + ", got " +
                          std::string(py::str(py::type::handle_of(value).attr("__name__"))));
  }
  const py::ssize_t ndim = array_.ndim();
  if (ndim == 0 && n == 1) {  // a pendulum's angle as a plain number
    data_ = reinterpret_cast<const char*>(array_.data());
  } else if (ndim == 1) {
    if (array_.shape(0) != n) {
      throw py::value_error(std::string(name) + ": expected " + Values(n) + " (one per joint), got " +
                            std::to_string(array_.shape(0)));
    }
    data_ = reinterpret_cast<const char*>(array_.data());
    col_stride_ = array_.strides(0);
  } else if (ndim == 2) {
    if (array_.shape(1) != n) {
      throw py::value_error(std::string(name) + ": expected shape (N, " + std::to_string(n) + "), one row of " +
                            Values(n) + " per state, got " + Shape(array_));
    }
    rows_ = array_.shape(0);
    data_ = reinterpret_cast<const char*>(array_.data());
    row_stride_ = array_.strides(0);
    col_stride_ = array_.strides(1);
  } else {
    throw py::value_error(std::string(name) + ": expected an array of shape " + shapes() + ", got shape " +
                          Shape(array_));
  }
  const py::ssize_t rows = rows_ < 0 ? 1 : rows_;
  for (py::ssize_t i = 0; i < rows; ++i) {
    for (int j = 0; j < n; ++j) {
      double x;
      std::memcpy(&x, data_ + i * row_stride_ + j * col_stride_, sizeof x);
      if (std::isfinite(x)) continue;
      const std::string where = rows_ < 0 ? "[" + std::to_string(j) + "]"
                                          : "[" + std::to_string(i) + ", " + std::to_string(j) + "]";
      throw py::value_error(std::string(name) + ": expected finite numbers, got " +
                            (std::isnan(x) ? "nan" : x > 0 ? "inf" : "-inf") + " at " + name + where);
    }
  }
}

const double* JointArray::Row(py::ssize_t i, std::vector<double>& scratch) const {
  const char* row = data_ + (rows_ < 0 ? 0 : i * row_stride_);
  if (col_stride_ == static_cast<py::ssize_t>(sizeof(double)) || n_ == 1) {
    // numpy aligns float64 data it allocates; a view into a byte buffer may not be, so copy those.
    if (reinterpret_cast<std::uintptr_t>(row) % alignof(double) == 0) return reinterpret_cast<const double*>(row);
  }
  for (int j = 0; j < n_; ++j) std::memcpy(&scratch[static_cast<std::size_t>(j)], row + j * col_stride_, sizeof(double));
  return scratch.data();
}

py::ssize_t BatchRows(std::initializer_list<const JointArray*> args) {
  const JointArray* first = nullptr;
  for (const JointArray* a : args) {
    if (!a->batched()) continue;
    if (!first) {
      first = a;
    } else if (a->rows() != first->rows()) {
      throw py::value_error(std::string(a->name()) + ": expected " + std::to_string(first->rows()) + " rows (as " +
                            first->name() + "), got " + std::to_string(a->rows()));
    }
  }
  return first ? first->rows() : -1;
}

// numpy's constructor through pybind11's table of it: py::array_t(shape) would first copy the shape into a vector.
py::array_t<double> NewArray(int ndim, const py::ssize_t* dims) {
  const auto& api = py::detail::npy_api::get();
  PyObject* descr = api.PyArray_DescrFromType_(py::detail::npy_api::NPY_DOUBLE_);
  if (!descr) throw py::error_already_set();
  PyObject* array = api.PyArray_NewFromDescr_(api.PyArray_Type_, descr, ndim, dims, nullptr, nullptr, 0, nullptr);
  if (!array) throw py::error_already_set();
  return py::reinterpret_steal<py::array_t<double>>(array);
}

}  // namespace lagrange::python
