#include "python/model_arrays.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace lagrange::python {
namespace py = pybind11;

namespace {

std::string Values(int n) { return std::to_string(n) + (n == 1 ? " value" : " values"); }

}  // namespace

// A float64 numpy array in this machine's byte order, read from numpy's own
// struct (pybind11's mirror of it): the check py::array_t::check_ makes, without
// building a dtype to compare with, which took about half of a one-state call.
bool IsNativeFloat64(PyObject* object) {
  const auto& api = py::detail::npy_api::get();
  if (!api.PyArray_Check_(object)) return false;
  const auto* descr = py::detail::array_descriptor_proxy(py::detail::array_proxy(object)->descr);
  return descr->type_num == py::detail::npy_api::NPY_DOUBLE_ && descr->byteorder != '>';
}

const double* ContiguousFiniteVector(PyObject* array, py::ssize_t n) {
  if (!IsNativeFloat64(array)) return nullptr;
  const auto* a = py::detail::array_proxy(array);
  if (a->nd != 1 || a->dimensions[0] != n || (n > 1 && a->strides[0] != static_cast<py::ssize_t>(sizeof(double))) ||
      !(a->flags & py::detail::npy_api::NPY_ARRAY_ALIGNED_)) {
    return nullptr;
  }
  const auto* data = reinterpret_cast<const double*>(a->data);
  return Eigen::Map<const Eigen::ArrayXd>(data, n).allFinite() ? data : nullptr;
}

double* ResultArrayData(PyObject* out, int ndim, const py::ssize_t* dims) {
  if (!IsNativeFloat64(out)) return nullptr;
  const auto* a = py::detail::array_proxy(out);
  constexpr int kFlags = py::detail::npy_api::NPY_ARRAY_C_CONTIGUOUS_ | py::detail::npy_api::NPY_ARRAY_ALIGNED_ |
                         py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  if ((a->flags & kFlags) != kFlags || a->nd != ndim) return nullptr;
  for (int d = 0; d < ndim; ++d) {
    if (a->dimensions[d] != dims[d]) return nullptr;
  }
  return reinterpret_cast<double*>(a->data);
}

JointArray::JointArray(const char* name, py::handle value, int n, const char* per) : name_(name), n_(n) {
  // (messages only: nothing is formatted on the good path)
  const auto shapes = [n] { return "(" + std::to_string(n) + ",) or (N, " + std::to_string(n) + ")"; };
  // np.asarray(None, float) is a 0-d nan: say what it was instead.
  if (value.is_none())
    throw py::value_error(std::string(name) + ": expected an array of shape " + shapes() + ", got None");
  // A float64 array is read where it is; anything else is converted (np.asarray(value, float64)).
  if (IsNativeFloat64(value.ptr())) {
    array_ = py::reinterpret_borrow<py::object>(value);
  } else {
    array_ = py::array_t<double, py::array::forcecast>::ensure(value);
    if (!array_) {
      PyErr_Clear();
      throw py::value_error(std::string(name) + ": expected numbers, an array of shape " + shapes() + ", got " +
                            std::string(py::str(py::type::handle_of(value).attr("__name__"))));
    }
  }
  const auto* a = py::detail::array_proxy(array_.ptr());
  const auto shape = [a] {
    std::string text = "(";
    for (int d = 0; d < a->nd; ++d) text += (d ? ", " : "") + std::to_string(a->dimensions[d]);
    return text + (a->nd == 1 ? ",)" : ")");
  };
  data_ = a->data;
  if (a->nd == 0 && n == 1) {  // a pendulum's angle as a plain number
  } else if (a->nd == 1) {
    if (a->dimensions[0] != n) {
      throw py::value_error(std::string(name) + ": expected " + Values(n) + " (" + per + "), got " +
                            std::to_string(a->dimensions[0]));
    }
    col_stride_ = a->strides[0];
  } else if (a->nd == 2) {
    if (a->dimensions[1] != n) {
      throw py::value_error(std::string(name) + ": expected shape (N, " + std::to_string(n) + "), one row of " +
                            Values(n) + " per state, got " + shape());
    }
    rows_ = a->dimensions[0];
    row_stride_ = a->strides[0];
    col_stride_ = a->strides[1];
  } else {
    throw py::value_error(std::string(name) + ": expected an array of shape " + shapes() + ", got shape " + shape());
  }
  // Rows read in place: every row's values adjacent and aligned (numpy aligns the float64 data it allocates; a
  // view into a byte buffer may not be, and a strided view's are apart): those are copied row by row instead.
  const auto aligned = [](py::ssize_t bytes) { return bytes % static_cast<py::ssize_t>(alignof(double)) == 0; };
  in_place_ = (col_stride_ == static_cast<py::ssize_t>(sizeof(double)) || n == 1) &&
              aligned(reinterpret_cast<std::uintptr_t>(data_)) && aligned(row_stride_);
  const py::ssize_t rows = rows_ < 0 ? 1 : rows_;
  // Finite: one vectorised pass over a contiguous block (the common case), else element by element.
  if (in_place_ && row_stride_ == n * static_cast<py::ssize_t>(sizeof(double)) &&
      Eigen::Map<const Eigen::ArrayXd>(reinterpret_cast<const double*>(data_), rows * n).allFinite()) {
    return;
  }
  for (py::ssize_t i = 0; i < rows; ++i) {
    for (int j = 0; j < n; ++j) {
      double x;
      std::memcpy(&x, data_ + i * row_stride_ + j * col_stride_, sizeof x);
      if (std::isfinite(x)) continue;
      const std::string where =
          rows_ < 0 ? "[" + std::to_string(j) + "]" : "[" + std::to_string(i) + ", " + std::to_string(j) + "]";
      throw py::value_error(std::string(name) + ": expected finite numbers, got " +
                            (std::isnan(x) ? "nan"
                             : x > 0       ? "inf"
                                           : "-inf") +
                            " at " + name + where);
    }
  }
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
