#pragma once
// The client side of talking to a daemon: where to find it (LinkOptions),
// and a link to one lagranged run that trusts nothing it has not seen
// consistently (DaemonLink). lagrangectl's live commands use it, as the
// Python module and the viewer are to.
//
// The bus is hostile: anyone on it can publish an instance's state, the
// status or a reply. So every packet is size-checked before it is decoded
// (protocol/wire.hpp), every string is escaped before it is printed, and a
// command or setpoint stream acts only when exactly one lagranged run (one
// run_id) publishes the instance's state; success is reported only from a
// reply of that run carrying the sender's own request_id. The one exception
// is the emergency stop, which is never withheld: it goes to every run
// publishing the state (AwaitRuns), and each run's verdict is its own reply.

#include <lagrange/base_state_t.hpp>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "protocol/bus.hpp"
#include "protocol/observer.hpp"

namespace lagrange {

// The longest a client waits for a daemon, a state or a verdict
// (LinkOptions::wait: lagrangectl --wait, Python's Client(wait=) and
// Client.state(timeout=)): a day. More is a slip (1e9 s is 32 years) that
// would hold the caller for good, as inf or nan would.
inline constexpr double kMaxWaitSeconds = 86400.0;
// "" when `seconds` is a wait a client takes (in (0, kMaxWaitSeconds]), else
// what was expected, the end of the option's or argument's message:
// "expected a positive number of seconds up to 86400 (a day), got 1e+09"
// (`shown`, when given, is what the user typed, in place of the number).
std::string CheckWait(double seconds, std::string_view shown = {});

// Where a client finds a daemon, and how long it waits for one.
struct LinkOptions {
  std::string lcm_url;         // "" → $LCM_DEFAULT_URL → udpm://239.255.76.67:7667?ttl=0
  std::string channel_prefix;  // as given to lagranged --channel-prefix
  double wait = 3.0;           // s to wait for the daemon before giving up (CheckWait)
  // The key file: none → $LAGRANGE_BUS_KEY_FILE → unsigned; an empty path is refused (ResolveBusKeyFile).
  std::optional<std::string> bus_key_file;
  // The bus domain: none → $LAGRANGE_BUS_DOMAIN → the bus's own (ResolveBusDomain, BusDomainOf).
  std::optional<std::string> bus_domain;

  // lcm_url resolved (ResolveLcmUrl, protocol/channels.hpp).
  std::string Url() const;
  // PREFIX + NAME_UPPER + suffix (protocol/channels.hpp).
  std::string Channel(const std::string& instance, const char* suffix) const;
  std::string StatusChannel() const;
  // Opens the bus, signed when a key is given: BusUrlError for a malformed URL
  // (worded by ParseUdpmUrl), BusKeyError for a key file or domain that cannot
  // be used, a BusError when it cannot be opened.
  std::unique_ptr<Bus> Open() const;
};

// What was heard on the bus while a client waited in vain for `instance`'s
// state under `prefix`, as the end of its error: given the channels heard
// (`channels`, at most kMaxHeardChannels), the instance's state under
// another prefix ("a lagranged publishes SIM_ARM_STATE: --channel-prefix
// SIM_?"), the nearest instance name under this prefix ("did you mean
// 'arm'?"), else the state channels heard, else that none was. Names from the
// bus are escaped. An empty `instance`: the wait was for the status (a
// lagranged publishing its status under another prefix is named).
std::string HeardHint(const std::string& prefix, const std::string& instance, const std::set<std::string>& channels);
inline constexpr std::size_t kMaxHeardChannels = 32;

// Messages a client's bus heard but could not believe for their signature,
// by reason: a daemon signing with another key, an unsigned daemon heard by a
// client with a key, a signed one heard by a client without. Counted from when
// the client opened its bus (SigningCensus).
struct SigningHeard {
  std::int64_t other_key = 0;          // with a key: tags that do not verify (another key, or a forger's)
  std::int64_t unsigned_refused = 0;   // with a key: messages without a signature
  std::int64_t out_of_window = 0;      // with a key: stamps more than 2 s from this clock, or replayed
  std::int64_t signed_unreadable = 0;  // without a key: signed messages, which it cannot check
  std::int64_t old_format = 0;         // with a key: signed in the format before bus domains (LGS1)
  std::string domain;                  // with a key: the bus domain the client's tags are bound to
};
// What they say, one clause per reason heard, for the end of a client's error
// ("heard 812 messages signed with another key or for another bus domain
// ...: give the daemon's key ... and bus domain ..."); "" when none was heard.
std::string SigningHint(const SigningHeard& heard);
// What was heard while a client waited in vain, in one place for every client
// (lagrangectl's commands and watch, the Python module): SigningHint when any
// message was dropped for its signature (it explains why nothing else came),
// else HeardHint.
std::string WhatWasHeard(const SigningHeard& signing, const std::string& prefix, const std::string& instance,
                         const std::set<std::string>& channels);

// Keeps a SigningHeard for one bus: subscribes to every channel (before the
// bus is shared) and reads the bus's refusal counts by reason.
class SigningCensus {
 public:
  explicit SigningCensus(Bus& bus);
  SigningCensus(const SigningCensus&) = delete;
  SigningCensus& operator=(const SigningCensus&) = delete;
  SigningHeard heard() const;

 private:
  Bus& bus_;
  BusStats at_start_;
  std::int64_t signed_unreadable_ = 0;
};

// How long a client listens to an instance before acting, so that a second
// run publishing on the same channel (two daemons, or a spoofer) shows.
inline constexpr double kRunWindow = 0.3;  // s after the first state
// A daemon publishes every instance's state each tick (1 kHz) and its status
// at 10 Hz: when a status has been heard and this long has passed without the
// instance's state, it is not coming (a mistyped instance, a forgotten
// --channel-prefix), and the client says so without waiting out --wait.
inline constexpr double kNoStateGrace = 0.5;  // s
// An emergency stop is sent again this often until every run answered: under
// a flood the kernel may drop a datagram before lagranged reads it, and a
// repeated estop is applied once (it is latest-wins).
inline constexpr std::chrono::milliseconds kEstopResend{20};
// After an applied estop a client watches the run's states this long, and
// says so when the estop did not stay (EstopDidNotStay): a clear_estop from
// another sender, on an unsigned bus anyone's, or a daemon without the
// estop_dwell rule. Shorter than the default dwell (0.5 s), so a deliberate
// clear after it is never taken for one.
inline constexpr double kEstopWatch = 0.2;  // s after the verdict

// Whether a state's mode keeps an applied estop: estop itself, an external
// plant that commands nothing (stopped, or waiting, its estop still latched)
// or a faulted instance (frozen; the estop stays latched through a fault).
// Running, hold and paused mean it was cleared.
bool KeepsEstop(std::int8_t mode);

// Distinct run ids a DaemonLink keeps per channel: enough to name two in an
// error, bounded so a spoofer cycling ids costs nothing. The runs it chose
// (AwaitOneRun, AwaitRuns) are never forgotten; the others are the most
// recently heard (LatestByRun).
inline constexpr std::size_t kMaxLinkRuns = 4;

// Listens to one instance's state, task and reply channels and the status
// channel on the caller's thread: the state, task state and status of each run
// id are kept by a BusObserver (protocol/observer.hpp) that follows the
// instance, the runs it chose pinned there; the replies to its own request are
// its own.
class DaemonLink {
 public:
  // Opens the bus (options.Open(): BusUrlError, BusError) and subscribes.
  // std::invalid_argument ("wait: " + CheckWait's reason) for a wait it refuses.
  DaemonLink(const LinkOptions& options, const std::string& instance);
  DaemonLink(const DaemonLink&) = delete;
  DaemonLink& operator=(const DaemonLink&) = delete;

  Bus& bus() { return *bus_; }
  const LinkOptions& options() const { return options_; }

  // Waits up to options.wait for the instance's first state (or kNoStateGrace
  // once a daemon's status is heard without it), listens kRunWindow longer, and
  // returns the one run id that published it. Throws a one-line error when none
  // came, or "two lagranged runs publish X (ids A and B):
  // refusing to act" when several did.
  std::int64_t AwaitOneRun();
  // Waits as AwaitOneRun does but refuses nothing: every run id that published
  // the instance's state (at most kMaxLinkRuns), in increasing order; replies are
  // then collected from each (reply(run)). Throws only when none came.
  std::vector<std::int64_t> AwaitRuns();
  // Throws the two-runs error if a second run has published the instance's
  // state since; `doing` ends the message ("refusing to act").
  void RequireOneRun(const std::string& doing) const;
  std::int64_t run_id() const { return run_id_; }

  // The latest state of the run (after AwaitOneRun), and how many came.
  const state_t& state() const;
  std::int64_t states_received() const;
  // When the run's latest state arrived, on the steady clock.
  std::chrono::steady_clock::time_point state_received_at() const;

  // The run's latest task state (<NAME>_TASK: the frame a task-space
  // controller moves), once one came after the run was chosen (else null), and
  // how many came since.
  const task_state_t* task_state() const;
  std::int64_t task_states_received() const;

  // The run's latest base state (<NAME>_BASE: a floating base's pose, twist and
  // momentum, the tick of the state it goes with in its tick), once one came
  // (else null: none yet, or a fixed base, which publishes none).
  const base_state_t* base_state() const;

  // Waits up to options.wait for a status from the run; throws a one-line error.
  const status_t& AwaitStatus();
  // The run's latest status, once one came after the run was chosen (else
  // null), and how many came since.
  const status_t* status() const;
  std::int64_t statuses_received() const;

  // Collects replies carrying `request_id` from now on.
  void ExpectReply(std::int64_t request_id);
  // The run's reply to the expected request, once it came.
  const std::optional<reply_t>& reply() const { return reply(run_id_); }
  // Run `run`'s reply to the expected request, once it came (AwaitRuns).
  const std::optional<reply_t>& reply(std::int64_t run) const;
  // The runs whose states are kept, in increasing order: the runs chosen
  // and, up to kMaxLinkRuns in all, those heard most recently.
  std::vector<std::int64_t> runs() const;
  // Run `run`'s latest state and when it arrived (a run runs() lists; else
  // std::out_of_range).
  const state_t& state(std::int64_t run) const { return Kept(run).message; }
  std::chrono::steady_clock::time_point state_received_at(std::int64_t run) const { return Kept(run).received; }

  // A command and its verdict. After AwaitOneRun: sends `command` (its
  // request_id and utime set here) once to the instance's command channel (a
  // repeat could apply twice) and returns the run's reply to it. Throws "no
  // verdict from lagranged (run X) within W s" after options.wait, the
  // two-runs error ("refusing to trust the verdict"), or "could not send the
  // command on CHANNEL".
  reply_t Command(command_t& command);
  // The emergency stop, never withheld. After AwaitRuns: sends `command` to
  // every run publishing the state, again every kEstopResend until every run
  // answered or options.wait passed. Each run's reply by run id (none: no
  // verdict in time).
  std::map<std::int64_t, std::optional<reply_t>> Estop(command_t& command);

  // "MODE with CONTROLLER" from run `run`'s first state after now (the tick
  // applied a command before its reply went out), or its latest after 0.5 s.
  std::string ModeAfterReply(std::int64_t run);

  // After run `run` applied an estop: watches every state it publishes for
  // kEstopWatch and returns "" when each one kept the estop (KeepsEstop),
  // else why the estop did not stay, one line: "the estop did not stay: hold
  // with pd 0.001 s after it was applied (a clear_estop from another sender?
  // an estop lasts the scene's estop_dwell on a lagranged that has it)".
  std::string EstopDidNotStay(std::int64_t run);

  // Called with every state of the chosen run (after AwaitOneRun) as it is
  // handled, and when it arrived: for a client that needs each one, not only
  // the latest (lagrange.Client.states).
  using StateObserver = std::function<void(const state_t&, std::chrono::steady_clock::time_point)>;
  void ObserveStates(StateObserver observer) { state_observer_ = std::move(observer); }

  // Handles messages for `seconds`.
  void Pump(double seconds);
  // Handles messages until `done` holds or `seconds` pass; returns whether it held.
  template <class Predicate>
  bool PumpUntil(Predicate done, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!done()) {
      const auto now = std::chrono::steady_clock::now();
      if (now >= end) return false;
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - now).count();
      bus_->Handle(static_cast<int>(std::min<std::int64_t>(left, 10)));
    }
    return true;
  }

 private:
  void OnState(const state_t& state);  // before the observer keeps it
  void OnReply(reply_t&& reply);
  void OnAny(std::string_view channel);
  void SendCommand(command_t& command);
  std::string TwoRunsMessage(const std::string& doing) const;
  // Waits up to options.wait for the instance's first state (else throws),
  // then kRunWindow longer.
  void AwaitFirstState();
  // Keeps `runs` for good (pinned in the observer); the first is run_id().
  void Choose(const std::vector<std::int64_t>& runs);
  const LatestByRun<state_t>& states() const { return seen_->states; }
  const LatestByRun<state_t>::Entry& Kept(std::int64_t run) const;

  LinkOptions options_;
  std::string instance_;
  std::string state_channel_;
  std::unique_ptr<Bus> bus_;
  SigningCensus signing_;               // what was dropped, or could not be checked, for its signature
  BusObserver observer_;                // the instance's states and task states, the statuses; kMaxLinkRuns per channel
  const ObservedInstance* seen_ = nullptr;  // the instance in observer_
  std::set<std::string> heard_;             // channels heard before the first state, for HeardHint
  std::int64_t run_id_ = 0;             // chosen by AwaitOneRun
  bool have_run_ = false;
  std::int64_t statuses_before_ = 0;     // the run's statuses counted when it was chosen (status())
  std::int64_t task_states_before_ = 0;  // and its task states (task_state())
  std::int64_t request_id_ = 0;
  std::map<std::int64_t, std::optional<reply_t>> replies_;  // to request_id_, by run: runs whose states are kept
  bool every_run_ = false;            // AwaitRuns: replies from every run whose states are kept count
  std::int64_t estop_watch_run_ = 0;  // EstopDidNotStay: the run whose states are checked (0: none)
  std::optional<state_t> estop_left_;  // its first state that did not keep the estop
  StateObserver state_observer_;       // ObserveStates
};

}  // namespace lagrange
