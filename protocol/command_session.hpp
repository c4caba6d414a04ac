#pragma once
// A command's session on the client side, written once for lagrangectl
// command and Python's Client.command, so that both word every verdict the
// same: how many gains a set-gains command carries, how a verdict reads, how
// much of a refusal's reason is shown, and an emergency stop's report over
// every run publishing the instance's state (DaemonLink::Estop).
//
// A report is lines, then, when the command was not done, one line saying
// why: lagrangectl prints the lines and fails with that line; Python's
// Verdict.message is the whole text (CommandReport::Text).

#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "protocol/client.hpp"

namespace lagrange {

// A refusal's reason is shown whole: a reply_t's reason passes the wire check
// at up to 4 KiB, and Escape's default cut would lose a gain refusal's bounds.
inline constexpr std::size_t kMaxReasonShown = 2048;

// The number of gains a set-gains command carries to an instance whose latest
// state is `s`: one per task axis (x, y, z, rx, ry, rz) when it runs a
// task-space controller (GainsPerTaskAxis), else one per joint.
bool GainsPerTaskAxis(const state_t& s);
int GainCount(const state_t& s);

// A command's words as its verdict quotes them: each escaped, one space apart.
std::string CommandWordsText(const std::vector<std::string>& words);

// What a client reports of a command.
struct CommandReport {
  bool accepted = false;           // done (an estop: applied, and kept, by every run)
  std::vector<std::string> lines;  // "arm: pause done; now paused with pd"; an estop to several runs: one per run
  std::string failure;             // not accepted: "refused: REASON", "estop applied by 1 of the 2 runs ..."
  std::int64_t run_id = 0;         // the run that answered (0: several, for an estop)

  // The lines, then the failure, one per line.
  std::string Text() const;
};

// A command's report from its run's reply: "INSTANCE: WORDS done; now MODE"
// (`mode_after`: DaemonLink::ModeAfterReply), or "refused: REASON" (escaped,
// at most kMaxReasonShown bytes of it).
CommandReport ReportCommand(const std::string& instance, const std::string& words, const reply_t& reply,
                            const std::string& mode_after);

// Sends `command` once over `link` (after AwaitOneRun; DaemonLink::Command,
// whose errors it throws) and reports its verdict; `words` as CommandWordsText.
CommandReport RunCommand(DaemonLink& link, const std::string& instance, const std::string& words, command_t& command);

// One run's part in an emergency stop, as the link saw it.
struct EstopRun {
  std::int64_t run = 0;
  std::optional<reply_t> reply;  // none: no verdict within the wait
  std::string did_not_stay;      // applied: DaemonLink::EstopDidNotStay ("" when it stayed)
  std::string mode_after;        // applied and stayed: DaemonLink::ModeAfterReply
};

// An estop's report. One run: worded as every other command ("arm: estop done;
// now estop with pd", "refused: REASON", "estop applied, but the estop did not
// stay: ..."), and std::runtime_error "no verdict from lagranged (run X) within
// W s" when it did not answer. Several runs: a line per run ("arm: run X: estop
// done; now ...", "... estop no verdict within W s", "... estop refused: R",
// "... estop applied, but ..."), and unless every run applied and kept it,
// "estop applied by A of the N runs publishing CHANNEL (ids X, Y)".
CommandReport ReportEstop(const std::string& instance, const std::string& state_channel, double wait,
                          const std::vector<EstopRun>& runs);

// The emergency stop over `link` (not yet awaited): every run publishing the
// instance's state (AwaitRuns), each sent the estop until it answered
// (DaemonLink::Estop), each that applied it watched (EstopDidNotStay), then
// ReportEstop.
CommandReport RunEstop(DaemonLink& link, const std::string& instance, command_t& command);

}  // namespace lagrange
