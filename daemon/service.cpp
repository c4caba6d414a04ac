#include "daemon/service.hpp"

#include <pthread.h>
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <future>
#include <iostream>
#include <optional>
#include <thread>
#include <utility>
#include <variant>

#include "daemon/log_file.hpp"
#include "daemon/loop.hpp"
#include "daemon/mpc_worker.hpp"
#include "daemon/publisher.hpp"
#include "daemon/realtime.hpp"
#include "daemon/receiver.hpp"
#include "daemon/runtime.hpp"
#include "daemon/timing_csv.hpp"
#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "protocol/ids.hpp"
#include "protocol/signing.hpp"
#include "protocol/status.hpp"
#include "sim/default_scene.hpp"
#include "sim/instance_model.hpp"
#include "sim/scene.hpp"
#include "sim/work_bound.hpp"
#include "sim/yaml_reader.hpp"

namespace lagrange {
namespace {

// The receive buffer lagranged asks for on the buses it reads, unless the URL
// names one (recv_buf_size): under a 140 k/s flood of refused datagrams on the
// two-process loop, the default (net.core.rmem_default, 208 KiB on Debian)
// overflowed and dropped up to 9 % of the real states and torques in the
// flood's seconds; 2 MiB dropped none (bench/flood_bench, README "Floods").
constexpr int kDaemonReceiveBuffer = 2 * 1024 * 1024;

// A warning when a bus's kernel granted less receive buffer than its URL asked
// (SO_RCVBUF reports twice the bytes granted).
void WarnSmallReceiveBuffer(const Bus* bus, const std::string& url) {
  if (bus == nullptr || url.rfind("udpm://", 0) != 0) return;
  const int asked = ParseUdpmUrl(url).recv_buf_size;
  const int granted = bus->receive_buffer_bytes() / 2;
  if (asked <= 0 || granted <= 0 || granted >= asked) return;
  spdlog::warn(
      "LCM receive buffer: the kernel granted {} KiB of the {} KiB asked (net.core.rmem_max caps it): a flood on the "
      "bus can overflow it and drop real setpoints, torques and states. As root: sysctl -w net.core.rmem_max={} "
      "(README, \"Floods\")",
      granted / 1024, asked / 1024, asked);
}

struct Options {
  std::string config = DefaultScenePath();
  std::string lcm_url;
  std::string input_lcm_url;
  std::string channel_prefix;
  std::string log_file;
  std::string log_level = "info";
  std::string overrun = "skip";
  std::string setpoint_age = "wall";
  int max_catch_up = 5;
  double duration = 0.0;  // s of ticks, then exit; 0: until a signal
  RealtimeOptions rt;
  double spin_us = 0.0;
  bool require_rt = false;
  std::string timing_csv;  // per-tick wake latency and compute, written off the publish path
  std::optional<std::string> bus_key;     // --bus-key; else $LAGRANGE_BUS_KEY_FILE; else the scene's bus.key_file
  std::optional<std::string> bus_domain;  // --bus-domain; else $LAGRANGE_BUS_DOMAIN; else the scene's; else the URL's
};

// --log-file: the rotating log and its start-up record (daemon/log_file.hpp); null without the option.
struct LogFiles {
  std::shared_ptr<LogFileSink> log;
  std::shared_ptr<LogFileSink> start;
};
constexpr std::size_t kLogFileSize = 5 * 1024 * 1024;
constexpr int kLogFilesKept = 3;

// Throws LogFileError when a log file cannot be opened.
LogFiles SetUpLogging(const Options& o) {
  LogFiles files;
  std::vector<spdlog::sink_ptr> sinks{std::make_shared<spdlog::sinks::stderr_color_sink_mt>()};
  if (!o.log_file.empty()) {
    files.log = std::make_shared<LogFileSink>(o.log_file, LogFileSink::Mode::kAppend, kLogFileSize, kLogFilesKept);
    files.start = std::make_shared<LogFileSink>(o.log_file + ".start", LogFileSink::Mode::kTruncate);
    sinks.push_back(files.log);
    sinks.push_back(files.start);
  }
  auto logger = std::make_shared<spdlog::logger>("lagranged", sinks.begin(), sinks.end());
  logger->set_level(spdlog::level::from_str(o.log_level));
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
  spdlog::flush_every(std::chrono::seconds(1));  // a thread of spdlog's; signals stay blocked in it
  return files;
}

// Signals the main thread takes with sigtimedwait; blocked in every thread.
//   SIGINT, SIGTERM  stop: the final status is logged, exit 0
//   SIGHUP           reopen the log file (after logrotate renamed it)
sigset_t HandledSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&signals, s);
  return signals;
}

// Signals whose default action would end the daemon and that mean nothing to
// it: SIGPIPE (stderr or a log pipe closed by the reader: the write fails
// with EPIPE instead), SIGXFSZ (a log file at the file size limit: the write
// fails with EFBIG instead, and the lines are counted as lost), SIGUSR1,
// SIGUSR2, SIGALRM.
void IgnoreStraySignals() {
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  for (int s : {SIGPIPE, SIGXFSZ, SIGUSR1, SIGUSR2, SIGALRM}) sigaction(s, &ignore, nullptr);
}

// Why the log file could not take the lines logged so far ("" when it could,
// or there is none): flushed first, so a full disk or a size limit shows now.
std::string LogFileProblem(const LogFiles& logs) {
  if (!logs.log) return "";
  spdlog::default_logger()->flush();
  for (const auto& file : {logs.log, logs.start}) {
    if (const std::string why = file->write_error(); !why.empty()) {
      return "--log-file '" + file->path() + "': cannot write: " + why;
    }
  }
  return "";
}

// SIGHUP: the log file by its name again, announced in the new file.
void ReopenLogFile(const LogFiles& logs) {
  if (!logs.log) {
    spdlog::info("SIGHUP: no --log-file to reopen");
    return;
  }
  if (const std::string why = logs.log->Reopen(); !why.empty()) {
    spdlog::warn("SIGHUP: cannot reopen {}: {}; still writing the old file", logs.log->path(), why);
  } else {
    spdlog::info("log file {} reopened (SIGHUP)", logs.log->path());
  }
  spdlog::default_logger()->flush();
}

// The real-time set-up's problems in one line, "; " between them.
std::string Joined(const std::vector<std::string>& problems) {
  std::string all;
  for (const std::string& p : problems) all += (all.empty() ? "" : "; ") + p;
  return all;
}

// Logs a thread's real-time outcome at debug; a refusal is warned about once per process.
void ReportThreadRealtime(const char* thread, const std::vector<std::string>& problems, std::atomic<bool>& warned) {
  if (problems.empty()) {
    spdlog::debug("real-time: {} thread runs {}", thread, DescribeThisThreadScheduling());
    return;
  }
  const std::string all = Joined(problems);
  spdlog::debug("real-time: {} thread: {}", thread, all);
  if (!warned.exchange(true)) spdlog::warn("real-time set-up not permitted, continuing without it: {}", all);
}

// Everything the loop needs that takes time, built and checked before it
// starts: the scene, the work bound, the run's model and the tick's data.
struct Prepared {
  Scene scene;
  std::shared_ptr<const DaemonModel> model;
  std::unique_ptr<Runtime> runtime;
};

// Prepared, or the exit status of a refusal (logged).
std::variant<int, Prepared> Prepare(const Options& o) {
  Prepared p;
  try {
    p.scene = LoadScene(o.config);
  } catch (const ConfigError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  const Scene& scene = p.scene;
  // The run's model, built once, with each method's measured cost: a tick
  // must end within the period whatever the scene does, and the run-time
  // integrator and method commands are held to the same bound
  // (sim/work_bound.hpp).
  try {
    BuildOptions options;
    options.channel_prefix = o.channel_prefix;
    const std::shared_ptr<DaemonModel> model = BuildDaemonModel(scene, options);
    MeasureCosts(*model);
    p.model = model;
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", o.config, e.what());
    return 2;
  }
  for (const WorkBound& b : WorkBoundsOf(*p.model)) {
    spdlog::debug("work bound: {}: worst case {} evaluations × {:.3g} µs + {:.3g} µs = {:.4g} ms per tick", b.instance,
                  b.evaluations, b.evaluation_s * 1e6, b.overhead_s * 1e6, b.tick_s() * 1e3);
  }
  if (const auto refusal = CheckWorkBounds(*p.model)) {
    spdlog::error("{}", *refusal);
    return 2;
  }
  try {
    p.runtime = std::make_unique<Runtime>(p.model);
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", o.config, e.what());
    return 2;
  }
  std::vector<std::string> names;
  std::vector<std::int32_t> dofs;
  std::vector<InstanceChannelNames> channels;
  for (const InstanceModel& m : p.model->instances) {
    names.push_back(m.name());
    dofs.push_back(m.num_dofs);
    channels.push_back(m.channels);
  }
  if (!StatusFits(names, dofs, {})) {
    spdlog::error(
        "{}: {} instances: a status_t listing them would not fit one datagram; split the scene across "
        "daemons (--channel-prefix)",
        o.config, names.size());
    return 2;
  }
  if (const std::string why = CheckChannelNames(channels, p.model->status_channel); !why.empty()) {
    spdlog::error("{}: {}", o.config, why);
    return 2;
  }
  return p;
}

// Runs `work` on a thread of its own while this thread keeps answering the
// handled signals, so that start-up, however long a scene makes it, never
// delays a stop: SIGINT or SIGTERM ends the process at once (exit 0, the
// line logged), SIGHUP reopens the log file.
template <class Work>
void WhileAnsweringSignals(const LogFiles& logs, Work&& work) {
  std::atomic<bool> done{false};
  std::exception_ptr failure;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      failure = std::current_exception();
    }
    done.store(true, std::memory_order_release);
  });
  const sigset_t signals = HandledSignals();
  while (!done.load(std::memory_order_acquire)) {
    const timespec wait{0, 20'000'000};
    const int got = sigtimedwait(&signals, nullptr, &wait);
    if (got == SIGHUP) {
      ReopenLogFile(logs);
    } else if (got > 0) {
      spdlog::info("stopped by signal {} during start-up", got);
      spdlog::default_logger()->flush();
      std::_Exit(0);  // the start-up thread may be mid-computation: nothing to hand over, nothing to join
    }
  }
  worker.join();
  if (failure) std::rethrow_exception(failure);
}

// The buses of a run. Outputs (state, status, replies) go to --lcm-url; inputs
// (setpoints, commands) come from --input-lcm-url, the same bus unless given.
// The receive thread also listens on the output bus for another publisher of
// this run's channels. Each bus object is used by one thread per direction.
struct Buses {
  std::string url;                 // outputs
  std::string input_url;           // inputs
  std::string in_url, listen_url;  // the two it reads, as opened: asking kDaemonReceiveBuffer unless they name a size
  std::string key_file;            // the bus key's file ("": unsigned)
  std::optional<BusKey> key;
  std::unique_ptr<Bus> out, in, replies, listen;  // listen: only when the inputs have a bus of their own
};

// Fills `b` (in place: the buses sign with its key); false when the key or a bus is refused (logged).
bool OpenBuses(const Options& o, const Scene& scene, Buses& b) {
  b.url = ResolveLcmUrl(o.lcm_url);
  b.input_url = o.input_lcm_url.empty() ? b.url : o.input_lcm_url;
  // Signed traffic: with a key every bus signs what it sends and takes only what verifies.
  // An empty --bus-key (an unset variable) is refused, never read as "unsigned".
  std::string domain;
  try {
    b.key_file = ResolveBusKeyFile(o.bus_key);
    if (b.key_file.empty()) b.key_file = scene.bus_key_file;
    domain = ResolveBusDomain(o.bus_domain);
    if (domain.empty()) domain = scene.bus_domain;  // still "": each bus its own (udpm://GROUP:PORT)
    if (!b.key_file.empty()) b.key = BusKey::FromFile(b.key_file);
  } catch (const BusKeyError& e) {
    spdlog::error("{}", e.what());
    return false;
  }
  const BusKey* signing = b.key ? &*b.key : nullptr;
  b.in_url = WithDefaultReceiveBuffer(b.input_url, kDaemonReceiveBuffer);
  b.listen_url = WithDefaultReceiveBuffer(b.url, kDaemonReceiveBuffer);
  try {
    b.out = OpenBus(b.url, signing, domain);
    b.in = OpenBus(b.in_url, signing, domain);
    b.replies = OpenBus(b.url, signing, domain);
    if (b.input_url != b.url) b.listen = OpenBus(b.listen_url, signing, domain);
  } catch (const BusError& e) {
    spdlog::error("{}", e.what());
    return false;
  }
  return true;
}

// A run's threads' parts over its buses: the tick's loop on its clock, the
// receive and publish sides, meeting at the ring and the counters, and the
// eventfd by which the loop wakes the publisher.
struct Service {
  Service(const Options& o, const Scene& scene, Runtime& runtime, const Buses& buses, std::int64_t run_id)
      : notify_fd(eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)),
        clock(static_cast<Nanoseconds>(o.spin_us * 1e3)),
        ring(1024, runtime.MakeRecord()),
        loop(runtime, clock,
             {ToNanoseconds(scene.period), o.overrun == "catch-up" ? OverrunPolicy::kCatchUp : OverrunPolicy::kSkip,
              o.max_catch_up},
             ring, notify_fd),
        receiver(*buses.in, buses.listen ? buses.listen.get() : buses.in.get(), *buses.replies, runtime, clock, stats,
                 o.setpoint_age == "stream" ? SetpointAge::kStream : SetpointAge::kWall, run_id),
        publisher(*buses.out, runtime, ring, loop, stats, notify_fd, run_id),
        mpc(MakeMpcWorkers(runtime)) {}
  ~Service() { close(notify_fd); }
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  const int notify_fd;
  MonotonicClock clock;
  SpscRing<TickRecord> ring;
  Loop loop;
  ReceiverStats stats;
  Receiver receiver;
  Publisher publisher;
  TimingCsvWriter timing;
  std::vector<std::unique_ptr<MpcWorker>> mpc;  // one optimiser thread per mpc controller (lagranged-mpc)
};

// --timing-csv: its writer started and handed to the publisher; false when the file cannot be written (logged).
bool StartTimingCsv(const Options& o, Service& s) {
  if (o.timing_csv.empty()) return true;
  if (!s.timing.Open(o.timing_csv)) {
    spdlog::error("--timing-csv: cannot write {}", o.timing_csv);
    return false;
  }
  s.timing.Start();
  s.publisher.SetTimingWriter(&s.timing);
  return true;
}

// The start-up lines: the scene, the buses and the run; whether the bus is signed; each instance.
void LogStartup(const Options& o, const Scene& scene, const DaemonModel& model, const Buses& b, std::int64_t run_id) {
  spdlog::info("scene {} ({}), {} instance(s) at {} Hz, LCM {}{}, run id {:016x}", o.config, scene.description,
               model.instances.size(), 1.0 / scene.period, b.url,
               b.input_url != b.url ? " (inputs from " + b.input_url + ")" : "", static_cast<std::uint64_t>(run_id));
  if (b.key) {
    spdlog::info(
        "bus signed with the key in {}, domain {}{}: unsigned, forged, replayed, stale and other domains' messages are "
        "dropped and counted",
        b.key_file, b.out->domain(), b.in->domain() != b.out->domain() ? " (inputs: " + b.in->domain() + ")" : "");
  } else {
    spdlog::info(
        "bus unsigned: anyone who can send to {} can command these instances (--bus-key FILE signs it; README, "
        "\"Signed traffic\")",
        b.input_url);
  }
  for (const InstanceModel& m : model.instances) {
    const InstanceChannelNames& c = m.channels;
    const std::string plant = m.external_plant() ? "external plant, model "
                              : m.config.mujoco ? "MuJoCo plant " + m.config.mujoco->file + " (" +
                                                      std::string(ToString(m.config.mujoco->integrator)) + "), model "
                                                : "";
    spdlog::info("  {}: {}{} with {}, {} / {} / {}{}{}", m.name(), plant, ToString(m.config.plant.type()), m.controllers.front().name, c.state, c.setpoint, c.command,
                 c.torque_in.empty() ? "" : ", torques from " + c.torque_in,
                 m.external_plant() ? ", measured state from " + c.measured_in + ", torque to " + c.torque_out : "");
  }
}

// Starts the tick thread (lagranged-tick): it applies the real-time set-up to
// itself and hands back what was refused (in `refused`, before this returns),
// then runs the loop once `go` is true; on false it returns at once.
std::thread StartTickThread(const Options& o, Loop& loop, const std::atomic<bool>& stop, std::int64_t max_ticks,
                            std::future<bool> go, std::vector<std::string>& refused) {
  std::promise<std::vector<std::string>> applied;
  auto result = applied.get_future();
  std::thread tick([&o, &loop, &stop, max_ticks, go = std::move(go), applied = std::move(applied)]() mutable {
    applied.set_value(ApplyToThisThread(o.rt));
    if (!go.get()) return;
    loop.Run(stop, max_ticks);
  });
  pthread_setname_np(tick.native_handle(), "lagranged-tick");
  refused = result.get();
  if (refused.empty()) {
    spdlog::debug("real-time: tick thread runs {}{}",
                  o.rt.priority > 0 ? fmt::format("SCHED_FIFO {}", o.rt.priority) : "SCHED_OTHER (no --rt-priority)",
                  o.rt.cpu >= 0 ? fmt::format(" on CPU {}", o.rt.cpu) : "");
  }
  return tick;
}

// Whether the loop may run on the real-time set-up's outcome (memory and the
// tick thread): what was refused is warned about once, or with --require-rt
// refuses the run (logged).
bool RealtimeAccepted(const Options& o, const std::vector<std::string>& problems) {
  if (problems.empty()) return true;
  const std::string all = Joined(problems);
  if (o.require_rt) {
    spdlog::error("--require-rt: real-time set-up not permitted: {}", all);
    return false;
  }
  spdlog::warn("real-time set-up not permitted, continuing without it: {}", all);  // once
  return true;
}

// The receive and publish threads (lagranged-recv, lagranged-pub), each at its priority below the tick's.
std::pair<std::thread, std::thread> StartIoThreads(Service& s, const ThreadPriorities& priorities,
                                                   const std::atomic<bool>& stop, std::atomic<bool>& rt_warned) {
  std::thread receive([&s, &stop, &rt_warned, priority = priorities.receive] {
    ReportThreadRealtime("receive", SetThisThreadPriority(priority), rt_warned);
    s.receiver.Run(stop);
  });
  std::thread publish([&s, &stop, &rt_warned, priority = priorities.publish] {
    ReportThreadRealtime("publish", SetThisThreadPriority(priority), rt_warned);
    s.publisher.Run(stop);
  });
  pthread_setname_np(receive.native_handle(), "lagranged-recv");
  pthread_setname_np(publish.native_handle(), "lagranged-pub");
  return {std::move(receive), std::move(publish)};
}

// Waits for SIGINT or SIGTERM (its number returned), reopening the log on
// SIGHUP, or until --duration's ticks have run (0 returned).
int WaitForStop(const LogFiles& logs, const Loop& loop, std::int64_t max_ticks) {
  const sigset_t signals = HandledSignals();
  while (max_ticks < 0 || loop.ticks() < max_ticks) {
    const timespec wait{0, 20'000'000};
    const int got = sigtimedwait(&signals, nullptr, &wait);
    if (got == SIGHUP) {
      ReopenLogFile(logs);
    } else if (got > 0) {
      return got;
    }
  }
  return 0;
}

// The final status, and what --log-file could not take.
void LogStopped(const LogFiles& logs, const Service& s, int signal_number) {
  spdlog::info("stopped{} after {} ticks: {} overruns, {} state messages published, {} records dropped",
               signal_number > 0 ? fmt::format(" by signal {}", signal_number) : std::string(), s.loop.ticks(),
               s.loop.overruns(), s.publisher.states_published(), s.loop.records_dropped());
  if (logs.log && logs.log->lines_lost() > 0) {
    spdlog::warn("--log-file '{}': {} line(s) could not be written ({})", logs.log->path(), logs.log->lines_lost(),
                 logs.log->write_error().empty() ? "it can be again" : logs.log->write_error());
  }
  spdlog::default_logger()->flush();
}

// The run's threads, from the real-time set-up to the last record: 0, or 3
// when --require-rt refuses the set-up. `rt_problems`: what locking memory refused.
int RunThreads(const Options& o, const LogFiles& logs, const Scene& scene, Service& s,
               std::vector<std::string> rt_problems) {
  std::atomic<bool> stop_loop{false}, stop_io{false};
  const std::int64_t max_ticks = o.duration > 0.0 ? std::llround(o.duration / scene.period) : -1;
  spdlog::debug("real-time: memory {}", !o.rt.lock_memory     ? "not locked (no --mlockall)"
                                        : rt_problems.empty() ? "locked (mlockall)"
                                                              : rt_problems.front());
  std::promise<bool> run_loop;  // false: --require-rt refused, the tick thread returns
  std::vector<std::string> tick_problems;
  std::thread tick = StartTickThread(o, s.loop, stop_loop, max_ticks, run_loop.get_future(), tick_problems);
  for (std::string& p : tick_problems) rt_problems.push_back(std::move(p));
  if (!RealtimeAccepted(o, rt_problems)) {
    run_loop.set_value(false);
    tick.join();
    return 3;
  }
  run_loop.set_value(true);
  std::atomic<bool> rt_warned{!rt_problems.empty()};
  auto [receive, publish] = StartIoThreads(s, PrioritiesBelow(o.rt.priority), stop_io, rt_warned);
  for (const std::unique_ptr<MpcWorker>& w : s.mpc) w->Start();  // at the default policy: below every loop thread
  if (logs.start) logs.start->Close();  // the start-up record ends here (daemon/log_file.hpp)

  const int signal_number = WaitForStop(logs, s.loop, max_ticks);
  for (const std::unique_ptr<MpcWorker>& w : s.mpc) w->Stop();  // within one DDP iteration
  stop_loop = true;
  tick.join();
  stop_io = true;
  receive.join();
  publish.join();
  s.publisher.Drain();  // the last records and a final status
  s.timing.Stop();      // writes what the publisher offered
  LogStopped(logs, s, signal_number);
  return 0;
}

// One run: the scene prepared (signals answered meanwhile), its buses, the
// threads' parts and the start-up lines, then the threads; the exit status.
int Serve(const Options& o, const LogFiles& logs) {
  std::variant<int, Prepared> prepared = 2;
  WhileAnsweringSignals(logs, [&] { prepared = Prepare(o); });
  if (const int* refused = std::get_if<int>(&prepared)) return *refused;
  Prepared& ready = std::get<Prepared>(prepared);
  Buses buses;
  if (!OpenBuses(o, ready.scene, buses)) return 2;
  const std::int64_t run_id = NewRunId();

  std::vector<std::string> rt_problems = LockMemory(o.rt);
  Service service(o, ready.scene, *ready.runtime, buses, run_id);
  WarnSmallReceiveBuffer(buses.in.get(), buses.in_url);
  WarnSmallReceiveBuffer(buses.listen.get(), buses.listen_url);
  if (!StartTimingCsv(o, service)) return 2;
  LogStartup(o, ready.scene, *ready.model, buses, run_id);
  // The start-up lines must have reached --log-file: a log that loses them would lose every later one too.
  if (const std::string why = LogFileProblem(logs); !why.empty()) {
    spdlog::error("lagranged: {}", why);
    return 2;
  }
  return RunThreads(o, logs, ready.scene, service, std::move(rt_problems));
}

// --config and the buses: what runs and where it talks.
void AddSceneAndBusOptions(CLI::App& app, Options& o) {
  app.add_option("--config", o.config, "Scene file")->capture_default_str();
  app.add_option("--lcm-url", o.lcm_url,
                 "LCM URL (default: $LCM_DEFAULT_URL, else " + std::string(kDefaultLcmUrl) + ")");
  app.add_option("--input-lcm-url", o.input_lcm_url,
                 "Bus for setpoints and commands, when it should differ from --lcm-url (outputs): a flood of input "
                 "traffic then never reaches the loggers of the state stream");
  app.add_option("--channel-prefix", o.channel_prefix, "Prepended to every channel name");
  app.add_option("--bus-key", o.bus_key,
                 "Sign and check every message with the shared key in FILE (readable by its owner only; "
                 "lagrangectl keygen FILE makes one); default: $LAGRANGE_BUS_KEY_FILE, else the scene's "
                 "bus.key_file");
  app.add_option("--bus-domain", o.bus_domain,
                 "Bind signatures to this domain (every program on the bus gives the same); default: "
                 "$LAGRANGE_BUS_DOMAIN, else the scene's bus.domain, else the bus's own (udpm://GROUP:PORT)");
}

// --log-file, --log-level.
void AddLogOptions(CLI::App& app, Options& o) {
  app.add_option("--log-file", o.log_file,
                 "Also log to this file (rotating: 5 MiB x 3; reopened on SIGHUP; flushed every second); the latest "
                 "start's start-up lines are also kept in FILE.start, never rotated");
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
}

// How the loop keeps time: overruns, setpoints' age, --duration.
void AddLoopOptions(CLI::App& app, Options& o) {
  app.add_option("--overrun", o.overrun, "Missed deadlines: skip them (count only) or catch-up (run late ticks)")
      ->check(CLI::IsMember({"skip", "catch-up"}))
      ->capture_default_str();
  app.add_option("--max-catch-up", o.max_catch_up, "Most extra ticks run to catch up after one late wake")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  app.add_option("--setpoint-age", o.setpoint_age,
                 "How a setpoint's age is judged: wall (now - utime; clocks in step) or stream (its delay within "
                 "the stream; any clock offset, e.g. replaying a log with lcm-logplayer)")
      ->check(CLI::IsMember({"wall", "stream"}))
      ->capture_default_str();
  app.add_option("--duration", o.duration, "Stop after this many seconds of ticks (default: run until signalled)")
      ->check(CLI::NonNegativeNumber);
}

// The real-time set-up and its check (--timing-csv).
void AddRealtimeOptions(CLI::App& app, Options& o) {
  app.add_flag("--mlockall", o.rt.lock_memory, "Lock the process's memory (mlockall)");
  app.add_option("--rt-priority", o.rt.priority,
                 "SCHED_FIFO priority P of the tick thread (1-99); the publish thread runs at P-1 and the receive "
                 "thread at P-2 (at least 1); other threads stay SCHED_OTHER")
      ->check(CLI::Range(1, 99));
  app.add_option("--cpu", o.rt.cpu, "Pin the tick thread to this CPU")->check(CLI::NonNegativeNumber);
  app.add_option("--spin-us", o.spin_us, "Busy-wait this long before each deadline instead of sleeping")
      ->check(CLI::Range(0.0, 1000.0));
  app.add_flag("--require-rt", o.require_rt, "Exit (status 3) if real-time set-up is not permitted");
  app.add_option("--timing-csv", o.timing_csv,
                 "Write every tick's wake-up latency and compute time (ns) to this CSV, to check a real-time "
                 "set-up tick by tick (written by a thread of its own; a slow disk drops rows, never ticks)");
}

// lagranged's command line, its options in the order --help lists them, read into `o`.
void DescribeCommandLine(CLI::App& app, Options& o) {
  app.name("lagranged");
  app.set_version_flag("--version", std::string("lagranged ") + LAGRANGE_VERSION);
  app.footer(
      "Signals: SIGINT and SIGTERM stop it (exit 0, final status logged); SIGHUP reopens --log-file; SIGPIPE, "
      "SIGXFSZ, SIGUSR1, SIGUSR2 and SIGALRM are ignored.");
  AddSceneAndBusOptions(app, o);
  AddLogOptions(app, o);
  AddLoopOptions(app, o);
  AddRealtimeOptions(app, o);
}

// The exit status when the command line ends the run (--help, --version: 0; an error: 2, said); nothing to go on.
std::optional<int> ParseCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return 0;
  } catch (const CLI::CallForVersion& e) {
    std::cout << e.what() << "\n";
    return 0;
  } catch (const CLI::ParseError& e) {
    std::cerr << "lagranged: " << e.what() << "\n";
    return 2;
  }
  return std::nullopt;
}

// Serve, with what escapes it logged: 2 for a bus that cannot be opened, 1 for anything else.
int ServeLoggingErrors(const Options& o, const LogFiles& logs) {
  try {
    return Serve(o, logs);
  } catch (const BusError& e) {  // a bad --lcm-url, or the bus could not be opened: named before the loop
    spdlog::error("lagranged: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace

int RunLagranged(int argc, char** argv) {
  // Before any thread starts: stray signals ignored, the handled ones blocked (the main thread waits for them).
  IgnoreStraySignals();
  const sigset_t signals = HandledSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  Options o;
  CLI::App app{"lagranged: simulates and controls the plants of a scene at a fixed rate, over LCM"};
  DescribeCommandLine(app, o);
  if (const std::optional<int> status = ParseCommandLine(app, argc, argv)) return *status;
  LogFiles logs;
  try {
    logs = SetUpLogging(o);
  } catch (const LogFileError& e) {
    std::cerr << "lagranged: " << e.what() << "\n";
    return 2;
  }
  return ServeLoggingErrors(o, logs);
}

}  // namespace lagrange
