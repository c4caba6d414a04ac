#pragma once
// A file argument (str, bytes or os.PathLike) as the bytes the file system
// takes, as open() takes it: os.fsencode, so a file name that is not UTF-8
// (os.listdir gives it as a str with surrogate escapes) opens as it does from
// the shell, and bytes are a path, not the text "b'...'".

#include <pybind11/pybind11.h>

#include <string>

namespace lagrange::python {

// ValueError for an embedded NUL (the C library would open the name cut
// there), as open() says; TypeError for what is not a path.
inline std::string FsPath(const pybind11::handle& path, const char* what) {
  namespace py = pybind11;
  const py::bytes encoded = py::module_::import("os").attr("fsencode")(path);
  std::string bytes = encoded;
  if (bytes.find('\0') != std::string::npos) throw py::value_error(std::string(what) + ": embedded null byte");
  return bytes;
}

}  // namespace lagrange::python
