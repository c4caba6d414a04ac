#include "protocol/command_session.hpp"

#include <map>
#include <stdexcept>

#include "base/escape.hpp"
#include "base/vocabulary.hpp"
#include "protocol/channels.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"

namespace lagrange {

bool GainsPerTaskAxis(const state_t& s) {
  const std::optional<ControllerType> active = ParseControllerType(s.controller);
  return active && IsTaskSpace(*active);
}

int GainCount(const state_t& s) { return GainsPerTaskAxis(s) ? kTaskDims : s.num_dofs; }

std::string CommandWordsText(const std::vector<std::string>& words) {
  std::string text;
  for (const std::string& w : words) {
    if (!text.empty()) text += ' ';
    text += Escape(w);
  }
  return text;
}

std::string CommandReport::Text() const {
  std::string text;
  for (const std::string& line : lines) {
    if (!text.empty()) text += '\n';
    text += line;
  }
  if (!failure.empty()) {
    if (!text.empty()) text += '\n';
    text += failure;
  }
  return text;
}

namespace {

std::string Refused(const reply_t& reply) { return "refused: " + Escape(reply.reason, kMaxReasonShown); }

}  // namespace

CommandReport ReportCommand(const std::string& instance, const std::string& words, const reply_t& reply,
                            const std::string& mode_after) {
  CommandReport report;
  report.run_id = reply.run_id;
  report.accepted = reply.accepted;
  if (!reply.accepted) {
    report.failure = Refused(reply);
  } else {
    report.lines.push_back(instance + ": " + words + " done; now " + mode_after);
  }
  return report;
}

CommandReport RunCommand(DaemonLink& link, const std::string& instance, const std::string& words, command_t& command) {
  const reply_t reply = link.Command(command);  // sent once: a repeat could apply twice
  return ReportCommand(instance, words, reply, reply.accepted ? link.ModeAfterReply(reply.run_id) : "");
}

namespace {

// The one run's verdict, worded as every other command's.
CommandReport ReportOneRunsEstop(const std::string& instance, double wait, const EstopRun& r) {
  if (!r.reply) {
    throw std::runtime_error("no verdict from lagranged (run " + RunIdText(r.run) + ") within " + FormatDouble(wait) +
                             " s");
  }
  CommandReport report;
  report.run_id = r.run;
  if (!r.reply->accepted) {
    report.failure = Refused(*r.reply);
  } else if (!r.did_not_stay.empty()) {
    report.failure = "estop applied, but " + r.did_not_stay;
  } else {
    report.accepted = true;
    report.lines.push_back(instance + ": estop done; now " + r.mode_after);
  }
  return report;
}

}  // namespace

CommandReport ReportEstop(const std::string& instance, const std::string& state_channel, double wait,
                          const std::vector<EstopRun>& runs) {
  if (runs.size() == 1) return ReportOneRunsEstop(instance, wait, runs[0]);
  CommandReport report;
  std::size_t applied = 0;
  std::string ids;
  for (const EstopRun& r : runs) {
    const std::string id = RunIdText(r.run);
    ids += (ids.empty() ? "" : ", ") + id;
    std::string line = instance + ": run " + id + ": estop ";
    if (!r.reply) {
      line += "no verdict within " + FormatDouble(wait) + " s";
    } else if (!r.reply->accepted) {
      line += Refused(*r.reply);
    } else if (!r.did_not_stay.empty()) {
      line += "applied, but " + r.did_not_stay;
    } else {
      ++applied;
      line += "done; now " + r.mode_after;
    }
    report.lines.push_back(std::move(line));
  }
  report.accepted = applied == runs.size();
  if (!report.accepted) {
    report.failure = "estop applied by " + std::to_string(applied) + " of the " + std::to_string(runs.size()) +
                     " runs publishing " + state_channel + " (ids " + ids + ")";
  }
  return report;
}

CommandReport RunEstop(DaemonLink& link, const std::string& instance, command_t& command) {
  link.AwaitRuns();
  const std::map<std::int64_t, std::optional<reply_t>> verdicts = link.Estop(command);
  std::vector<EstopRun> runs;
  for (const auto& [run, reply] : verdicts) {
    EstopRun r{run, reply, "", ""};
    if (reply && reply->accepted) {
      r.did_not_stay = link.EstopDidNotStay(run);
      if (r.did_not_stay.empty()) r.mode_after = link.ModeAfterReply(run);
    }
    runs.push_back(std::move(r));
  }
  return ReportEstop(instance, link.options().Channel(instance, kStateSuffix), link.options().wait, runs);
}

}  // namespace lagrange
