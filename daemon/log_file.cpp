#include "daemon/log_file.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace lagrange {
namespace {

// What a file that is not a regular one is, for the refusal.
const char* KindOf(mode_t mode) {
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISDIR(mode)) return "a directory";
  return "not a regular file";
}

// Opens for writing (append or truncate), close-on-exec; never creates directories. Anything but a regular
// file is refused before it is opened (opening a FIFO for writing would wait for a reader).
std::FILE* OpenFile(const std::string& path, const char* mode, std::string& error, std::size_t& size) {
  struct stat before {};
  if (stat(path.c_str(), &before) == 0 && !S_ISREG(before.st_mode)) {
    error = std::string("not a regular file (") + KindOf(before.st_mode) +
            "): the log is rotated by renaming it; name a file";
    return nullptr;
  }
  std::FILE* f = std::fopen(path.c_str(), mode);
  if (f == nullptr) {
    error = std::strerror(errno);
    return nullptr;
  }
  struct stat st {};
  size = fstat(fileno(f), &st) == 0 ? static_cast<std::size_t>(st.st_size) : 0;
  return f;
}

}  // namespace

LogFileSink::LogFileSink(std::string path, Mode mode, std::size_t max_size, int max_files)
    : path_(std::move(path)), max_size_(max_size), max_files_(max_files) {
  std::string error;
  file_ = OpenFile(path_, mode == Mode::kAppend ? "ae" : "we", error, size_);
  if (file_ == nullptr) throw LogFileError("--log-file '" + path_ + "': cannot open: " + error);
}

LogFileSink::~LogFileSink() {
  if (file_ != nullptr) std::fclose(file_);
}

std::string LogFileSink::Reopen() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (file_ == nullptr) return "closed";
  std::string error;
  std::size_t size = 0;
  std::FILE* fresh = OpenFile(path_, "ae", error, size);
  if (fresh == nullptr) return error;
  std::fclose(file_);
  file_ = fresh;
  size_ = size;
  return "";
}

void LogFileSink::Close() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (file_ == nullptr) return;
  std::fclose(file_);
  file_ = nullptr;
}

std::string LogFileSink::write_error() {
  std::lock_guard<std::mutex> lock(mutex_);
  return error_ != 0 ? std::strerror(error_) : "";
}

std::size_t LogFileSink::lines_lost() {
  std::lock_guard<std::mutex> lock(mutex_);
  return lines_lost_;
}

// The first failure after a success is said on stderr at once (the lines that
// would say it go to this file too); later ones are only counted.
void LogFileSink::Wrote(int errno_value) {
  if (errno_value != 0 && error_ == 0) {
    std::fprintf(stderr, "lagranged: --log-file '%s': cannot write: %s; its lines are lost until it can be\n",
                 path_.c_str(), std::strerror(errno_value));
  }
  error_ = errno_value;
}

void LogFileSink::sink_it_(const spdlog::details::log_msg& msg) {
  if (file_ == nullptr) return;
  spdlog::memory_buf_t formatted;
  formatter_->format(msg, formatted);
  if (max_files_ > 0 && size_ > 0 && size_ + formatted.size() > max_size_) Rotate();
  if (file_ == nullptr) return;
  errno = 0;
  const std::size_t put = std::fwrite(formatted.data(), 1, formatted.size(), file_);
  size_ += put;
  if (put < formatted.size()) {
    ++lines_lost_;
    Wrote(errno != 0 ? errno : EIO);
    std::clearerr(file_);
  }
}

// A failed flush loses what the buffer held: counted as one line at least.
void LogFileSink::flush_() {
  if (file_ == nullptr) return;
  errno = 0;
  if (std::fflush(file_) != 0) {
    ++lines_lost_;
    Wrote(errno != 0 ? errno : EIO);
    std::clearerr(file_);
  } else if (error_ != 0) {
    Wrote(0);
  }
}

// PATH.N-1 → PATH.N, …, PATH → PATH.1, then a new PATH. A failed rename only
// overwrites an older file; if the new PATH cannot be created, the lines go
// to the other sinks (stderr) until the next Reopen.
void LogFileSink::Rotate() {
  std::fclose(file_);
  file_ = nullptr;
  for (int i = max_files_; i > 0; --i) {
    const std::string from = i == 1 ? path_ : path_ + "." + std::to_string(i - 1);
    std::rename(from.c_str(), (path_ + "." + std::to_string(i)).c_str());
  }
  std::string error;
  file_ = OpenFile(path_, "we", error, size_);
}

}  // namespace lagrange
