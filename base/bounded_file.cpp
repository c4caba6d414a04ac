#include "base/bounded_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>
#include <utility>

namespace lagrange {
namespace {

std::string FileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a file";
}

class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }

 private:
  int fd_;
};

std::string SystemReason(int error) { return std::generic_category().message(error); }

}  // namespace

int OpenRegularFile(const std::string& path) {
  // Non-blocking: opening a FIFO for reading would wait for a writer. Only a regular file is read.
  FileDescriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
  if (fd.get() < 0) {
    const int error = errno;
    throw FileReadError("cannot be opened (" + SystemReason(error) + ")");
  }
  struct stat status {};
  if (::fstat(fd.get(), &status) != 0) {
    const int error = errno;
    throw FileReadError("cannot be read (" + SystemReason(error) + ")");
  }
  if (!S_ISREG(status.st_mode)) throw FileReadError("not a regular file (" + FileKind(status.st_mode) + ")");
  return fd.release();
}

std::string ReadBoundedFile(const std::string& path, std::size_t max_bytes) {
  const FileDescriptor fd(OpenRegularFile(path));
  std::string text;
  char buffer[1 << 16];
  while (true) {
    const ssize_t n = ::read(fd.get(), buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      throw FileReadError("cannot be read (" + SystemReason(error) + ")");
    }
    if (n == 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
    if (text.size() > max_bytes) {
      throw FileReadError(max_bytes >= (1u << 20) ? "larger than " + std::to_string(max_bytes >> 20) + " MiB"
                                                   : "larger than " + std::to_string(max_bytes) + " bytes");
    }
  }
  return text;
}

}  // namespace lagrange
