#include "tools/spawn.hpp"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <stdexcept>

namespace lagrange {
namespace {

// Makes `fd` the child's `target` (stdout or stderr), without close-on-exec.
// Async-signal-safe.
void Redirect(int fd, int target) {
  if (fd < 0) return;
  if (fd == target) {
    const int flags = fcntl(fd, F_GETFD);
    if (flags >= 0) fcntl(fd, F_SETFD, flags & ~FD_CLOEXEC);
  } else {
    dup2(fd, target);  // the copy never has FD_CLOEXEC
  }
}

// The exec candidates for `file`, in execvp's order: `file` itself when it
// has a '/' (or no PATH search), else DIR/file for each PATH entry (an empty
// entry: the cwd; no PATH: confstr's default, /bin:/usr/bin).
std::vector<std::string> Candidates(const std::string& file, bool search_path) {
  if (file.empty()) return {};
  if (!search_path || file.find('/') != std::string::npos) return {file};
  std::string path;
  if (const char* env = getenv("PATH")) {
    path = env;
  } else {
    const std::size_t n = confstr(_CS_PATH, nullptr, 0);
    path.assign(n > 0 ? n - 1 : 0, '\0');
    if (n > 0) confstr(_CS_PATH, path.data(), n);
  }
  std::vector<std::string> candidates;
  std::size_t start = 0;
  while (true) {
    const std::size_t colon = path.find(':', start);
    const std::string dir = path.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
    candidates.push_back(dir.empty() ? file : dir + "/" + file);
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  return candidates;
}

}  // namespace

pid_t Spawn(const std::vector<std::string>& argv, const SpawnOptions& options) {
  if (argv.empty()) throw std::invalid_argument("Spawn: empty argv");

  // Everything the child needs, built here: after fork it may not allocate.
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const std::vector<std::string> candidates =
      Candidates(options.file.empty() ? argv[0] : options.file, options.search_path);
  std::vector<const char*> paths;
  paths.reserve(candidates.size());
  for (const std::string& c : candidates) paths.push_back(c.c_str());
  struct sigaction default_action {};
  default_action.sa_handler = SIG_DFL;
  sigemptyset(&default_action.sa_mask);
  const pid_t parent = getpid();

  const pid_t pid = fork();
  if (pid != 0) return pid;  // the parent: the child's pid, or -1 (errno from fork)

  // The child: async-signal-safe calls only from here on.
  if (options.stderr_fd == STDOUT_FILENO) {  // before stdout is replaced
    Redirect(options.stderr_fd, STDERR_FILENO);
    Redirect(options.stdout_fd, STDOUT_FILENO);
  } else {
    Redirect(options.stdout_fd, STDOUT_FILENO);
    Redirect(options.stderr_fd, STDERR_FILENO);
  }
  if (options.timer_slack_ns > 0) prctl(PR_SET_TIMERSLACK, options.timer_slack_ns, 0, 0, 0);
  if (options.default_sigpipe) sigaction(SIGPIPE, &default_action, nullptr);
  if (options.die_with_parent) {
    prctl(PR_SET_PDEATHSIG, SIGKILL, 0, 0, 0);
    if (getppid() != parent) _exit(127);  // it died before prctl: no signal would come
  }
  for (const char* path : paths) {
    execv(path, args.data());
    // As execvp: a missing or unreadable candidate moves on to the next; anything else is final.
    if (errno != ENOENT && errno != ENOTDIR && errno != EACCES && errno != ESTALE && errno != ENODEV &&
        errno != ETIMEDOUT)
      break;
  }
  _exit(127);
}

}  // namespace lagrange
