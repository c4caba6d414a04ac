// lagrange.Client and lagrange.read_log: the project's own client and log
// reader bound, not re-implemented. A Client keeps one DaemonLink
// (protocol/client.hpp) per instance it talks to: the hardened receive path
// (wire checks before decoding), one lagranged run per instance (a second
// run publishing the same state refuses to act), verdicts only from that run
// carrying the request's own id, and signed traffic with a key. read_log is
// log2csv's decoding (protocol/log_records.hpp) into numpy columns.
// Every wait releases the GIL.

#include <lagrange/setpoint_t.hpp>
#include <lagrange/torque_t.hpp>

#include <pybind11/stl.h>

#include <poll.h>

#include <atomic>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <regex>
#include <thread>
#include <type_traits>

#include "base/escape.hpp"
#include "controllers/factory.hpp"
#include "protocol/channels.hpp"
#include "protocol/client.hpp"
#include "protocol/clock.hpp"
#include "protocol/command_session.hpp"
#include "protocol/command_words.hpp"
#include "protocol/ids.hpp"
#include "protocol/lcm_log.hpp"
#include "protocol/log_records.hpp"
#include "protocol/mode.hpp"
#include "protocol/setpoint_check.hpp"
#include "python/bindings.hpp"
#include "python/bus_arrays.hpp"
#include "python/paths.hpp"

namespace lagrange::python {
namespace {

// The most states Client.states keeps that the caller has not taken yet; beyond, the oldest are dropped and counted.
constexpr std::size_t kMaxQueuedStates = 100000;

double SteadySeconds(std::chrono::steady_clock::time_point t) {
  // CLOCK_MONOTONIC, as Python's time.monotonic().
  return std::chrono::duration<double>(t.time_since_epoch()).count();
}

// Text that came off the bus or out of a log (escaped, but bytes >= 0x80
// pass as they came) as a str: invalid UTF-8 is shown as \\xHH, never an error.
py::str Text(const std::string& text) {
  PyObject* o = PyUnicode_DecodeUTF8(text.data(), static_cast<Py_ssize_t>(text.size()), "backslashreplace");
  if (o == nullptr) throw py::error_already_set();
  return py::reinterpret_steal<py::str>(o);
}

// One state_t, as Python sees it.
struct State {
  std::int64_t utime = 0, run_id = 0, tick = 0;
  double t = 0.0;
  int num_dofs = 0;
  VectorXd q, qd, qdd, tau, q_des, qd_des;
  double kinetic_energy = 0.0, potential_energy = 0.0;
  std::string controller, mode;
  double received = 0.0;  // s, time.monotonic() when it arrived

  State(const state_t& s, std::chrono::steady_clock::time_point at)
      : utime(s.utime),
        run_id(s.run_id),
        tick(s.tick),
        t(s.t),
        num_dofs(s.num_dofs),
        kinetic_energy(s.kinetic_energy),
        potential_energy(s.potential_energy),
        controller(Escape(s.controller)),
        mode(ModeName(s.mode)),
        received(SteadySeconds(at)) {
    for (const auto& [out, in] : {std::pair{&q, &s.q},
                                  {&qd, &s.qd},
                                  {&qdd, &s.qdd},
                                  {&tau, &s.tau},
                                  {&q_des, &s.q_des},
                                  {&qd_des, &s.qd_des}}) {
      *out = Eigen::Map<const VectorXd>(in->data(), static_cast<Eigen::Index>(in->size()));
    }
  }
};

// The daemon's verdict on a command.
struct Verdict {
  bool accepted = false;
  std::string message;  // as lagrangectl command reports it: "arm: estop done; now estop with pd", "refused: REASON"
  std::int64_t run_id = 0;
};

// The C++ errors a client meets, as Python's: a bad URL or key is the caller's argument.
[[noreturn]] void Rethrow() {
  try {
    throw;
  } catch (const py::error_already_set&) {
    throw;
  } catch (const py::builtin_exception&) {
    throw;
  } catch (const BusUrlError& e) {
    throw py::value_error(ValidUtf8(e.what()));
  } catch (const BusKeyError& e) {
    throw py::value_error(ValidUtf8(e.what()));
  } catch (const CommandWordsError& e) {
    throw py::value_error(ValidUtf8(e.what()));
  } catch (const std::exception& e) {
    throw std::runtime_error(ValidUtf8(e.what()));
  }
}

class Client {
 public:
  Client(std::optional<std::string> url, std::string prefix, std::optional<std::string> key_file, double wait,
         std::optional<std::string> bus_domain) {
    if (const std::string why = CheckWait(wait); !why.empty()) throw py::value_error("wait: " + why);
    options_.lcm_url = url.value_or("");
    options_.channel_prefix = std::move(prefix);
    if (!options_.channel_prefix.empty() && !CheckChannelName(options_.channel_prefix + "X").empty()) {
      throw py::value_error(
          "prefix: expected the start of an LCM channel name (printable ASCII without spaces, "
          "under 63 bytes), got '" +
          Escape(options_.channel_prefix, 64) + "'");
    }
    options_.bus_key_file = std::move(key_file);
    options_.bus_domain = std::move(bus_domain);
    options_.wait = wait;
    try {
      options_.Open();  // the URL and the key checked now, with lagrangectl's lines
    } catch (...) {
      Rethrow();
    }
  }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;
  ~Client() {
    stop_ = true;
    if (receiver_.joinable()) receiver_.join();
  }

  State GetState(const std::string& name, double timeout) {
    CheckTimeout(timeout);
    return ReadLatest(name, timeout, [](DaemonLink& link) { return State(link.state(), link.state_received_at()); });
  }

  // The latest base_state_t of the instance's run (<NAME>_BASE), waiting up to
  // `timeout` s for the first; RuntimeError when none comes (a fixed base publishes none).
  BaseState GetBaseState(const std::string& name, double timeout) {
    CheckTimeout(timeout);
    const base_state_t base = ReadLatest(name, timeout, [&](DaemonLink& link) {
      if (!link.PumpUntil([&] { return link.base_state() != nullptr; }, timeout)) {
        throw std::runtime_error("no base state from instance '" + Escape(name, 64) + "' on " +
                                 Escape(options_.Channel(name, kBaseSuffix), 80) + " within " + FormatDouble(timeout) +
                                 " s (run " + RunIdText(link.run_id()) +
                                 "): only a floating base (plant floating_base: true) publishes one");
      }
      return *link.base_state();
    });
    BaseState out(base.t, BaseStateValues(base).data());
    out.utime = base.utime;
    out.run_id = base.run_id;
    out.tick = base.tick;
    return out;
  }

  // The states one Client.states iterator has not taken yet: each iterator
  // has its own, so two iterators of one instance (two threads, or one that
  // replaces another) each get every state, and one that goes takes only its own.
  struct StateQueue {
    std::deque<State> states;
    std::int64_t dropped = 0;  // beyond kMaxQueuedStates, the oldest
  };

  // The next state of `name` from the queue the iterator fills; nullopt once
  // `until` passes. Waits in slices of kSignalSliceS, looking for a signal
  // (Ctrl-C) between them, so a daemon that went quiet does not hold the
  // notebook for the rest of the duration.
  std::optional<State> NextState(const std::string& name, StateQueue& queue,
                                 std::chrono::steady_clock::time_point until) {
    for (;;) {
      std::optional<State> s;
      bool over = false;
      {
        py::gil_scoped_release release;
        try {
          Link& link = LinkFor(name, options_.wait);
          std::lock_guard lock(link.mutex);
          const auto now = std::chrono::steady_clock::now();
          const auto slice_end = std::min(until, now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                           std::chrono::duration<double>(kSignalSliceS)));
          link.link->PumpUntil([&] { return !queue.states.empty(); },
                               std::chrono::duration<double>(slice_end - now).count());
          link.link->RequireOneRun("refusing to act");
          if (!queue.states.empty()) {
            s = std::move(queue.states.front());
            queue.states.pop_front();
          }
          over = std::chrono::steady_clock::now() >= until;
        } catch (...) {
          Rethrow();
        }
      }
      if (s || over) return s;
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    }
  }
  static constexpr double kSignalSliceS = 0.05;  // s between two looks for a signal while no state comes

  // A new queue of every state of `name` from now on (Client.states).
  std::shared_ptr<StateQueue> StartQueue(const std::string& name) {
    py::gil_scoped_release release;
    try {
      Link& link = LinkFor(name, options_.wait);
      std::lock_guard lock(link.mutex);
      CatchUp(*link.link);  // states from now on, not those the socket kept since the last call
      auto queue = std::make_shared<StateQueue>();
      link.queues.push_back(queue);
      link.queueing = static_cast<int>(link.queues.size());
      return queue;
    } catch (...) {
      Rethrow();
    }
  }
  void StopQueue(const std::string& name, const std::shared_ptr<StateQueue>& queue) {
    if (Link* link = Find(name)) {
      py::gil_scoped_release release;
      std::lock_guard lock(link->mutex);
      std::erase(link->queues, queue);
      link->queueing = static_cast<int>(link->queues.size());
    }
  }
  std::int64_t states_dropped(const std::string& name, const StateQueue& queue) {
    Link* link = Find(name);
    if (link == nullptr) return 0;
    py::gil_scoped_release release;
    std::lock_guard lock(link->mutex);
    return queue.dropped;
  }

  bool SendSetpoint(const std::string& name, const py::object& q, const py::object& qd, const py::object& qdd) {
    const int n = NumDofs(name);
    setpoint_t msg;
    msg.num_dofs = n;
    const VectorXd vq = JointVector(q, n, "q");
    const VectorXd vqd = qd.is_none() ? VectorXd::Zero(n) : JointVector(qd, n, "qd");
    const VectorXd vqdd = qdd.is_none() ? VectorXd::Zero(n) : JointVector(qdd, n, "qdd");
    msg.q.assign(vq.data(), vq.data() + n);
    msg.qd.assign(vqd.data(), vqd.data() + n);
    msg.qdd.assign(vqdd.data(), vqdd.data() + n);
    py::gil_scoped_release release;
    Link& link = *Find(name);  // opened by NumDofs
    const std::unique_lock lock = LockToAct(link);
    msg.utime = MonotonicClock().WallMicros();
    return link.link->bus().PublishMessage(options_.Channel(name, kSetpointSuffix), msg);
  }

  // One torque_t of this client's stream: its run id, the sequence from 1,
  // state_tick the latest state's (or the one given). Refused, unsent, while
  // the instance's latest state says it runs another controller than its
  // external one (lagranged would count the torque rejected, with the same
  // reason); a Verdict accepted once the datagram went out.
  Verdict SendTorque(const std::string& name, const py::object& tau, const std::optional<std::int64_t>& state_tick,
                     const std::optional<std::string>& channel) {
    const int n = NumDofs(name);
    const VectorXd v = JointVector(tau, n, "tau");
    if (channel) {
      if (const std::string why = CheckChannelName(*channel); !why.empty()) throw py::value_error("channel: " + why);
    }
    py::gil_scoped_release release;
    Link& link = *Find(name);  // opened by NumDofs
    const std::unique_lock lock = LockToAct(link);
    const std::int64_t run = link.link->run_id();
    if (const std::string& active = link.link->state().controller; active != ToString(ControllerType::kExternal)) {
      return {false, "refused: " + NotRunningExternalReason(Escape(active, 64)), run};
    }
    torque_t& msg = link.torque;
    if (msg.run_id == 0) msg.run_id = NewRunId();
    ++msg.sequence;  // grows even when a publish fails: lagranged sees a gap, not a repeat
    msg.state_tick = state_tick.value_or(link.link->state().tick);
    msg.num_dofs = n;
    msg.tau.assign(v.data(), v.data() + n);
    msg.utime = MonotonicClock().WallMicros();
    const std::string on = channel.value_or(options_.Channel(name, kTorqueSuffix));
    if (!link.link->bus().PublishMessage(on, msg)) return {false, "could not send the torque on " + on, run};
    return {true, name + ": torque " + std::to_string(msg.sequence) + " sent on " + on, run};
  }

  Verdict SendCommand(const std::string& name, const std::vector<std::string>& words, const py::object& kp,
                      const py::object& kd) {
    command_t c;
    try {
      c = CommandFromWords(words);
    } catch (...) {
      Rethrow();
    }
    const bool gains = c.command == command_t::SET_GAINS;
    if (gains && (kp.is_none() || kd.is_none())) throw py::value_error("gains: needs both kp and kd");
    if (!gains && (!kp.is_none() || !kd.is_none())) throw py::value_error("kp, kd: only for gains");
    if (c.command == command_t::ESTOP) return Estop(name, c);
    if (gains) {
      // One gain per joint, or per task axis under a task-space controller (GainCount); one value for all.
      const int n = GainCount(LatestState(name));
      for (const auto& [gain, what, out] : {std::tuple{&kp, "kp", &c.kp}, {&kd, "kd", &c.kd}}) {
        const VectorXd v = JointVector(*gain, n, what, true);
        for (int i = 0; i < n; ++i) {
          if (v[i] < 0.0) throw py::value_error(std::string(what) + ": expected gains >= 0, got " + FormatDouble(v[i]));
        }
        out->assign(v.data(), v.data() + n);
      }
      c.num_gains = n;
    }
    py::gil_scoped_release release;
    try {
      Link& link = LinkFor(name, options_.wait);
      std::lock_guard lock(link.mutex);
      CatchUp(*link.link);
      return Of(lagrange::RunCommand(*link.link, name, CommandWordsText(words), c));
    } catch (...) {
      Rethrow();
    }
  }

  const LinkOptions& options() const { return options_; }

 private:
  // One instance's link and what the client keeps beside it, under its own
  // mutex (a call and the receive thread take turns). Never erased.
  struct Link {
    std::mutex mutex;
    std::unique_ptr<DaemonLink> link;
    std::vector<std::shared_ptr<StateQueue>> queues;  // Client.states: one per live iterator, each every state
    std::atomic<int> queueing{0};  // queues.size(): iterators handle the link, the receive thread leaves it alone
    torque_t torque{};  // this client's torque stream to the instance
  };

  // Handles every datagram already waiting, so the link's latest state is
  // the latest sent. Bounded, for a flood. Under the link's mutex.
  static void CatchUp(DaemonLink& link) {
    for (int k = 0; k < 64 && link.bus().Drain() > 0; ++k) {
    }
  }

  // lagrangectl --wait's rule (CheckWait, protocol/client.hpp).
  static void CheckTimeout(double timeout) {
    if (const std::string why = CheckWait(timeout); !why.empty()) throw py::value_error("timeout: " + why);
  }

  // `link` locked for sending, once it is known to follow one lagranged run
  // (RequireOneRun's refusal raised as the Python error).
  static std::unique_lock<std::mutex> LockToAct(Link& link) {
    std::unique_lock lock(link.mutex);
    try {
      link.link->RequireOneRun("refusing to act");
    } catch (...) {
      Rethrow();
    }
    return lock;
  }

  Link* Find(const std::string& name) {
    std::lock_guard lock(links_mutex_);
    const auto it = links_.find(name);
    return it == links_.end() ? nullptr : it->second.get();
  }

  // The link to `name`'s one lagranged run, opened and awaited (up to `wait` s) on first use.
  Link& LinkFor(const std::string& name, double wait) {
    if (Link* link = Find(name)) return *link;
    // Every channel of the instance is a valid LCM channel name, or the name is the caller's mistake.
    if (name.empty()) throw py::value_error("name: expected an instance name (as in the scene), got ''");
    if (const std::string why = CheckChannelName(options_.Channel(name, kTelemetrySuffix)); !why.empty()) {
      throw py::value_error("name '" + Escape(name, 64) + "': its channel " + why.substr(0, why.find(", got")) +
                            ", got " + Escape(options_.Channel(name, kTelemetrySuffix), 80));
    }
    LinkOptions o = options_;
    o.wait = wait;
    auto link = std::make_unique<Link>();
    link->link = std::make_unique<DaemonLink>(o, name);
    link->link->AwaitOneRun();  // throws: no state, or two runs
    Link* raw = link.get();
    raw->link->ObserveStates([raw](const state_t& s, std::chrono::steady_clock::time_point at) {
      for (const std::shared_ptr<StateQueue>& queue : raw->queues) {
        if (queue->states.size() >= kMaxQueuedStates) {
          queue->states.pop_front();
          ++queue->dropped;
        }
        queue->states.emplace_back(s, at);
      }
    });
    std::lock_guard lock(links_mutex_);
    Link& out = *links_.try_emplace(name, std::move(link)).first->second;  // another thread's, if it came first
    if (!receiver_.joinable()) receiver_ = std::thread([this] { Receive(); });
    return out;
  }

  state_t LatestState(const std::string& name) {
    return ReadLatest(name, options_.wait, [](DaemonLink& link) { return link.state(); });
  }

  // What `read` takes from `name`'s link (opened on first use, waiting up to `wait` s), caught up to the latest
  // datagram (not the one the link last handled) and checked to follow one lagranged run; without the GIL, so
  // `read` touches no Python object; C++ errors raised as Python's.
  template <typename Read>
  std::invoke_result_t<Read&, DaemonLink&> ReadLatest(const std::string& name, double wait, Read read) {
    py::gil_scoped_release release;
    try {
      Link& link = LinkFor(name, wait);
      std::lock_guard lock(link.mutex);
      CatchUp(*link.link);
      link.link->RequireOneRun("refusing to act");
      return read(*link.link);
    } catch (...) {
      Rethrow();
    }
  }

  // The instance's joint count: its link's (a run's num_dofs does not change), opened on first use.
  int NumDofs(const std::string& name) {
    if (Link* link = Find(name)) {
      py::gil_scoped_release release;  // a states() iterator may hold the link while it waits
      std::lock_guard lock(link->mutex);
      return link->link->state().num_dofs;
    }
    return LatestState(name).num_dofs;
  }

  Verdict Estop(const std::string& name, command_t& c) {
    py::gil_scoped_release release;
    try {
      // Every run publishing the state (not only the one this client follows): a link of its own.
      DaemonLink link(options_, name);
      return Of(RunEstop(link, name, c));
    } catch (...) {
      Rethrow();
    }
  }

  // A command's report as Python's Verdict: its whole text, as lagrangectl command shows it.
  static Verdict Of(const CommandReport& report) { return {report.accepted, report.Text(), report.run_id}; }

  // Between calls, a thread of the client's own handles what arrives on
  // every link, so that the latest state is the latest sent however long
  // Python waited between two calls, and no reply is lost to a receive
  // buffer that filled up meanwhile. It waits for data holding no lock, and
  // passes over a link a call is using (the call handles it).
  void Receive() {
    std::vector<pollfd> fds;
    std::vector<Link*> links;
    while (!stop_) {
      fds.clear();
      links.clear();
      {
        std::lock_guard lock(links_mutex_);
        for (const auto& [name, link] : links_) {
          if (link->queueing > 0) continue;  // its iterator's thread reads it, without a second reader waking per datagram
          links.push_back(link.get());
          fds.push_back({link->link->bus().fd(), POLLIN, 0});
        }
      }
      poll(fds.data(), fds.size(), kReceivePollMs);
      for (Link* link : links) {
        std::unique_lock lock(link->mutex, std::try_to_lock);
        if (!lock.owns_lock()) continue;
        try {
          link->link->bus().Drain();
        } catch (...) {  // (out of memory queueing a state) the next call's own pumping will say so
        }
      }
    }
  }
  static constexpr int kReceivePollMs = 20;  // how soon the thread sees stop_ and a new link

  LinkOptions options_;
  std::mutex links_mutex_;  // links_ itself; each link has its own
  std::map<std::string, std::unique_ptr<Link>> links_;
  std::atomic<bool> stop_{false};
  std::thread receiver_;  // Receive, from the first link on
};

// Client.states(name, duration): every state as it arrives, for `duration` seconds, from a queue of its own.
class StateIterator {
 public:
  StateIterator(std::shared_ptr<Client> client, std::string name, double duration)
      : client_(std::move(client)), name_(std::move(name)), queue_(client_->StartQueue(name_)) {
    // Beyond kForever s, no end (a double of nanoseconds past about 292 years does not convert to the clock's).
    using Clock = std::chrono::steady_clock;
    until_ = duration > kForever
                 ? Clock::time_point::max()
                 : Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(duration));
  }
  static constexpr double kForever = 1e9;  // s (32 years)
  ~StateIterator() { client_->StopQueue(name_, queue_); }
  State Next() {
    std::optional<State> s = client_->NextState(name_, *queue_, until_);
    if (!s) throw py::stop_iteration();
    return std::move(*s);
  }
  std::int64_t dropped() const { return client_->states_dropped(name_, *queue_); }

 private:
  std::shared_ptr<Client> client_;
  std::string name_;
  std::shared_ptr<Client::StateQueue> queue_;
  std::chrono::steady_clock::time_point until_;
};

// read_log: one channel's records while reading (one typed buffer per
// field: 8 bytes a number), and as Python sees them (columns as numpy arrays).
struct LogColumn {
  std::vector<std::int64_t> ints;  // kInt, kId
  std::vector<double> reals;       // kReal
  std::vector<std::string> texts;  // kText
};
struct LogChannelRows {
  std::string channel;
  std::optional<std::string> type;  // "state_t", ...; None for a type that is not lagrange's
  std::int64_t rows = 0;
  std::int64_t skipped = 0;  // did not decode, or another num_dofs than the channel's first message
  std::vector<LogField> fields;
  std::vector<LogColumn> columns;  // by field: rows × max(width, 1) values

  void Add(const LogRow& row) {
    std::size_t v = 0;
    for (std::size_t k = 0; k < fields.size(); ++k) {
      for (int i = 0; i < std::max(fields[k].width, 1); ++i, ++v) {
        switch (fields[k].kind) {
          case LogFieldKind::kInt:
          case LogFieldKind::kId: columns[k].ints.push_back(std::get<std::int64_t>(row.values[v])); break;
          case LogFieldKind::kReal: columns[k].reals.push_back(std::get<double>(row.values[v])); break;
          case LogFieldKind::kText: columns[k].texts.push_back(std::get<std::string>(row.values[v])); break;
        }
      }
    }
    ++rows;
  }
};
struct LogChannel {
  std::string channel;
  std::optional<std::string> type;
  std::int64_t rows = 0;
  std::int64_t skipped = 0;
  py::dict columns;  // field name → array
};

py::object ColumnArray(const LogField& field, const LogColumn& column, std::int64_t rows) {
  std::vector<py::ssize_t> shape = {static_cast<py::ssize_t>(rows)};
  if (field.width > 0) shape.push_back(field.width);
  switch (field.kind) {
    case LogFieldKind::kInt:
    case LogFieldKind::kId: {
      py::array_t<std::int64_t> a(shape);
      std::copy(column.ints.begin(), column.ints.end(), a.mutable_data());
      return a;
    }
    case LogFieldKind::kReal: {
      py::array_t<double> a(shape);
      std::copy(column.reals.begin(), column.reals.end(), a.mutable_data());
      return a;
    }
    case LogFieldKind::kText: {
      py::list texts;
      for (const std::string& t : column.texts) texts.append(Text(t));
      return texts;
    }
  }
  return py::none();
}

py::dict ReadLog(const py::object& path_arg, const std::optional<std::string>& channel_regex, bool partial) {
  const std::string path = FsPath(path_arg, "path");
  std::map<std::string, LogChannelRows> channels;
  {
    py::gil_scoped_release release;
    try {
      ReadLogRecords(path, channel_regex.value_or(""), [&](const LogRecord& r) {
        LogChannelRows& c = channels[std::string(r.channel)];
        c.channel = r.channel;
        if (r.fields == nullptr) {  // not lagrange's
          ++c.skipped;
          return;
        }
        c.type = ToString(r.type);
        if (r.row == nullptr) {
          ++c.skipped;
          return;
        }
        if (c.fields.empty()) {
          c.fields = *r.fields;
          c.columns.resize(c.fields.size());
        }
        c.Add(*r.row);
      });
    } catch (const LcmLogCutShortError& e) {
      // Every whole event before the cut was read: with `partial` that is the log (one still being written).
      if (!partial) throw py::value_error(ValidUtf8(e.what()));
    } catch (const LcmLogError& e) {
      py::gil_scoped_acquire acquire;
      std::error_code ec;
      if (!std::filesystem::exists(path, ec)) {
        PyErr_SetString(PyExc_FileNotFoundError, ValidUtf8(e.what()).c_str());
        throw py::error_already_set();
      }
      throw py::value_error(ValidUtf8(e.what()));
    } catch (const std::regex_error& e) {
      throw py::value_error("channel: not a regular expression: '" + channel_regex.value_or("") + "' (" + e.what() +
                            ")");
    }
  }
  py::dict out;
  for (const auto& [name, c] : channels) {
    // A channel name is whatever bytes came on the bus: one that is not UTF-8 is keyed and named with them as
    // \xHH, as the client's messages show it (a str cannot hold it, and one such channel would fail the read).
    const std::string channel = ValidUtf8(name);
    LogChannel record{channel, c.type, c.rows, c.skipped, py::dict()};
    for (std::size_t k = 0; k < c.fields.size(); ++k) {
      record.columns[py::str(c.fields[k].name)] = ColumnArray(c.fields[k], c.columns[k], c.rows);
    }
    out[py::str(channel)] = py::cast(std::move(record));
  }
  return out;
}

}  // namespace

void BindBus(py::module_& m) {
  py::class_<State>(m, "State", "One state_t of an instance, as lagranged published it (SI units; arrays shape (n,)).")
      .def_readonly("utime", &State::utime, "Wall clock of the tick, µs since the epoch.")
      .def_readonly("run_id", &State::run_id, "The lagranged run that published it.")
      .def_readonly("tick", &State::tick, "Tick number (consecutive: a gap is a lost message).")
      .def_readonly("t", &State::t, "Simulated time, s.")
      .def_readonly("num_dofs", &State::num_dofs)
      .def_property_readonly(
          "q", [](const State& s) { return ToArray(s.q); }, "Positions, rad or m.")
      .def_property_readonly(
          "qd", [](const State& s) { return ToArray(s.qd); }, "Velocities.")
      .def_property_readonly(
          "qdd", [](const State& s) { return ToArray(s.qdd); }, "Accelerations.")
      .def_property_readonly(
          "tau", [](const State& s) { return ToArray(s.tau); },
          "Applied generalized force (after limits and saturation), N·m or N.")
      .def_property_readonly(
          "q_des", [](const State& s) { return ToArray(s.q_des); }, "Setpoint positions.")
      .def_property_readonly(
          "qd_des", [](const State& s) { return ToArray(s.qd_des); }, "Setpoint velocities.")
      .def_readonly("kinetic_energy", &State::kinetic_energy, "T, J.")
      .def_readonly("potential_energy", &State::potential_energy, "V, J.")
      .def_property_readonly(
          "controller", [](const State& s) { return Text(s.controller); }, "The active controller (escaped).")
      .def_readonly("mode", &State::mode, "running, hold, fault, paused, estop, stopped or waiting.")
      .def_readonly("received", &State::received, "When this client received it, s on time.monotonic()'s clock.")
      .def("__repr__", [](const State& s) {
        return "<lagrange.State tick " + std::to_string(s.tick) + " t = " + FormatDouble(s.t) + " s, " + s.mode + ">";
      });

  py::class_<Verdict>(m, "Verdict",
                      "lagranged's verdict on a command (its reply_t to this command's request id); or\n"
                      "send_torque's outcome (accepted: sent; refused: not sent, in lagranged's words).")
      .def_readonly("accepted", &Verdict::accepted)
      .def_property_readonly(
          "message", [](const Verdict& v) { return Text(v.message); },
          "As lagrangectl command reports it: 'arm: pause done; now paused with pd' or 'refused: REASON'.")
      .def_readonly("run_id", &Verdict::run_id, "The run that answered (0: several, for an estop).")
      .def("__bool__", [](const Verdict& v) { return v.accepted; })
      .def("__repr__", [](const Verdict& v) { return Text("<lagrange.Verdict " + v.message + ">"); });

  py::class_<StateIterator>(m, "StateIterator", "Every state of one instance as it arrives, for a duration.")
      .def("__iter__", [](StateIterator& it) -> StateIterator& { return it; })
      .def("__next__", &StateIterator::Next)
      .def_property_readonly("dropped", &StateIterator::dropped,
                             "States this iterator dropped because more than 100000 waited unread.");

  py::class_<Client, std::shared_ptr<Client>>(m, "Client",
                                              R"(A client of lagranged on the bus: lagrangectl's own client code.

Client(url=None, prefix="", key_file=None, wait=3.0, bus_domain=None)
  url         LCM URL, udpm://GROUP:PORT?ttl=N (None: $LCM_DEFAULT_URL, else udpm://239.255.76.67:7667?ttl=0)
  prefix      the daemon's --channel-prefix
  key_file    the daemon's --bus-key: sign what is sent, believe only what the key signed
              (None: $LAGRANGE_BUS_KEY_FILE, else unsigned; "" is refused)
  wait        s to wait for an instance's first state (and for a verdict)
  bus_domain  the daemon's --bus-domain, what signatures are bound to
              (None: $LAGRANGE_BUS_DOMAIN, else the bus's own, udpm://GROUP:PORT)
Each instance is followed through one lagranged run: its first state is awaited, then 0.3 s
more, and a second run publishing the same state refuses every action (RuntimeError naming
both ids), except the emergency stop, which goes to every run. Waits release the GIL.
Raises ValueError for a malformed URL, an unusable key file or domain, RuntimeError when no daemon
answers, with lagrangectl's one-line messages.)")
      .def(py::init<std::optional<std::string>, std::string, std::optional<std::string>, double,
                    std::optional<std::string>>(),
           py::arg("url") = py::none(), py::arg("prefix") = "", py::arg("key_file") = py::none(), py::arg("wait") = 3.0,
           py::arg("bus_domain") = py::none())
      .def("state", &Client::GetState, py::arg("name"), py::arg("timeout") = 3.0,
           "The instance's latest state. The first call waits up to timeout s for it (RuntimeError if none).")
      .def("base_state", &Client::GetBaseState, py::arg("name"), py::arg("timeout") = 3.0,
           "The latest base_state_t of the instance's run on <NAME>_BASE (a BaseState: a floating base's pose,\n"
           "twist, centre of mass and momentum; its tick is the State's it goes with). Waits up to timeout s\n"
           "for the first (RuntimeError if none: a fixed base publishes none).")
      .def(
          "states",
          [](const std::shared_ptr<Client>& c, const std::string& name, double duration) {
            if (!(std::isfinite(duration) && duration >= 0.0)) {
              throw py::value_error("duration: expected a number of seconds >= 0, got " + FormatDouble(duration));
            }
            return std::make_unique<StateIterator>(c, name, duration);
          },
          py::arg("name"), py::arg("duration"),
          "Every state of the instance as it arrives, for duration s (an iterator of State).")
      .def("send_setpoint", &Client::SendSetpoint, py::arg("name"), py::arg("q"), py::arg("qd") = py::none(),
           py::arg("qdd") = py::none(),
           "One joint setpoint (setpoint_t: q, and qd, qdd default zeros; shape (n,)) on <PREFIX><NAME>_SETPOINT.\n"
           "Returns whether it was sent; lagranged's counts (status) say whether it was accepted.")
      .def("send_torque", &Client::SendTorque, py::arg("name"), py::arg("tau"), py::arg("state_tick") = py::none(),
           py::arg("channel") = py::none(),
           "One torque (torque_t, N·m or N, shape (n,)) for an instance under `controller: external`, on\n"
           "<PREFIX><NAME>_TORQUE (or channel): this client's stream (its own run id, sequence from 1),\n"
           "state_tick the latest state's tick unless given. Returns a Verdict: accepted once sent\n"
           "('arm: torque 12 sent on ARM_TORQUE'; lagranged's status counts say whether it applied it);\n"
           "refused, and nothing sent, while the instance runs another controller, in lagranged's words\n"
           "('refused: the instance is not running its external controller (active: pd)').")
      .def(
          "command",
          [](Client& c, const std::string& name, const std::string& kind, const py::args& args, const py::object& kp,
             const py::object& kd) {
            std::vector<std::string> words = {kind};
            for (const py::handle& a : args) words.push_back(py::str(a));
            return c.SendCommand(name, words, kp, kd);
          },
          py::arg("name"), py::arg("kind"), py::arg("kp") = py::none(), py::arg("kd") = py::none(),
          R"(Command an instance and return lagranged's verdict (Verdict: accepted, message).

kind and its words as lagrangectl command takes them: command("arm", "estop"),
command("arm", "controller", "pd"), command("arm", "effect", "damping", "on"),
command("arm", "gains", kp=[200, 150], kd=30) (one value for every joint, or one per joint).
A refusal is a Verdict with accepted False; no verdict within wait is RuntimeError; a word
that is not a command is ValueError. An estop goes to every run publishing the state.)")
      .def_property_readonly("url", [](const Client& c) { return c.options().Url(); })
      .def_property_readonly("prefix", [](const Client& c) { return c.options().channel_prefix; });

  py::class_<LogChannel>(m, "LogChannel", R"(One channel of an lcm-logger file, decoded as log2csv decodes it.

Its columns are log2csv's: log_utime (µs, when the logger received it), then the message's
fields; an array field is one (rows, n) array (log2csv's columns q0, q1, ..). Integers and ids
are int64 arrays, numbers float64, text a list of str (escaped as in the CSV).)")
      .def_readonly("channel", &LogChannel::channel)
      .def_readonly("type", &LogChannel::type,
                    "The LCM type (\"state_t\", ...), None for a type that is not lagrange's.")
      .def_readonly("rows", &LogChannel::rows)
      .def_readonly("skipped", &LogChannel::skipped,
                    "Messages not decoded: undecodable, another num_dofs, or (type None) not lagrange's.")
      .def_readonly("columns", &LogChannel::columns, "{field name: array or list}, in the message's order.")
      .def("__getattr__",
           [](const LogChannel& c, const std::string& name) -> py::object {
             if (c.columns.contains(name)) return c.columns[py::str(name)];
             throw py::attribute_error("channel " + c.channel + " has no field '" + name + "'");
           })
      .def("__getitem__",
           [](const LogChannel& c, const std::string& name) -> py::object {
             if (c.columns.contains(name)) return c.columns[py::str(name)];
             throw py::key_error(name);
           })
      .def("__len__", [](const LogChannel& c) { return c.rows; })
      .def("__repr__", [](const LogChannel& c) {
        return "<lagrange.LogChannel " + c.channel + ": " + std::to_string(c.rows) + " rows of " +
               c.type.value_or("an unknown type") + ">";
      });

  m.def("read_log", &ReadLog, py::arg("path"), py::arg("channel") = py::none(), py::kw_only(),
        py::arg("partial") = false,
        R"doc(Decode an lcm-logger file: {channel: LogChannel}, the same decoding as lagrangectl log2csv.

channel  only channels matching this regular expression (all when None)
partial  True: a log cut short (a logger stopped, or one still writing) is read to its
         last whole event; False (the default): it raises ValueError, as log2csv refuses it
Every record is wire-checked before it is decoded (a recorded packet is as untrusted as a
live one); signed traffic is decoded without checking its signature. Raises FileNotFoundError
or ValueError with log2csv's one-line messages: a file that is not a regular file ("cannot read
PATH: not a regular file (a FIFO)": nothing waits for a writer), not a log ("PATH is not an LCM
log ..."), or a log cut short or corrupt, naming the event's byte offset ("PATH: cut short inside
the event at byte 1234: it declares a 2147483647-byte payload, of which the file holds 8").)doc");
}

}  // namespace lagrange::python
