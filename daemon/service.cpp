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
#include <variant>

#include "daemon/log_file.hpp"
#include "daemon/loop.hpp"
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

// Logs a thread's real-time outcome at debug; a refusal is warned about once per process.
void ReportThreadRealtime(const char* thread, const std::vector<std::string>& problems, std::atomic<bool>& warned) {
  if (problems.empty()) {
    spdlog::debug("real-time: {} thread runs {}", thread, DescribeThisThreadScheduling());
    return;
  }
  std::string all;
  for (const std::string& p : problems) all += (all.empty() ? "" : "; ") + p;
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

int Serve(const Options& o, const LogFiles& logs) {
  std::variant<int, Prepared> prepared = 2;
  WhileAnsweringSignals(logs, [&] { prepared = Prepare(o); });
  if (const int* refused = std::get_if<int>(&prepared)) return *refused;
  Prepared& ready = std::get<Prepared>(prepared);
  const Scene& scene = ready.scene;
  const std::shared_ptr<const DaemonModel>& model = ready.model;
  std::unique_ptr<Runtime>& runtime = ready.runtime;
  std::vector<std::string> names;
  for (const InstanceModel& m : model->instances) names.push_back(m.name());
  // Outputs (state, status, replies) go to --lcm-url; inputs (setpoints,
  // commands) come from --input-lcm-url, the same bus unless given. The
  // receive thread also listens on the output bus for another publisher of
  // this run's channels. Each bus object is used by one thread per direction.
  const std::string url = ResolveLcmUrl(o.lcm_url);
  const std::string input_url = o.input_lcm_url.empty() ? url : o.input_lcm_url;
  // Signed traffic: with a key every bus signs what it sends and takes only what verifies.
  // An empty --bus-key (an unset variable) is refused, never read as "unsigned".
  std::string key_file, domain;
  std::optional<BusKey> key;
  try {
    key_file = ResolveBusKeyFile(o.bus_key);
    if (key_file.empty()) key_file = scene.bus_key_file;
    domain = ResolveBusDomain(o.bus_domain);
    if (domain.empty()) domain = scene.bus_domain;  // still "": each bus its own (udpm://GROUP:PORT)
    if (!key_file.empty()) key = BusKey::FromFile(key_file);
  } catch (const BusKeyError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  const BusKey* signing = key ? &*key : nullptr;
  std::unique_ptr<Bus> bus_out, bus_in, bus_replies, bus_listen;
  // The buses it reads ask for kDaemonReceiveBuffer unless their URL names a size.
  const std::string in_url = WithDefaultReceiveBuffer(input_url, kDaemonReceiveBuffer);
  const std::string listen_url = WithDefaultReceiveBuffer(url, kDaemonReceiveBuffer);
  try {
    bus_out = OpenBus(url, signing, domain);
    bus_in = OpenBus(in_url, signing, domain);
    bus_replies = OpenBus(url, signing, domain);
    if (input_url != url) bus_listen = OpenBus(listen_url, signing, domain);
  } catch (const BusError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  const std::int64_t run_id = NewRunId();

  std::vector<std::string> rt_problems = LockMemory(o.rt);
  const int notify_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  MonotonicClock clock(static_cast<Nanoseconds>(o.spin_us * 1e3));
  SpscRing<TickRecord> ring(1024, runtime->MakeRecord());
  const LoopTimerOptions timer{ToNanoseconds(scene.period),
                               o.overrun == "catch-up" ? OverrunPolicy::kCatchUp : OverrunPolicy::kSkip,
                               o.max_catch_up};
  Loop loop(*runtime, clock, timer, ring, notify_fd);
  ReceiverStats stats;
  Receiver receiver(*bus_in, bus_listen ? bus_listen.get() : bus_in.get(), *bus_replies, *runtime, clock, stats,
                    o.setpoint_age == "stream" ? SetpointAge::kStream : SetpointAge::kWall, run_id);
  Publisher publisher(*bus_out, *runtime, ring, loop, stats, notify_fd, run_id);
  WarnSmallReceiveBuffer(bus_in.get(), in_url);
  WarnSmallReceiveBuffer(bus_listen.get(), listen_url);
  TimingCsvWriter timing;
  if (!o.timing_csv.empty()) {
    if (!timing.Open(o.timing_csv)) {
      spdlog::error("--timing-csv: cannot write {}", o.timing_csv);
      close(notify_fd);
      return 2;
    }
    timing.Start();
    publisher.SetTimingWriter(&timing);
  }

  spdlog::info("scene {} ({}), {} instance(s) at {} Hz, LCM {}{}, run id {:016x}", o.config, scene.description,
               names.size(), 1.0 / scene.period, url, input_url != url ? " (inputs from " + input_url + ")" : "",
               static_cast<std::uint64_t>(run_id));
  if (key) {
    spdlog::info(
        "bus signed with the key in {}, domain {}{}: unsigned, forged, replayed, stale and other domains' messages are "
        "dropped and counted",
        key_file, bus_out->domain(), bus_in->domain() != bus_out->domain() ? " (inputs: " + bus_in->domain() + ")" : "");
  } else {
    spdlog::info(
        "bus unsigned: anyone who can send to {} can command these instances (--bus-key FILE signs it; README, "
        "\"Signed traffic\")",
        input_url);
  }
  for (const InstanceModel& m : model->instances) {
    const InstanceChannelNames& c = m.channels;
    const std::string plant = m.external_plant() ? "external plant, model "
                              : m.config.mujoco ? "MuJoCo plant " + m.config.mujoco->file + " (" +
                                                      std::string(ToString(m.config.mujoco->integrator)) + "), model "
                                                : "";
    spdlog::info("  {}: {}{} with {}, {} / {} / {}{}{}", m.name(), plant, ToString(m.config.plant.type()), m.controllers.front().name, c.state, c.setpoint, c.command,
                 c.torque_in.empty() ? "" : ", torques from " + c.torque_in,
                 m.external_plant() ? ", measured state from " + c.measured_in + ", torque to " + c.torque_out : "");
  }

  // The start-up lines must have reached --log-file: a log that loses them would lose every later one too.
  if (const std::string why = LogFileProblem(logs); !why.empty()) {
    spdlog::error("lagranged: {}", why);
    close(notify_fd);
    return 2;
  }

  std::atomic<bool> stop_loop{false}, stop_io{false};
  const std::int64_t max_ticks = o.duration > 0.0 ? std::llround(o.duration / scene.period) : -1;
  // Real-time set-up: the tick thread reports it, then runs the loop only once told to.
  const ThreadPriorities priorities = PrioritiesBelow(o.rt.priority);
  spdlog::debug("real-time: memory {}", !o.rt.lock_memory     ? "not locked (no --mlockall)"
                                        : rt_problems.empty() ? "locked (mlockall)"
                                                              : rt_problems.front());
  std::promise<std::vector<std::string>> rt_result;
  auto rt_future = rt_result.get_future();
  std::promise<bool> run_loop;  // false: --require-rt refused, the tick thread returns
  auto run_loop_future = run_loop.get_future();
  std::thread tick([&] {
    rt_result.set_value(ApplyToThisThread(o.rt));
    if (!run_loop_future.get()) return;
    loop.Run(stop_loop, max_ticks);
  });
  pthread_setname_np(tick.native_handle(), "lagranged-tick");
  std::vector<std::string> tick_problems = rt_future.get();
  if (tick_problems.empty()) {
    spdlog::debug("real-time: tick thread runs {}{}",
                  o.rt.priority > 0 ? fmt::format("SCHED_FIFO {}", o.rt.priority) : "SCHED_OTHER (no --rt-priority)",
                  o.rt.cpu >= 0 ? fmt::format(" on CPU {}", o.rt.cpu) : "");
  }
  for (std::string& p : tick_problems) rt_problems.push_back(std::move(p));
  if (!rt_problems.empty()) {
    std::string all;
    for (const std::string& p : rt_problems) all += (all.empty() ? "" : "; ") + p;
    if (o.require_rt) {
      run_loop.set_value(false);
      tick.join();
      close(notify_fd);
      spdlog::error("--require-rt: real-time set-up not permitted: {}", all);
      return 3;
    }
    spdlog::warn("real-time set-up not permitted, continuing without it: {}", all);  // once
  }
  run_loop.set_value(true);
  std::atomic<bool> rt_warned{!rt_problems.empty()};
  std::thread receive([&] {
    ReportThreadRealtime("receive", SetThisThreadPriority(priorities.receive), rt_warned);
    receiver.Run(stop_io);
  });
  std::thread publish([&] {
    ReportThreadRealtime("publish", SetThisThreadPriority(priorities.publish), rt_warned);
    publisher.Run(stop_io);
  });
  pthread_setname_np(receive.native_handle(), "lagranged-recv");
  pthread_setname_np(publish.native_handle(), "lagranged-pub");
  if (logs.start) logs.start->Close();  // the start-up record ends here (daemon/log_file.hpp)

  // Wait for SIGINT or SIGTERM, reopen the log on SIGHUP, or stop when --duration runs out.
  const sigset_t signals = HandledSignals();
  int signal_number = 0;
  while (max_ticks < 0 || loop.ticks() < max_ticks) {
    const timespec wait{0, 20'000'000};
    const int got = sigtimedwait(&signals, nullptr, &wait);
    if (got == SIGHUP) {
      ReopenLogFile(logs);
    } else if (got > 0) {
      signal_number = got;
      break;
    }
  }
  stop_loop = true;
  tick.join();
  stop_io = true;
  receive.join();
  publish.join();
  publisher.Drain();  // the last records and a final status
  timing.Stop();      // writes what the publisher offered
  close(notify_fd);
  spdlog::info("stopped{} after {} ticks: {} overruns, {} state messages published, {} records dropped",
               signal_number > 0 ? fmt::format(" by signal {}", signal_number) : std::string(), loop.ticks(),
               loop.overruns(), publisher.states_published(), loop.records_dropped());
  if (logs.log && logs.log->lines_lost() > 0) {
    spdlog::warn("--log-file '{}': {} line(s) could not be written ({})", logs.log->path(), logs.log->lines_lost(),
                 logs.log->write_error().empty() ? "it can be again" : logs.log->write_error());
  }
  spdlog::default_logger()->flush();
  return 0;
}

}  // namespace

int RunLagranged(int argc, char** argv) {
  // Before any thread starts: stray signals ignored, the handled ones blocked (the main thread waits for them).
  IgnoreStraySignals();
  const sigset_t signals = HandledSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  Options o;
  CLI::App app{"lagranged: simulates and controls the plants of a scene at a fixed rate, over LCM"};
  app.name("lagranged");
  app.set_version_flag("--version", std::string("lagranged ") + LAGRANGE_VERSION);
  app.footer(
      "Signals: SIGINT and SIGTERM stop it (exit 0, final status logged); SIGHUP reopens --log-file; SIGPIPE, "
      "SIGXFSZ, SIGUSR1, SIGUSR2 and SIGALRM are ignored.");
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
  app.add_option("--log-file", o.log_file,
                 "Also log to this file (rotating: 5 MiB x 3; reopened on SIGHUP; flushed every second); the latest "
                 "start's start-up lines are also kept in FILE.start, never rotated");
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
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
  LogFiles logs;
  try {
    logs = SetUpLogging(o);
  } catch (const LogFileError& e) {
    std::cerr << "lagranged: " << e.what() << "\n";
    return 2;
  }
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

}  // namespace lagrange
