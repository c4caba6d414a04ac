#pragma once
// numpy arrays at lagrange.Model's boundary: per-joint arguments of one state
// (n,) or a batch (N, n), any layout and any real dtype, checked (shape,
// finite) with messages in lagrangectl's words, and read row by row without
// the GIL. Nothing here calls Python once the GIL is released: an argument
// keeps its numpy array alive and is read through its pointer and strides.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <exception>
#include <initializer_list>
#include <string>
#include <thread>
#include <vector>

namespace lagrange::python {

// Whether `object` is a float64 numpy array in this machine's byte order.
bool IsNativeFloat64(PyObject* object);

// `array`'s n values when it is what a C++ call reads in place: a float64
// numpy array of shape (n,), contiguous, aligned, every value finite; else
// null (the caller then takes the general path, JointArray, whose checks
// name what is wrong).
const double* ContiguousFiniteVector(PyObject* array, pybind11::ssize_t n);

// `out`'s data when it can take a result of shape dims[0 .. ndim) in place: a
// writeable, aligned, C-contiguous float64 numpy array of exactly that shape;
// else null.
double* ResultArrayData(PyObject* out, int ndim, const pybind11::ssize_t* dims);

// One per-joint argument (q, qd, qdd or tau): a float64 view of what the caller
// passed (converted only when it was not float64 already: a list, ints,
// float32), with its shape. `rows` is -1 for a single state (n,), else N.
class JointArray {
 public:
  // Checks `value` as argument `name` of a plant with n degrees of freedom:
  // a number array of shape (n,) or (N, n), every element finite. Throws
  // pybind11::value_error with one line: "q: expected 2 values (one per joint), got 3";
  // `per` replaces "one per joint" (a floating base's q: "nq: p, quaternion x y z w, joints").
  JointArray(const char* name, pybind11::handle value, int n, const char* per = "one per joint");

  const char* name() const { return name_; }
  bool batched() const { return rows_ >= 0; }
  pybind11::ssize_t rows() const { return rows_; }
  // Row i's values: contiguous in the caller's array (no copy), or copied into
  // `scratch` (n) when the array is strided along the joints. A single state's
  // row is the same for every i (it is broadcast against a batch).
  const double* Row(pybind11::ssize_t i, std::vector<double>& scratch) const {
    const char* row = data_ + (rows_ < 0 ? 0 : i * row_stride_);
    if (in_place_) return reinterpret_cast<const double*>(row);
    for (int j = 0; j < n_; ++j)
      std::memcpy(&scratch[static_cast<std::size_t>(j)], row + j * col_stride_, sizeof(double));
    return scratch.data();
  }

 private:
  const char* name_;
  pybind11::object array_;  // a float64 numpy array: the caller's, or its conversion
  int n_;
  pybind11::ssize_t rows_ = -1;
  const char* data_ = nullptr;
  pybind11::ssize_t row_stride_ = 0, col_stride_ = 0;  // bytes
  bool in_place_ = false;                              // Row reads the caller's array (no copy)
};

// The batch size of a call: -1 when every argument is a single state, else the
// rows shared by the batched ones (single states broadcast against them).
// Throws value_error naming the argument whose row count differs.
pybind11::ssize_t BatchRows(std::initializer_list<const JointArray*> args);

// A new C-contiguous float64 array of shape dims[0 .. ndim).
pybind11::array_t<double> NewArray(int ndim, const pybind11::ssize_t* dims);

// Copies a column-major Eigen matrix (rows x cols) into row-major `out`, as numpy lays (rows, cols) out.
template <class Matrix>
void CopyRowMajor(const Matrix& m, double* out) {
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(out, m.rows(), m.cols()) = m;
}

// A batch of `rows` states over up to `threads` threads without the GIL: the
// calling thread is one of them, and when no more threads can start it does
// the remaining chunks itself. work(begin, end) computes the states [begin,
// end) with its own data and returns the first whose outputs are not finite,
// or end; an exception in any chunk is rethrown here. Returns the first such
// state over the batch, or rows.
template <class Work>
pybind11::ssize_t RunBatch(pybind11::ssize_t rows, int threads, Work work) {
  using pybind11::ssize_t;
  const ssize_t workers = std::min<ssize_t>(threads, std::max<ssize_t>(rows, 1));
  const ssize_t chunk = (rows + workers - 1) / workers;
  std::vector<ssize_t> bad(static_cast<std::size_t>(workers), rows);
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(workers));
  auto one = [&](ssize_t w) {
    try {
      const ssize_t begin = std::min(rows, w * chunk), end = std::min(rows, begin + chunk);
      const ssize_t i = work(begin, end);
      if (i != end) bad[static_cast<std::size_t>(w)] = i;
    } catch (...) {
      errors[static_cast<std::size_t>(w)] = std::current_exception();
    }
  };
  {
    pybind11::gil_scoped_release release;
    std::vector<std::thread> pool;
    try {
      for (ssize_t w = 1; w < workers; ++w) pool.emplace_back(one, w);
    } catch (...) {  // no more threads: the calling thread does the rest
      for (ssize_t w = static_cast<ssize_t>(pool.size()) + 1; w < workers; ++w) one(w);
    }
    one(0);
    for (std::thread& t : pool) t.join();
  }
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  return *std::min_element(bad.begin(), bad.end());
}

// help()'s text of a per-joint call (Model's and its derivatives'): `text`, then
// the paragraph every such call ends with.
inline std::string BatchDoc(const char* text) {
  return std::string(text) + R"(

A batch (N, n) of any argument gives results with a leading axis N (a single
state is used for every row); it runs without the GIL over `threads` threads,
each with its own data. ValueError for a wrong shape or a non-finite input,
RuntimeError when a result is not finite (naming the state).)";
}

// What help() and the signatures say of an argument or a result (numpy.typing
// names, as the stubs): each carries the Python object itself.
struct ArrayArg {
  pybind11::handle value;
};
struct ArrayResult {  // numpy.ndarray
  pybind11::object value;
};
struct NumberResult {  // a float for one state, an array for a batch
  pybind11::object value;
};
struct PoseResult {  // (R, p)
  pybind11::object value;
};

}  // namespace lagrange::python

namespace pybind11::detail {

template <>
struct type_caster<lagrange::python::ArrayArg> {
  PYBIND11_TYPE_CASTER(lagrange::python::ArrayArg, const_name("numpy.typing.ArrayLike"));
  bool load(handle src, bool) {
    value.value = src;
    return true;
  }
  static handle cast(const lagrange::python::ArrayArg& a, return_value_policy, handle) { return a.value.inc_ref(); }
};

// A result named `kName` in signatures, returned as the object it holds.
template <class Result>
struct named_result_caster {
  bool load(handle, bool) { return false; }
  static handle cast(Result result, return_value_policy, handle) { return result.value.release(); }
};
template <>
struct type_caster<lagrange::python::ArrayResult> : named_result_caster<lagrange::python::ArrayResult> {
  PYBIND11_TYPE_CASTER(lagrange::python::ArrayResult, const_name("numpy.ndarray[numpy.float64]"));
  using named_result_caster<lagrange::python::ArrayResult>::cast;
  using named_result_caster<lagrange::python::ArrayResult>::load;
};
template <>
struct type_caster<lagrange::python::NumberResult> : named_result_caster<lagrange::python::NumberResult> {
  PYBIND11_TYPE_CASTER(lagrange::python::NumberResult, const_name("float | numpy.ndarray[numpy.float64]"));
  using named_result_caster<lagrange::python::NumberResult>::cast;
  using named_result_caster<lagrange::python::NumberResult>::load;
};
template <>
struct type_caster<lagrange::python::PoseResult> : named_result_caster<lagrange::python::PoseResult> {
  PYBIND11_TYPE_CASTER(lagrange::python::PoseResult,
                       const_name("tuple[numpy.ndarray[numpy.float64], numpy.ndarray[numpy.float64]]"));
  using named_result_caster<lagrange::python::PoseResult>::cast;
  using named_result_caster<lagrange::python::PoseResult>::load;
};

}  // namespace pybind11::detail
