#include "tools/view/log_view.hpp"

#include <lagrange/telemetry_t.hpp>

#include <algorithm>
#include <iterator>
#include <map>
#include <optional>
#include <set>

#include "base/escape.hpp"
#include "protocol/channels.hpp"
#include "protocol/lcm_log.hpp"
#include "protocol/receive.hpp"

namespace lagrange::cli::view {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxLogStates = 1 << 20;  // states kept from a log (about 100 MB for 7 joints)
constexpr std::size_t kMaxOtherStates = 16;     // state channels of instances the scene lacks, named
constexpr std::size_t kMaxLogPlans = 1 << 16;   // mpc plans kept per instance (at most 16 knots each)
constexpr int kBasesAfterAState = 16;           // base states looked through for the one of a state's tick

// The last entry of `logged` (sorted by t) at or before `t`; null when none.
template <class Entry>
const Entry* LastAtOrBefore(const std::vector<Entry>& logged, double t) {
  auto it = std::upper_bound(logged.begin(), logged.end(), t, [](double x, const Entry& e) { return x < e.t; });
  return it == logged.begin() ? nullptr : &*std::prev(it);
}

}  // namespace

// What reading the log counted, and the channels it reads.
struct LogView::Counts {
  std::map<std::string, std::size_t> state, telemetry, task, mpc, base;  // channel => instance
  std::size_t states = 0, dropped = 0, refused = 0;
  std::set<std::string> other_states;  // escaped
};

LogView::LogView(const std::string& file, const ViewModels& models, std::vector<ViewInstance> instances,
                 const LinkOptions& bus, std::ostream& err)
    : file_(file), models_(models), instances_(std::move(instances)), recorded_(instances_.size()) {
  Read(bus);
  for (const std::string& note : notes_) err << "lagrangectl view: " << file_ << ": " << note << "\n";
}

void LogView::Read(const LinkOptions& bus) {
  LcmLogReader reader(file_);  // LcmLogError: "cannot read F" / "F is not an LCM log ..."
  Counts counts;
  for (std::size_t i = 0; i < instances_.size(); ++i) {
    LinkOptions link = bus;
    link.channel_prefix = instances_[i].prefix;
    counts.state[link.Channel(instances_[i].name, kStateSuffix)] = i;
    counts.telemetry[link.Channel(instances_[i].name, kTelemetrySuffix)] = i;
    counts.task[link.Channel(instances_[i].name, kTaskSuffix)] = i;
    counts.mpc[link.Channel(instances_[i].name, kMpcSuffix)] = i;
    counts.base[link.Channel(instances_[i].name, kBaseSuffix)] = i;
  }
  std::optional<std::int64_t> first;
  while (const LcmLogEvent* e = reader.Next()) {
    if (!first) first = e->utime;
    const double t = 1e-6 * static_cast<double>(e->utime - *first);
    duration_ = std::max(duration_, t);
    Note(counts, std::string(e->channel), e->data, e->size, t);
  }
  Finish(counts, reader.end());
}

// One logged event: kept when it is a state, telemetry, task state, mpc plan or base state of an instance and
// decodes.
void LogView::Note(Counts& counts, const std::string& channel, const std::uint8_t* data, std::size_t size, double t) {
  if (auto it = counts.state.find(channel); it != counts.state.end()) {
    auto s = Receive<state_t>(data, size, Framing::kRecorded).message;
    if (!s) {
      ++counts.refused;
    } else if (counts.states >= kMaxLogStates) {
      ++counts.dropped;
    } else {
      ++counts.states;
      recorded_[it->second].states.push_back({t, std::move(*s)});
    }
  } else if (auto tt = counts.telemetry.find(channel); tt != counts.telemetry.end()) {
    auto m = Receive<telemetry_t>(data, size, Framing::kRecorded).message;
    auto& telemetry = recorded_[tt->second].telemetry;
    if (m && telemetry.size() < kMaxLogStates) telemetry.push_back({t, {m->energy_residual, m->quadrature_bound}});
  } else if (auto tk = counts.task.find(channel); tk != counts.task.end()) {
    auto m = Receive<task_state_t>(data, size, Framing::kRecorded).message;
    auto& tasks = recorded_[tk->second].tasks;
    if (m && tasks.size() < kMaxLogStates) tasks.push_back({t, std::move(*m)});
  } else if (auto mp = counts.mpc.find(channel); mp != counts.mpc.end()) {
    auto m = Receive<mpc_t>(data, size, Framing::kRecorded).message;
    auto& plans = recorded_[mp->second].plans;
    if (m && plans.size() < kMaxLogPlans) plans.push_back({t, std::move(*m)});
  } else if (auto b = counts.base.find(channel); b != counts.base.end()) {
    auto m = Receive<base_state_t>(data, size, Framing::kRecorded).message;
    auto& bases = recorded_[b->second].bases;
    if (m && bases.size() < kMaxLogStates) bases.push_back({t, std::move(*m)});
  } else if (channel.ends_with(kStateSuffix) && counts.other_states.size() < kMaxOtherStates) {
    counts.other_states.insert(Escape(channel, 64));
  }
}

void LogView::Finish(const Counts& counts, LcmLogReader::End end) {
  if (end == LcmLogReader::End::kTruncated) notes_.push_back("the log ends inside an event (cut short)");
  if (end == LcmLogReader::End::kCorrupt) notes_.push_back("the log ends at a corrupt event");
  if (counts.refused > 0)
    notes_.push_back(std::to_string(counts.refused) + " states that do not decode were passed over");
  if (counts.dropped > 0)
    notes_.push_back("only the first " + std::to_string(kMaxLogStates) + " states are shown (" +
                     std::to_string(counts.dropped) + " more)");
  for (const std::string& c : counts.other_states) notes_.push_back(c + " is in the log but not in the scene: not drawn (--scene)");
  if (counts.states == 0) notes_.push_back("no state of the scene's instances in this log");
}

json LogView::Info() const { return {{"file", Escape(file_)}, {"duration", duration_}, {"notes", notes_}}; }

json LogView::FrameAt(double t) const {
  json instances = json::array();
  for (std::size_t i = 0; i < instances_.size(); ++i) {
    json j = InstanceAt(i, t);
    if (!j.is_null()) instances.push_back(std::move(j));
  }
  return {{"t", t}, {"instances", instances}};
}

// Instance i at its last state at or before t, with its telemetry, task state and plan as they were then.
json LogView::InstanceAt(std::size_t i, double t) const {
  const Recorded& r = recorded_[i];
  const Logged<state_t>* s = LastAtOrBefore(r.states, t);
  if (s == nullptr) return nullptr;
  const Logged<task_state_t>* task = LastAtOrBefore(r.tasks, t);
  const Logged<mpc_t>* plan = LastAtOrBefore(r.plans, t);
  json j = InstanceJson(instances_[i], models_, s->message, t - s->t, task ? &task->message : nullptr,
                        plan ? &plan->message : nullptr, BaseOf(r, *s, t));
  j["log_t"] = s->t;
  if (const Logged<Telemetry>* m = LastAtOrBefore(r.telemetry, t)) {
    j["eps"] = m->message.residual;
    j["eps_bound"] = m->message.bound;
  }
  return j;
}

// A floating base's state for the logged state `s` shown at `t`: the one of its run and tick (published after
// it in the same tick, so maybe logged after t; among the next kBasesAfterAState), else the last logged at or
// before t; null when none.
const base_state_t* LogView::BaseOf(const Recorded& r, const Logged<state_t>& s, double t) const {
  auto it = std::lower_bound(r.bases.begin(), r.bases.end(), s.t,
                             [](const Logged<base_state_t>& e, double x) { return e.t < x; });
  for (int k = 0; it != r.bases.end() && k < kBasesAfterAState; ++it, ++k) {
    if (it->message.run_id == s.message.run_id && it->message.tick == s.message.tick) return &it->message;
  }
  const Logged<base_state_t>* last = LastAtOrBefore(r.bases, t);
  return last != nullptr ? &last->message : nullptr;
}

}  // namespace lagrange::cli::view
