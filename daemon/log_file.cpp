#include "daemon/log_file.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace lagrange {
namespace {

// Opens for writing (append or truncate), close-on-exec; never creates directories.
std::FILE* OpenFile(const std::string& path, const char* mode, std::string& error, std::size_t& size) {
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

void LogFileSink::sink_it_(const spdlog::details::log_msg& msg) {
  if (file_ == nullptr) return;
  spdlog::memory_buf_t formatted;
  formatter_->format(msg, formatted);
  if (max_files_ > 0 && size_ > 0 && size_ + formatted.size() > max_size_) Rotate();
  if (file_ == nullptr) return;
  size_ += std::fwrite(formatted.data(), 1, formatted.size(), file_);
}

void LogFileSink::flush_() {
  if (file_ != nullptr) std::fflush(file_);
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
