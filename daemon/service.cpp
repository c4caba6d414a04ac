#include "daemon/service.hpp"

#include <signal.h>
#include <spdlog/sinks/rotating_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cmath>
#include <future>
#include <iostream>
#include <thread>

#include "daemon/channels.hpp"
#include "daemon/lcm_bridge.hpp"
#include "daemon/loop.hpp"
#include "daemon/realtime.hpp"
#include "daemon/runtime.hpp"
#include "daemon/scene.hpp"
#include "daemon/yaml_reader.hpp"

namespace lagrange {
namespace {

struct Options {
  std::string config = LAGRANGE_DEFAULT_SCENE;
  std::string lcm_url;
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
  std::string timing_csv;  // bench/: per-tick timing, written by the publish thread
};

void SetUpLogging(const Options& o) {
  std::vector<spdlog::sink_ptr> sinks{std::make_shared<spdlog::sinks::stderr_color_sink_mt>()};
  if (!o.log_file.empty()) {
    sinks.push_back(std::make_shared<spdlog::sinks::rotating_file_sink_mt>(o.log_file, 5 * 1024 * 1024, 3));
  }
  auto logger = std::make_shared<spdlog::logger>("lagranged", sinks.begin(), sinks.end());
  logger->set_level(spdlog::level::from_str(o.log_level));
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
}

int Serve(const Options& o) {
  // Everything the loop needs is built and checked before it starts.
  Scene scene;
  try {
    scene = LoadScene(o.config);
  } catch (const ConfigError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  std::unique_ptr<Runtime> runtime;
  try {
    runtime = std::make_unique<Runtime>(scene);
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", o.config, e.what());
    return 2;
  }
  std::vector<std::string> names;
  for (const auto& inst : scene.instances) names.push_back(inst.name);
  const ChannelNames channels = MakeChannelNames(names, o.channel_prefix);
  const std::string url = ResolveLcmUrl(o.lcm_url);
  lcm::LCM lcm_in(url), lcm_out(url);
  if (!lcm_in.good() || !lcm_out.good()) {
    spdlog::error("cannot open LCM at {}", url);
    return 1;
  }

  std::vector<std::string> rt_problems = LockMemory(o.rt);
  const int notify_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  MonotonicClock clock(static_cast<Nanoseconds>(o.spin_us * 1e3));
  SpscRing<TickRecord> ring(1024, runtime->MakeRecord());
  const LoopTimerOptions timer{static_cast<Nanoseconds>(std::llround(scene.period * 1e9)),
                               o.overrun == "catch-up" ? OverrunPolicy::kCatchUp : OverrunPolicy::kSkip,
                               o.max_catch_up};
  Loop loop(*runtime, clock, timer, ring, notify_fd);
  ReceiverStats stats;
  LcmReceiver receiver(lcm_in, channels, *runtime, clock, stats,
                       o.setpoint_age == "stream" ? SetpointAge::kStream : SetpointAge::kWall);
  LcmPublisher publisher(lcm_out, channels, *runtime, ring, loop, stats, notify_fd);
  if (!o.timing_csv.empty() && !publisher.WriteTimingCsv(o.timing_csv)) {
    spdlog::error("--timing-csv: cannot write {}", o.timing_csv);
    close(notify_fd);
    return 2;
  }

  spdlog::info("scene {} ({}), {} instance(s) at {} Hz, LCM {}", o.config, scene.description, names.size(),
               1.0 / scene.period, url);
  for (std::size_t i = 0; i < names.size(); ++i) {
    spdlog::info("  {}: {} with {}, {} / {} / {}", names[i], ToString(scene.instances[i].plant.type()),
                 runtime->instance(i).controller().name(), channels.state[i], channels.setpoint[i], channels.command[i]);
  }

  std::atomic<bool> stop_loop{false}, stop_io{false};
  const std::int64_t max_ticks = o.duration > 0.0 ? std::llround(o.duration / scene.period) : -1;
  std::promise<std::vector<std::string>> rt_result;
  auto rt_future = rt_result.get_future();
  std::atomic<bool> rt_ok{true};
  std::thread tick([&] {
    rt_result.set_value(ApplyToThisThread(o.rt));
    if (!rt_ok.load()) return;
    loop.Run(stop_loop, max_ticks);
  });
  for (std::string& p : rt_future.get()) rt_problems.push_back(std::move(p));
  if (!rt_problems.empty()) {
    std::string all;
    for (const std::string& p : rt_problems) all += (all.empty() ? "" : "; ") + p;
    if (o.require_rt) {
      rt_ok = false;
      tick.join();
      spdlog::error("--require-rt: real-time set-up not permitted: {}", all);
      return 3;
    }
    spdlog::warn("real-time set-up not permitted, continuing without it: {}", all);  // once
  }
  std::thread receive([&] { receiver.Run(stop_io); });
  std::thread publish([&] { publisher.Run(stop_io); });

  // Wait for SIGINT or SIGTERM (blocked in every thread), or for --duration to run out.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  int signal_number = 0;
  while (max_ticks < 0 || loop.ticks() < max_ticks) {
    const timespec wait{0, 20'000'000};
    signal_number = sigtimedwait(&signals, nullptr, &wait);
    if (signal_number > 0) break;
  }
  stop_loop = true;
  tick.join();
  stop_io = true;
  receive.join();
  publish.join();
  publisher.Drain();  // the last records and a final status
  close(notify_fd);
  spdlog::info("stopped{} after {} ticks: {} overruns, {} state messages published, {} records dropped",
               signal_number > 0 ? fmt::format(" by signal {}", signal_number) : std::string(), loop.ticks(),
               loop.overruns(), publisher.states_published(), loop.records_dropped());
  spdlog::default_logger()->flush();
  return 0;
}

}  // namespace

int RunLagranged(int argc, char** argv) {
  // Block the stop signals before any thread starts: the main thread waits for them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  Options o;
  CLI::App app{"lagranged: simulates and controls the plants of a scene at a fixed rate, over LCM"};
  app.name("lagranged");
  app.add_option("--config", o.config, "Scene file")->capture_default_str();
  app.add_option("--lcm-url", o.lcm_url, "LCM URL (default: $LCM_DEFAULT_URL, else " + std::string(kDefaultLcmUrl) + ")");
  app.add_option("--channel-prefix", o.channel_prefix, "Prepended to every channel name");
  app.add_option("--log-file", o.log_file, "Also log to this file (rotating: 5 MiB x 3)");
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
  app.add_option("--rt-priority", o.rt.priority, "SCHED_FIFO priority of the tick thread (1-99)")->check(CLI::Range(1, 99));
  app.add_option("--cpu", o.rt.cpu, "Pin the tick thread to this CPU")->check(CLI::NonNegativeNumber);
  app.add_option("--spin-us", o.spin_us, "Busy-wait this long before each deadline instead of sleeping")
      ->check(CLI::Range(0.0, 1000.0));
  app.add_flag("--require-rt", o.require_rt, "Exit (status 3) if real-time set-up is not permitted");
  app.add_option("--timing-csv", o.timing_csv,
                 "Write every tick's wake-up latency and compute time (ns) to this CSV, from the publish thread "
                 "(for bench/)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return 0;
  } catch (const CLI::ParseError& e) {
    std::cerr << "lagranged: " << e.what() << "\n";
    return 2;
  }
  SetUpLogging(o);
  try {
    return Serve(o);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

}  // namespace lagrange
