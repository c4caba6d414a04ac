#pragma once
// lagranged's log files (--log-file PATH):
//
//   PATH         every line; rotated by size (PATH.1 … PATH.N, newest first) and
//                reopened by name on SIGHUP, so logrotate's rename-then-HUP works
//   PATH.start   the start-up lines of the latest start only (options, scene,
//                instances, real-time set-up), truncated at each start and closed
//                once the loop runs: no flood of later lines can rotate them away
//
// Both are opened before anything else happens, with fopen: a missing
// directory is an error (never created), as is a directory, an unwritable
// path or anything but a regular file (/dev/full, a FIFO: a log is rotated by
// renaming it, and a device would lose its lines). A write that fails later
// (a full disk, a file size limit) loses lines, never the daemon: the first
// failure is said at once on stderr, the lines lost are counted
// (lines_lost), and the start-up checks that its own lines were written
// (write_error) before the loop runs.

#include <spdlog/sinks/base_sink.h>

#include <cstddef>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <string>

namespace lagrange {

struct LogFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class LogFileSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  enum class Mode : std::uint8_t { kAppend, kTruncate };
  // Opens `path`. `max_size` bytes per file before rotating into `max_files`
  // older ones; max_files 0: never rotate. Throws LogFileError
  // ("--log-file 'PATH': cannot open: <reason>").
  LogFileSink(std::string path, Mode mode, std::size_t max_size = 0, int max_files = 0);
  ~LogFileSink() override;

  const std::string& path() const { return path_; }
  // Closes the file and opens `path` again (appending): after logrotate renamed
  // it, a new file of that name. Returns "" or why it kept writing the old one.
  std::string Reopen();
  // Flushes and closes the file; later lines are not written to it.
  void Close();
  // Why the latest write or flush failed ("No space left on device"), or "" when
  // the latest succeeded.
  std::string write_error();
  // Lines that could not be written since the file was opened.
  std::size_t lines_lost();

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override;
  void flush_() override;

 private:
  void Rotate();
  // A write or flush that failed with `errno_value` (0: it succeeded).
  void Wrote(int errno_value);

  std::string path_;
  std::size_t max_size_;
  int max_files_;
  std::FILE* file_ = nullptr;
  std::size_t size_ = 0;  // bytes in the current file
  int error_ = 0;               // errno of the latest failed write or flush; 0 after one that succeeded
  std::size_t lines_lost_ = 0;  // lines not written (whole or in part)
};

}  // namespace lagrange
