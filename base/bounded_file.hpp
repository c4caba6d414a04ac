#pragma once
// Reading a file someone else may have named: a URDF robot, a scene, an
// lcm-logger file. Only a regular file is read, opened without blocking (a
// FIFO would wait for a writer forever, a device never end), and a whole file
// only up to a bound (/dev/zero, or a file grown by mistake, would read until
// memory runs out). Part of lagrange_base, the bottom layer: the URDF reader,
// the scene reader and protocol/'s log reader all read through it.

#include <cstddef>
#include <stdexcept>
#include <string>

namespace lagrange {

// Why a file could not be read: "cannot be opened (No such file or
// directory)", "not a regular file (a FIFO)", "larger than 2 MiB", ... The
// caller adds the file's name in its own message format.
class FileReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The whole of `path`, at most `max_bytes` of it. Throws FileReadError.
std::string ReadBoundedFile(const std::string& path, std::size_t max_bytes);

// `path` opened for reading (O_RDONLY | O_CLOEXEC; opened without blocking,
// and a regular file, so reads from it never wait for a writer): a file
// descriptor the caller closes. Throws FileReadError.
int OpenRegularFile(const std::string& path);

}  // namespace lagrange
