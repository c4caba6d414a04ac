// lagrange::Spawn's die_with_parent: a child started with it does not outlive
// its parent. This test process adopts orphans (a child subreaper), forks a
// parent that spawns a long sleep with the flag and reports its pid once it
// runs, kills that parent, and reaps the orphaned grandchild: it must have
// been killed, by SIGKILL, without anyone else signalling it.

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "tools/spawn.hpp"

namespace lagrange {
namespace {

// How long the grandchild may take to be killed and reaped: a bound for a
// loaded machine, not a timing assertion (it is killed as its parent dies).
constexpr double kReapTimeout = 30.0;  // s

// Waits up to kReapTimeout for `pid` (a child of this process) to end; its
// wait status, or -1 when it is still running.
int ReapWithin(pid_t pid) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kReapTimeout);
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return -1;
}

TEST(Spawn, AChildThatDiesWithItsParentIsKilledWhenItsParentIs) {
  ASSERT_EQ(prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0), 0);  // orphans below us come to us
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  const pid_t parent = fork();  // one thread here: the child may spawn before exec
  ASSERT_GE(parent, 0);
  if (parent == 0) {
    close(pipe_fds[0]);
    // The grandchild's copy of `exec_fds` closes at its exec, after its prctl:
    // the read below ends then, so the parent is killed only after the
    // signal is set up (killed before, the grandchild exits on its own).
    int exec_fds[2];
    if (pipe2(exec_fds, O_CLOEXEC) != 0) _exit(1);
    SpawnOptions options;
    options.die_with_parent = true;
    const pid_t grandchild = Spawn({"/bin/sleep", "1000"}, options);
    close(exec_fds[1]);
    char byte;
    while (read(exec_fds[0], &byte, 1) > 0) {
    }
    const bool told = write(pipe_fds[1], &grandchild, sizeof grandchild) == static_cast<ssize_t>(sizeof grandchild);
    close(pipe_fds[1]);
    if (!told) _exit(1);
    while (true) pause();  // until killed
  }
  close(pipe_fds[1]);
  pid_t grandchild = -1;
  const bool read_pid = read(pipe_fds[0], &grandchild, sizeof grandchild) == static_cast<ssize_t>(sizeof grandchild);
  close(pipe_fds[0]);
  ASSERT_TRUE(read_pid);
  ASSERT_GT(grandchild, 0);

  ASSERT_EQ(kill(parent, SIGKILL), 0);
  int parent_status = 0;
  ASSERT_EQ(waitpid(parent, &parent_status, 0), parent);
  ASSERT_TRUE(WIFSIGNALED(parent_status));

  const int status = ReapWithin(grandchild);  // reparented to this process, the subreaper
  if (status == -1) {
    kill(grandchild, SIGKILL);
    waitpid(grandchild, nullptr, 0);
  }
  ASSERT_NE(status, -1) << "the grandchild outlived its parent";
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGKILL);
  prctl(PR_SET_CHILD_SUBREAPER, 0, 0, 0, 0);
}

}  // namespace
}  // namespace lagrange
