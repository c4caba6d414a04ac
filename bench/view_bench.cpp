// What lagrangectl view costs (issue 24): to the daemons it watches, and
// itself. Two lagranged run on a private LCM port, the default scene (the arm
// and the cart-pole) and the Panda (config/panda_minjerk.yaml, under
// --channel-prefix PANDA_); the program alternates --rounds times between
//   without   the daemons alone, for --seconds
//   with      lagrangectl view watching both at --rate frames per second,
//             with --clients streams read as a browser reads them (server-sent
//             events over HTTP; nothing is rendered), for --seconds
// and measures, from /proc, each window's CPU of the daemons (user + system,
// every thread) and of the viewer, and the frames each stream received.
//
// Figures, each against a baseline measured in the same run:
//   daemons' CPU with the viewer / without it   1.00 within the noise: the viewer only listens
//   viewer's CPU / the daemons' CPU             what watching costs, beside what is watched
//   frames per second per stream / --rate      the decimation: every browser gets the display rate
// and the absolute CPU (s per s: 1.0 is one core busy) for the record. The
// results go to OUT/view.json and stdout.

#include <signal.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <thread>

#include <nlohmann/json.hpp>

#include "bench/harness.hpp"
#include "bench/options.hpp"
#include "bench/proc_stats.hpp"

// Last: it includes <resolv.h>, whose macro _res would rename a parameter in Eigen's headers.
#include <httplib.h>

namespace lagrange::bench {
namespace {

namespace fs = std::filesystem;

struct Options : DaemonOptions {
  std::string lagrangectl;
  int http_port = 18390;
  double seconds = 10.0;
  int rounds = 2;
  int clients = 1;
  double rate = 60.0;
  bool quick = false;
};

struct Window {
  double wall = 0.0, daemons_cpu = 0.0, viewer_cpu = 0.0;
  double frames_per_stream = 0.0;  // per second
};

// Streams /api/stream as a browser's EventSource would, counting frames, until stopped.
class StreamReader {
 public:
  StreamReader(int port) {
    thread_ = std::thread([this, port] {
      while (!stop_) {
        httplib::Client client("127.0.0.1", port);
        client.set_read_timeout(2, 0);
        client.Get("/api/stream", [this](const char* data, std::size_t n) {
          for (std::size_t i = 0; i + 5 <= n; ++i) frames_ += std::string_view(data + i, 5) == "data:";
          return !stop_.load();
        });
        if (!stop_) std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    });
  }
  ~StreamReader() {
    stop_ = true;
    thread_.join();
  }
  std::int64_t frames() const { return frames_.load(); }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> frames_{0};
  std::thread thread_;
};

Window Measure(const Options& o, const std::vector<pid_t>& daemons, pid_t viewer,
               std::vector<std::unique_ptr<StreamReader>>& streams) {
  auto daemons_cpu = [&] {
    double s = 0.0;
    for (pid_t d : daemons) s += ProcessCpuSeconds(d);
    return s;
  };
  std::int64_t frames0 = 0;
  for (auto& s : streams) frames0 += s->frames();
  const double d0 = daemons_cpu(), v0 = viewer > 0 ? ProcessCpuSeconds(viewer) : 0.0;
  const auto t0 = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
  Window w;
  w.wall = std::chrono::duration<double>(Clock::now() - t0).count();
  w.daemons_cpu = (daemons_cpu() - d0) / w.wall;
  w.viewer_cpu = viewer > 0 ? (ProcessCpuSeconds(viewer) - v0) / w.wall : 0.0;
  std::int64_t frames1 = 0;
  for (auto& s : streams) frames1 += s->frames();
  w.frames_per_stream = streams.empty() ? 0.0 : static_cast<double>(frames1 - frames0) / w.wall / streams.size();
  return w;
}

int Run(const Options& o) {
  const std::string url = Url(o.port);
  const std::string default_scene = o.Scene("default.yaml"), panda_scene = o.Scene("panda_minjerk.yaml");
  std::vector<pid_t> daemons;
  daemons.push_back(Spawn(LagrangedArgs(o.lagranged, default_scene, url), o.File("lagranged_view.log")));
  std::vector<std::string> panda = LagrangedArgs(o.lagranged, panda_scene, url);
  panda.insert(panda.end(), {"--channel-prefix", "PANDA_"});
  daemons.push_back(Spawn(panda, o.File("lagranged_view_panda.log")));
  std::this_thread::sleep_for(std::chrono::seconds(2));  // both ticking

  std::vector<Window> without, with;
  int status = 0;
  for (int round = 0; round < o.rounds; ++round) {
    std::vector<std::unique_ptr<StreamReader>> none;
    without.push_back(Measure(o, daemons, -1, none));
    const pid_t viewer = Spawn({o.lagrangectl, "view", "--lcm-url", url, "--port", std::to_string(o.http_port), "--bind",
                                "127.0.0.1", "--rate", std::to_string(o.rate), "--channel-prefix", "", "--scene",
                                default_scene, "--channel-prefix", "PANDA_", "--scene", panda_scene},
                               o.File("view_bench_viewer.log"));
    std::vector<std::unique_ptr<StreamReader>> streams;
    for (int c = 0; c < o.clients; ++c) streams.push_back(std::make_unique<StreamReader>(o.http_port));
    std::this_thread::sleep_for(std::chrono::seconds(1));  // listening, streaming
    with.push_back(Measure(o, daemons, viewer, streams));
    streams.clear();
    kill(viewer, SIGINT);
    const Exit e = WaitExit(viewer, 10.0);
    if (e.status != 0) {
      std::cerr << "view_bench: lagrangectl view: " << DescribeExit(e.status) << "\n";
      status = 1;
    }
  }
  for (pid_t d : daemons) {
    const Exit e = Terminate(d, 10.0);
    if (e.status != 0) status = 1;
  }

  auto mean = [](const std::vector<Window>& v, double Window::*f) {
    double s = 0.0;
    for (const Window& w : v) s += w.*f;
    return v.empty() ? 0.0 : s / v.size();
  };
  const double d_without = mean(without, &Window::daemons_cpu), d_with = mean(with, &Window::daemons_cpu);
  const double viewer = mean(with, &Window::viewer_cpu), fps = mean(with, &Window::frames_per_stream);
  nlohmann::json j = {{"seconds", o.seconds},        {"rounds", o.rounds},
                      {"clients", o.clients},        {"rate", o.rate},
                      {"load_average", LoadAverage()},
                      {"daemons_cpu_without", d_without}, {"daemons_cpu_with", d_with},
                      {"daemons_ratio", d_with / d_without},
                      {"viewer_cpu", viewer},        {"viewer_over_daemons", viewer / d_without},
                      {"frames_per_stream", fps},    {"frames_over_rate", fps / o.rate}};
  std::ofstream(o.File("view.json")) << j.dump(2) << "\n";
  std::printf("lagrangectl view at %.0f Hz, %d stream(s), the default scene and the Panda (%d x %.0f s each way)\n",
              o.rate, o.clients, o.rounds, o.seconds);
  std::printf("  daemons' CPU, with the viewer / without it   %.3f   (%.3f / %.3f s per s)\n", d_with / d_without, d_with,
              d_without);
  std::printf("  viewer's CPU / the daemons' CPU              %.3f   (%.3f s per s)\n", viewer / d_without, viewer);
  std::printf("  frames per second per stream / rate          %.3f   (%.1f)\n", fps / o.rate, fps);
  std::printf("  load average %s\n", LoadAverage().c_str());
  return status;
}

int Main(int argc, char** argv) {
  Options o;
  o.port = 8390;
  o.config = SourceConfigDir();
  CLI::App app{"view_bench: what lagrangectl view costs the daemons it watches, and itself"};
  AddDaemonOptions(app, o, ConfigOption::kSceneFolder, "The folder of default.yaml and panda_minjerk.yaml");
  const fs::path sibling = fs::read_symlink("/proc/self/exe").parent_path().parent_path() / "tools" / "lagrangectl";
  if (fs::exists(sibling)) o.lagrangectl = sibling.string();
  app.add_option("--lagrangectl", o.lagrangectl, "lagrangectl (default: ../tools/lagrangectl beside this program)")
      ->check(CLI::ExistingFile);
  app.add_option("--http-port", o.http_port, "The viewer's port on 127.0.0.1")->capture_default_str();
  auto* seconds = app.add_option("--seconds", o.seconds, "Each window, s")->capture_default_str();
  auto* rounds = app.add_option("--rounds", o.rounds, "Windows each way, alternating")->capture_default_str();
  app.add_option("--clients", o.clients, "Streams read at once")->capture_default_str();
  app.add_option("--rate", o.rate, "The viewer's frames per second")->capture_default_str();
  AddQuickFlag(app, o.quick, "A smoke run: 2 s windows, one round", [&] {
    QuickDefault(seconds, o.seconds, 2.0);
    QuickDefault(rounds, o.rounds, 1);
  });
  CLI11_PARSE(app, argc, argv);
  if (o.lagrangectl.empty()) {
    std::cerr << "view_bench: no lagrangectl beside this program; give --lagrangectl\n";
    return 2;
  }
  if (const int status = PrepareRun("view_bench", o, {o.port})) return status;
  return Run(o);
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) { return lagrange::bench::Main(argc, argv); }
