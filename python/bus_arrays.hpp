#pragma once
// numpy arrays in and out for the simulator and the bus (simulate.cpp,
// bus.cpp): float64, copied, shapes checked with the CLI's wording.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "plant/types.hpp"
#include "protocol/format.hpp"
#include "protocol/log_records.hpp"

namespace lagrange::python {

namespace py = pybind11;

// A copy of `v` as a float64 array of shape (n,).
inline py::array_t<double> ToArray(const VectorXd& v) {
  py::array_t<double> out(v.size());
  std::copy(v.data(), v.data() + v.size(), out.mutable_data());
  return out;
}
inline py::array_t<double> ToArray(const std::vector<double>& v) {
  py::array_t<double> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

// `rows` × `columns` values, row after row, as a float64 array of shape (rows, columns).
inline py::array_t<double> ToMatrix(const std::vector<double>& values, py::ssize_t rows, py::ssize_t columns) {
  py::array_t<double> out({rows, columns});
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}

// A floating base's arrays, named and ordered as log2csv's <NAME>_BASE
// columns (kBaseStateArrays: position, orientation, linear_velocity,
// angular_velocity, com, linear_momentum, angular_momentum).
inline constexpr std::size_t kNumBaseArrays = std::size(kBaseStateArrays);
using BaseArrays = std::array<py::array_t<double>, kNumBaseArrays>;

// One base_state_t, or an offline instance's base now (lagrange.BaseState):
// `values` kBaseStateWidth doubles in kBaseStateArrays' order, each array of
// shape (width,); utime, run_id and tick are the message's (none offline).
struct BaseState {
  std::optional<std::int64_t> utime, run_id, tick;
  double t = 0.0;
  BaseArrays arrays;
  BaseState(double time, const double* values) : t(time) {
    for (std::size_t k = 0; k < kNumBaseArrays; ++k) {
      const int width = kBaseStateArrays[k].width;
      arrays[k] = py::array_t<double>(width);
      std::copy(values, values + width, arrays[k].mutable_data());
      values += width;
    }
  }
};

// A run's base, one row per step (lagrange.BaseRows): `values` rows ×
// kBaseStateWidth doubles, row after row, each array of shape (rows, width).
inline BaseArrays BaseColumns(const std::vector<double>& values, py::ssize_t rows) {
  BaseArrays out;
  py::ssize_t first = 0;  // the array's first column in a row
  for (std::size_t k = 0; k < kNumBaseArrays; ++k) {
    const py::ssize_t width = kBaseStateArrays[k].width;
    out[k] = py::array_t<double>({rows, width});
    double* data = out[k].mutable_data();
    for (py::ssize_t r = 0; r < rows; ++r) {
      const double* row = values.data() + r * kBaseStateWidth + first;
      std::copy(row, row + width, data + r * width);
    }
    first += width;
  }
  return out;
}

// `what` (a name such as "tau") as n finite values: a sequence or array of
// shape (n,), any dtype numpy casts to float64. ValueError otherwise, worded
// as lagrangectl's: "tau: expected 2 values (one per joint), got 3".
inline VectorXd JointVector(const py::handle& values, int n, const char* what, bool allow_one = false) {
  py::array_t<double, py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::forcecast>::ensure(values);
  } catch (const py::error_already_set&) {
    a = {};
  }
  if (!a)
    throw py::value_error(std::string(what) + ": expected numbers, got " +
                          std::string(py::str(py::type::of(values).attr("__name__"))));
  if (a.ndim() > 1)
    throw py::value_error(std::string(what) + ": expected shape (" + std::to_string(n) + ",), got an array of " +
                          std::to_string(a.ndim()) + " dimensions");
  const py::ssize_t size = a.ndim() == 0 ? 1 : a.shape(0);
  const bool one = allow_one && size == 1;
  if (size != n && !one) {
    throw py::value_error(std::string(what) + ": expected " + std::to_string(n) + (n == 1 ? " value" : " values") +
                          (one && n > 1 ? "" : "") +
                          (allow_one && n > 1 ? " (one for every joint, or one per joint)" : " (one per joint)") +
                          ", got " + std::to_string(size));
  }
  VectorXd out(n);
  const double* data = a.data();
  for (int i = 0; i < n; ++i) {
    const double x = data[one ? 0 : i];
    if (!std::isfinite(x)) {
      throw py::value_error(std::string(what) + ": expected finite values, got " + FormatDouble(x) + " at index " +
                            std::to_string(i));
    }
    out[i] = x;
  }
  return out;
}

// A message that may quote the bus or a file (Escape lets bytes >= 0x80 through) as
// valid UTF-8, each byte of an invalid sequence as \xHH: Python makes the
// exception's str from it, and would fail on invalid UTF-8. Written here, not
// with Python's codec, because it runs without the GIL.
inline std::string ValidUtf8(const std::string& text) {
  std::string out;
  const auto* b = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = b[i];
    const std::size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
    bool ok = len > 0 && i + len <= n;
    for (std::size_t k = 1; ok && k < len; ++k) ok = (b[i + k] & 0xc0) == 0x80;
    // No overlong forms, surrogates or code points past U+10FFFF (Python's decoder refuses them too).
    if (ok && len == 2) ok = c >= 0xc2;
    if (ok && len == 3) ok = !(c == 0xe0 && b[i + 1] < 0xa0) && !(c == 0xed && b[i + 1] >= 0xa0);
    if (ok && len == 4) ok = c <= 0xf4 && !(c == 0xf0 && b[i + 1] < 0x90) && !(c == 0xf4 && b[i + 1] >= 0x90);
    if (ok) {
      out.append(text, i, len);
      i += len;
      continue;
    }
    char hex[5];
    std::snprintf(hex, sizeof hex, "\\x%02x", c);
    out += hex;
    ++i;
  }
  return out;
}

}  // namespace lagrange::python
