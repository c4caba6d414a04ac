// lagrangectl view: a live 3-D view of every instance on the bus, of an
// lcm-logger recording (--log), or of a URDF alone with a slider per joint
// (--urdf), served as a web page (tools/view/index.html, viewer.js) by
// cpp-httplib with server-sent events; three.js comes from Debian's
// libjs-three, served from its directory, so nothing is fetched from the
// internet.
//
// The viewer only listens: it never publishes. Every pose it sends is
// computed here, by the plant's own kinematics (tools/view_model.hpp), from
// the states on the bus or in the log, decimated to --rate frames per second:
// one frame is kept (the latest), and each browser is sent the newest frame
// when it can take one, so a slow browser skips frames and never queues
// them. At most --max-clients browsers stream at once; more are refused (503).
// Every string from the bus is escaped (plant/escape.hpp) and the page puts
// text in the document only as text.

#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "daemon/default_scene.hpp"
#include "daemon/scene.hpp"
#include "plant/escape.hpp"
#include "plant/urdf.hpp"
#include "protocol/channels.hpp"
#include "protocol/ids.hpp"
#include "protocol/lcm_log.hpp"
#include "protocol/mode.hpp"
#include "protocol/status.hpp"
#include "protocol/wire.hpp"
#include "tools/bus_options.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/interrupt.hpp"
#include "tools/view_model.hpp"
#include "tools/view_page.hpp"

// Last: it includes <resolv.h>, whose macro _res would rename a parameter in Eigen's headers.
#include <httplib.h>

namespace lagrange::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using SteadyClock = std::chrono::steady_clock;

constexpr double kStale = 0.5;                   // s without a state: STALE (states come every tick)
constexpr std::size_t kMaxExtraInstances = 64;   // instances a status names that the scene lacks (shown as text)
constexpr std::size_t kMaxLogStates = 1 << 20;   // states kept from a log (about 100 MB for 7 joints)
constexpr std::uintmax_t kMaxMeshBytes = 64u << 20;  // a mesh file served, bytes
constexpr const char* kDefaultThreeDir = "/usr/share/javascript/three";

// JSON text of `j`; bytes that are not UTF-8 (from the bus) become U+FFFD.
std::string Dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

json Numbers(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(std::isfinite(x) ? json(x) : json(nullptr));
  return a;
}

bool AllFinite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// The newest frame, and a wait for one newer than a browser's last: each
// browser's stream thread waits here, so none holds more than one frame.
class FrameHub {
 public:
  void Publish(std::string frame) {
    {
      std::lock_guard lock(mutex_);
      frame_ = std::make_shared<const std::string>(std::move(frame));
      ++seq_;
    }
    cv_.notify_all();
  }
  // The newest frame if newer than `seq` (which it updates), waiting up to `timeout`; null on timeout or stop.
  std::shared_ptr<const std::string> Next(std::uint64_t& seq, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, timeout, [&] { return stopped_ || seq_ != seq; });
    if (stopped_ || seq_ == seq) return nullptr;
    seq = seq_;
    return frame_;
  }
  void Stop() {
    {
      std::lock_guard lock(mutex_);
      stopped_ = true;
    }
    cv_.notify_all();
  }
  bool stopped() {
    std::lock_guard lock(mutex_);
    return stopped_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::shared_ptr<const std::string> frame_;
  std::uint64_t seq_ = 0;
  bool stopped_ = false;
};

// One instance the view knows of: a model (index into models_, or −1 when the
// scene has none of that name) and what the bus or the log last said of it.
struct Tracked {
  std::string prefix, name;  // channel prefix and instance name
  int model = -1;
  std::optional<state_t> state;
  SteadyClock::time_point received;
  std::set<std::int64_t> runs;  // run ids heard within kStale (two: which is which cannot be told)
  std::map<std::int64_t, SteadyClock::time_point> run_heard;
  std::optional<telemetry_t> telemetry;
  std::optional<task_state_t> task;  // a task-space controller's frame and target (<NAME>_TASK)
  json event;  // the latest entry into fault, estop or stopped, from every state (not only the frames sent)
  bool changed = false;
};

// A state recorded in a log, kept for the time slider.
struct LoggedState {
  double t = 0.0;  // s since the log's first event (the logger's clock)
  state_t state;
};
struct LoggedTelemetry {
  double t = 0.0;
  double residual = 0.0, bound = 0.0;
};
struct LoggedTask {
  double t = 0.0;
  task_state_t task;
};

// A task-space controller's target pose as the page draws it (a ghost frame):
// the frame's name, the target's position (m) and orientation (w, x, y, z), as
// the daemon published them; null when not finite.
json TargetJson(const task_state_t& task) {
  const auto finite = [](const auto& a) { return std::all_of(std::begin(a), std::end(a), [](double x) { return std::isfinite(x); }); };
  if (!finite(task.position_des) || !finite(task.orientation_des)) return nullptr;
  return {{"frame", Escape(task.frame)},
          {"p", {task.position_des[0], task.position_des[1], task.position_des[2]}},
          {"q", {task.orientation_des[0], task.orientation_des[1], task.orientation_des[2], task.orientation_des[3]}}};
}

class ViewCommand final : public Command {
 public:
  explicit ViewCommand(CLI::App& parent)
      : Command(parent.add_subcommand(
            "view",
            "Serve a live 3-D view of every instance on the bus (or of a log, or of a URDF) as a web page; "
            "it only listens, never publishes")) {
    app_->add_option("--port", port_, "HTTP port")->check(CLI::Range(1, 65535))->capture_default_str();
    app_->add_option("--bind", bind_,
                     "Address to listen on. The default serves this host only; 0.0.0.0 exposes the view (read-only, "
                     "unauthenticated) to everyone who can reach this host")
        ->capture_default_str();
    app_->add_option("--scene", scenes_,
                     "The scene lagranged runs, for its models (default: the scene lagranged runs without --config); "
                     "one per --channel-prefix, or one for all");
    app_->add_option("--log", log_, "Show an lcm-logger recording instead of the bus, with a time slider");
    app_->add_option("--urdf", urdf_, "Show this robot alone, with a slider per joint");
    app_->add_option("--package-path", package_path_,
                     "Directories holding the packages of a URDF's package:// meshes (repeatable, searched in order)");
    app_->add_option("--three", three_dir_, "three.js directory (Debian's libjs-three)")->capture_default_str();
    app_->add_option("--rate", rate_, "Frames per second sent to each browser")
        ->check(PositiveNumber(240.0))
        ->capture_default_str();
    app_->add_option("--max-clients", max_clients_, "Browsers streaming at once; more are refused")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    app_->add_option("--lcm-url", bus_.lcm_url,
                     "LCM URL (default: $LCM_DEFAULT_URL, else " + std::string(kDefaultLcmUrl) + ")");
    app_->add_option("--channel-prefix", prefixes_, "The daemons' --channel-prefix (repeatable: several daemons)");
    app_->add_option("--bus-key", bus_.bus_key_file,
                     "Believe only what the key signed (the daemon's --bus-key FILE); default: $" +
                         std::string(kBusKeyEnv));
    app_->add_option("--bus-domain", bus_.bus_domain,
                     "The domain signatures are bound to (the daemon's --bus-domain); default: $" +
                         std::string(kBusDomainEnv) + ", else the bus's own");
  }

  int Run(std::ostream& out, std::ostream& err) override {
    if (!urdf_.empty() && (!log_.empty() || !scenes_.empty()))
      throw UsageError("--urdf shows a robot alone: it takes no --log or --scene");
    if (!fs::is_regular_file(fs::path(three_dir_) / "build/three.module.js"))
      throw UsageError("three.js not found in " + Escape(three_dir_) +
                       " (expected build/three.module.js; install Debian's libjs-three or give --three DIR)");
    if (prefixes_.empty()) prefixes_.push_back("");
    if (!scenes_.empty() && scenes_.size() != 1 && scenes_.size() != prefixes_.size())
      throw UsageError("give one --scene, or one per --channel-prefix (" + std::to_string(prefixes_.size()) + ")");
    LoadModels();
    if (!log_.empty()) ReadLog(err);

    httplib::Server server;
    server.new_task_queue = [this] { return new httplib::ThreadPool(static_cast<std::size_t>(max_clients_) + 4); };
    // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, with which a second view on the same
    // port binds too and the kernel shares the browsers between them.
    server.set_socket_options([](socket_t sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    Routes(server);
    if (!server.bind_to_port(bind_.c_str(), port_))
      throw std::runtime_error("cannot listen on " + Escape(bind_) + ":" + std::to_string(port_) +
                               " (in use, or not an address of this host)");
    std::thread http([&] { server.listen_after_bind(); });
    out << "lagrangectl view: http://" << (bind_ == "0.0.0.0" ? "127.0.0.1" : bind_) << ":" << port_ << "/"
        << (mode_ == Mode::kLive ? "" : mode_ == Mode::kLog ? " (log " + Escape(log_) + ")" : " (urdf)")
        << " (Ctrl-C stops)" << std::endl;
    CatchInterrupt();
    int status = 0;
    try {
      if (mode_ == Mode::kLive)
        Listen();
      else
        while (!Interrupted()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    } catch (...) {
      hub_.Stop();
      server.stop();
      http.join();
      throw;
    }
    hub_.Stop();
    server.stop();
    http.join();
    return status;
  }

 private:
  enum class Mode { kLive, kLog, kUrdf };

  void LoadModels() {
    mode_ = !urdf_.empty() ? Mode::kUrdf : !log_.empty() ? Mode::kLog : Mode::kLive;
    if (mode_ == Mode::kUrdf) {
      auto robot = std::make_shared<const UrdfRobot>(LoadUrdf(urdf_));  // UrdfError: one line naming the file
      models_.push_back(std::make_unique<ViewModel>(robot->name, UrdfPlantSpec(robot), ViewModelOptions{package_path_, {}}));
      return;
    }
    if (scenes_.empty()) scenes_.push_back(DefaultScenePath());
    std::vector<Scene> scenes;
    for (const std::string& file : scenes_) scenes.push_back(LoadScene(file));  // ConfigError: one line
    for (std::size_t d = 0; d < prefixes_.size(); ++d) {
      const Scene& scene = scenes[scenes.size() == 1 ? 0 : d];
      for (const InstanceConfig& instance : scene.instances) {
        const std::string label = prefixes_[d].empty() ? instance.name : prefixes_[d] + " " + instance.name;
        models_.push_back(
            std::make_unique<ViewModel>(label, instance.plant, ViewModelOptions{package_path_, instance.torque_limits}));
        Tracked t;
        t.prefix = prefixes_[d];
        t.name = instance.name;
        t.model = static_cast<int>(models_.size()) - 1;
        tracked_.push_back(std::move(t));
      }
    }
  }

  LinkOptions Link(const std::string& prefix) const {
    LinkOptions link = bus_;
    link.channel_prefix = prefix;
    return link;
  }

  // ---- the page ----

  json ModelJson() const {
    json models = json::array();
    for (std::size_t m = 0; m < models_.size(); ++m) {
      json g = models_[m]->geometry();
      g["index"] = m;
      models.push_back(std::move(g));
    }
    json j = {{"mode", mode_ == Mode::kLive ? "live" : mode_ == Mode::kLog ? "log" : "urdf"},
              {"models", models},
              {"rate", rate_}};
    if (mode_ == Mode::kLog) {
      j["log"] = {{"file", Escape(log_)}, {"duration", log_duration_}, {"notes", log_notes_}};
    }
    if (mode_ == Mode::kLive) {
      json prefixes = json::array();
      for (const std::string& p : prefixes_) prefixes.push_back(Escape(p));
      j["bus"] = {{"url", Escape(bus_.Url())}, {"prefixes", prefixes}};
    }
    return j;
  }

  void Routes(httplib::Server& server) {
    // The page only reads: every other method is refused before its body is read. (cpp-httplib reads a POST's
    // body into memory whole, with no bound on a chunked one, whatever its payload limit; a route-less POST of
    // gigabytes would otherwise be held here.)
    server.set_pre_routing_handler([](const httplib::Request& req, httplib::Response& res) {
      if (req.method == "GET" || req.method == "HEAD") return httplib::Server::HandlerResponse::Unhandled;
      res.status = 405;
      res.set_header("Allow", "GET, HEAD");
      res.set_header("Connection", "close");  // an unread body is not a next request
      res.set_content("lagrangectl view only serves GET (it takes nothing from a browser)", "text/plain");
      return httplib::Server::HandlerResponse::Handled;
    });
    server.Get("/", [](const httplib::Request&, httplib::Response& res) {
      res.set_content(kViewIndexHtml, "text/html; charset=utf-8");
    });
    server.Get("/viewer.js", [](const httplib::Request&, httplib::Response& res) {
      res.set_content(kViewScript, "text/javascript; charset=utf-8");
    });
    server.set_mount_point("/three", three_dir_);  // httplib refuses paths that leave the directory
    server.set_file_extension_and_mimetype_mapping("js", "text/javascript");
    const std::string model = Dump(ModelJson());
    server.Get("/api/model", [model](const httplib::Request&, httplib::Response& res) {
      res.set_content(model, "application/json");
    });
    server.Get(R"(/mesh/(\d{1,4})/(\d{1,4}))", [this](const httplib::Request& req, httplib::Response& res) {
      const std::size_t m = std::stoul(req.matches[1]), k = std::stoul(req.matches[2]);
      if (m >= models_.size() || k >= models_[m]->mesh_files().size()) {
        res.status = 404;
        return;
      }
      ServeFile(models_[m]->mesh_files()[k], res);
    });
    if (mode_ == Mode::kUrdf) {
      server.Get("/api/poses", [this](const httplib::Request& req, httplib::Response& res) { UrdfPoses(req, res); });
    }
    if (mode_ == Mode::kLog) {
      server.Get("/api/log", [this](const httplib::Request& req, httplib::Response& res) { LogFrame(req, res); });
    }
    if (mode_ == Mode::kLive) {
      server.Get("/api/stream", [this](const httplib::Request&, httplib::Response& res) { Stream(res); });
    }
  }

  static void ServeFile(const std::string& file, httplib::Response& res) {
    std::error_code error;
    const std::uintmax_t size = fs::file_size(file, error);
    if (error || size > kMaxMeshBytes) {
      res.status = error ? 404 : 413;
      return;
    }
    std::ifstream in(file, std::ios::binary);
    std::string bytes(size, '\0');
    if (!in.read(bytes.data(), static_cast<std::streamsize>(size))) {
      res.status = 404;
      return;
    }
    res.set_content(std::move(bytes), "application/octet-stream");
  }

  // GET /api/poses?q=a,b,..: the URDF's poses at q (clamped to nothing: the kinematics take any finite q).
  void UrdfPoses(const httplib::Request& req, httplib::Response& res) {
    const ViewModel& model = *models_.front();
    VectorXd q = VectorXd::Zero(model.num_dofs());
    std::string text = req.get_param_value("q");
    std::istringstream in(text);
    std::string item;
    int k = 0;
    while (std::getline(in, item, ',')) {
      const std::optional<double> v = ParseFiniteNumber(item);
      if (!v || k >= q.size()) {
        res.status = 400;
        res.set_content("q: expected " + std::to_string(q.size()) + " finite numbers", "text/plain");
        return;
      }
      q[k++] = *v;
    }
    if (k != q.size() && !text.empty()) {
      res.status = 400;
      res.set_content("q: expected " + std::to_string(q.size()) + " finite numbers", "text/plain");
      return;
    }
    json frame;
    {
      std::lock_guard lock(poses_mutex_);
      frame = {{"instances", json::array({{{"model", 0},
                                           {"name", model.geometry()["name"]},
                                           {"q", Numbers(std::vector<double>(q.data(), q.data() + q.size()))},
                                           {"poses", model.Poses(q)}}})}};
    }
    res.set_content(Dump(frame), "application/json");
  }

  // ---- live ----

  // The stream of one browser: the newest frame whenever there is one it has
  // not had, a comment every second so that a closed connection shows.
  void Stream(httplib::Response& res) {
    if (clients_.fetch_add(1) >= max_clients_) {
      clients_.fetch_sub(1);
      res.status = 503;
      res.set_content("lagrangectl view: " + std::to_string(max_clients_) + " browsers are watching already (--max-clients)",
                      "text/plain");
      return;
    }
    res.set_header("Cache-Control", "no-cache");
    auto seq = std::make_shared<std::uint64_t>(0);
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, seq](std::size_t, httplib::DataSink& sink) {
          const auto frame = hub_.Next(*seq, std::chrono::milliseconds(1000));
          if (hub_.stopped()) return false;
          const std::string chunk = frame ? "data: " + *frame + "\n\n" : std::string(": alive\n\n");
          return sink.write(chunk.data(), chunk.size());
        },
        [this](bool) { clients_.fetch_sub(1); });
  }

  void Listen() {
    auto bus = bus_.Open();  // signed when a key is given: states must verify, as watch's do
    for (std::size_t d = 0; d < prefixes_.size(); ++d) {
      const LinkOptions link = Link(prefixes_[d]);
      bus->Subscribe(link.StatusChannel(), [this, d](std::string_view, const std::uint8_t* data, std::size_t n) {
        status_t s;
        if (CheckStatusPacket(data, n) != WireCheck::kOk || s.decode(data, 0, static_cast<int>(n)) != static_cast<int>(n))
          return;
        statuses_[d] = {std::move(s), SteadyClock::now()};
      });
    }
    for (std::size_t i = 0; i < tracked_.size(); ++i) SubscribeTracked(*bus, i);
    const auto period = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(1.0 / rate_));
    auto next = SteadyClock::now();
    while (!Interrupted()) {
      next += period;
      for (;;) {
        const auto now = SteadyClock::now();
        if (now >= next) break;
        bus->Handle(static_cast<int>(std::max<std::int64_t>(
            1, std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count())));
      }
      if (SteadyClock::now() > next + 10 * period) next = SteadyClock::now();  // fell behind: skip, never catch up
      SubscribeNamedInStatus(*bus);
      hub_.Publish(Dump(LiveFrame()));
    }
  }

  void SubscribeTracked(Bus& bus, std::size_t i) {
    const LinkOptions link = Link(tracked_[i].prefix);
    bus.Subscribe(link.Channel(tracked_[i].name, kStateSuffix),
                  [this, i](std::string_view, const std::uint8_t* data, std::size_t n) {
                    state_t s;
                    if (CheckStatePacket(data, n) != WireCheck::kOk ||
                        s.decode(data, 0, static_cast<int>(n)) != static_cast<int>(n))
                      return;
                    Tracked& t = tracked_[i];
                    const bool stopped = s.mode == state_t::MODE_FAULT || s.mode == state_t::MODE_ESTOP ||
                                         s.mode == state_t::MODE_STOPPED;
                    if (stopped && (!t.state || t.state->mode != s.mode || t.state->run_id != s.run_id))
                      t.event = {{"mode", ModeName(s.mode)}, {"t", s.t}, {"tick", s.tick}, {"run", RunIdText(s.run_id)}};
                    t.received = SteadyClock::now();
                    t.run_heard[s.run_id] = t.received;
                    if (t.run_heard.size() > 8) t.run_heard.erase(t.run_heard.begin());
                    t.state = std::move(s);
                    t.changed = true;
                  });
    bus.Subscribe(link.Channel(tracked_[i].name, kTelemetrySuffix),
                  [this, i](std::string_view, const std::uint8_t* data, std::size_t n) {
                    telemetry_t m;
                    if (CheckTelemetryPacket(data, n) != WireCheck::kOk ||
                        m.decode(data, 0, static_cast<int>(n)) != static_cast<int>(n))
                      return;
                    tracked_[i].telemetry = std::move(m);
                  });
    bus.Subscribe(link.Channel(tracked_[i].name, kTaskSuffix),
                  [this, i](std::string_view, const std::uint8_t* data, std::size_t n) {
                    task_state_t m;
                    if (CheckTaskStatePacket(data, n) != WireCheck::kOk ||
                        m.decode(data, 0, static_cast<int>(n)) != static_cast<int>(n))
                      return;
                    tracked_[i].task = std::move(m);
                  });
  }

  // Instances a daemon's status names that the scene has not: shown as text (no model to draw them by).
  void SubscribeNamedInStatus(Bus& bus) {
    for (const auto& [d, entry] : statuses_) {
      for (const std::string& name : entry.first.instance_names) {
        if (extra_instances_ >= kMaxExtraInstances) return;
        const bool known = std::any_of(tracked_.begin(), tracked_.end(), [&](const Tracked& t) {
          return t.prefix == prefixes_[d] && t.name == name;
        });
        if (known || name.empty() || name.size() > 64 ||
            !std::all_of(name.begin(), name.end(), [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; }))
          continue;
        Tracked t;
        t.prefix = prefixes_[d];
        t.name = name;
        tracked_.push_back(std::move(t));
        ++extra_instances_;
        SubscribeTracked(bus, tracked_.size() - 1);
      }
    }
  }

  // What the page shows of one instance: its state, its poses and its setpoint's (the ghost).
  json InstanceJson(const Tracked& t, const state_t& s, double age) {
    json j = {{"model", t.model},
              {"name", Escape(t.prefix.empty() ? t.name : t.prefix + " " + t.name)},
              {"run", RunIdText(s.run_id)},
              {"mode", ModeName(s.mode)},
              {"controller", Escape(s.controller)},
              {"t", s.t},
              {"tick", s.tick},
              {"age", age},
              {"q", Numbers(s.q)},
              {"q_des", Numbers(s.q_des)},
              {"tau", Numbers(s.tau)}};
    if (t.model < 0) {
      j["note"] = "not in the scene: not drawn (give lagrangectl view the scene lagranged runs: --scene)";
      return j;
    }
    const ViewModel& model = *models_[static_cast<std::size_t>(t.model)];
    if (s.num_dofs != model.num_dofs()) {
      j["note"] = "its state has " + std::to_string(s.num_dofs) + " joints, the scene's model " +
                  std::to_string(model.num_dofs()) + ": not drawn (another scene?)";
      return j;
    }
    std::lock_guard lock(poses_mutex_);
    if (AllFinite(s.q)) j["poses"] = model.Poses(Eigen::Map<const VectorXd>(s.q.data(), s.num_dofs));
    else j["note"] = "non-finite q: not drawn";
    if (AllFinite(s.q_des)) j["ghost"] = model.Poses(Eigen::Map<const VectorXd>(s.q_des.data(), s.num_dofs));
    return j;
  }

  json LiveFrame() {
    const auto now = SteadyClock::now();
    json instances = json::array();
    for (Tracked& t : tracked_) {
      if (!t.state) continue;
      const double age = std::chrono::duration<double>(now - t.received).count();
      json j = InstanceJson(t, *t.state, age);
      if (age > kStale) j["stale"] = true;
      if (!t.event.is_null()) j["event"] = t.event;
      int live_runs = 0;
      for (const auto& [run, heard] : t.run_heard) live_runs += std::chrono::duration<double>(now - heard).count() <= kStale;
      if (live_runs > 1)
        j["warning"] = std::to_string(live_runs) + " lagranged runs publish this instance: which is which cannot be told";
      for (const auto& [d, entry] : statuses_) {
        if (prefixes_[d] != t.prefix || entry.first.run_id != t.state->run_id) continue;
        j["reason"] = ModeReasonIn(entry.first, t.name, t.state->mode);
      }
      if (t.telemetry && t.telemetry->run_id == t.state->run_id) {
        j["eps"] = t.telemetry->energy_residual;
        j["eps_bound"] = t.telemetry->quadrature_bound;
      }
      if (t.task && t.task->run_id == t.state->run_id && t.model >= 0) j["target"] = TargetJson(*t.task);
      instances.push_back(std::move(j));
    }
    json daemons = json::array();
    for (const auto& [d, entry] : statuses_) {
      const status_t& s = entry.first;
      const double age = std::chrono::duration<double>(now - entry.second).count();
      daemons.push_back({{"prefix", Escape(prefixes_[d])},
                         {"run", RunIdText(s.run_id)},
                         {"ticks", s.ticks},
                         {"overruns", s.overruns},
                         {"period", s.period},
                         {"stale", age > kStale}});
    }
    return {{"instances", instances}, {"daemons", daemons}};
  }

  // ---- log ----

  void ReadLog(std::ostream& err) {
    LcmLogReader reader(log_);  // LcmLogError: "cannot read F" / "F is not an LCM log ..."
    std::map<std::string, std::size_t> state_channels, telemetry_channels, task_channels;
    for (std::size_t i = 0; i < tracked_.size(); ++i) {
      const LinkOptions link = Link(tracked_[i].prefix);
      state_channels[link.Channel(tracked_[i].name, kStateSuffix)] = i;
      telemetry_channels[link.Channel(tracked_[i].name, kTelemetrySuffix)] = i;
      task_channels[link.Channel(tracked_[i].name, kTaskSuffix)] = i;
    }
    logged_.resize(tracked_.size());
    logged_telemetry_.resize(tracked_.size());
    logged_task_.resize(tracked_.size());
    std::optional<std::int64_t> first;
    std::int64_t states = 0, dropped = 0, refused = 0;
    std::set<std::string> other_states;
    while (const LcmLogEvent* e = reader.Next()) {
      if (!first) first = e->utime;
      const double t = 1e-6 * static_cast<double>(e->utime - *first);
      log_duration_ = std::max(log_duration_, t);
      const std::string channel(e->channel);
      if (auto it = state_channels.find(channel); it != state_channels.end()) {
        state_t s;
        if (e->data == nullptr || CheckStatePacket(e->data, e->size) != WireCheck::kOk ||
            s.decode(e->data, 0, static_cast<int>(e->size)) != static_cast<int>(e->size)) {
          ++refused;
          continue;
        }
        if (static_cast<std::size_t>(states) >= kMaxLogStates) {
          ++dropped;
          continue;
        }
        ++states;
        logged_[it->second].push_back({t, std::move(s)});
      } else if (auto tt = telemetry_channels.find(channel); tt != telemetry_channels.end()) {
        telemetry_t m;
        if (e->data == nullptr || CheckTelemetryPacket(e->data, e->size) != WireCheck::kOk ||
            m.decode(e->data, 0, static_cast<int>(e->size)) != static_cast<int>(e->size))
          continue;
        if (logged_telemetry_[tt->second].size() < kMaxLogStates)
          logged_telemetry_[tt->second].push_back({t, m.energy_residual, m.quadrature_bound});
      } else if (auto tk = task_channels.find(channel); tk != task_channels.end()) {
        task_state_t m;
        if (e->data == nullptr || CheckTaskStatePacket(e->data, e->size) != WireCheck::kOk ||
            m.decode(e->data, 0, static_cast<int>(e->size)) != static_cast<int>(e->size))
          continue;
        if (logged_task_[tk->second].size() < kMaxLogStates) logged_task_[tk->second].push_back({t, std::move(m)});
      } else if (channel.size() > 6 && channel.compare(channel.size() - 6, 6, kStateSuffix) == 0 &&
                 other_states.size() < 16) {
        other_states.insert(Escape(channel, 64));
      }
    }
    if (reader.end() == LcmLogReader::End::kTruncated) log_notes_.push_back("the log ends inside an event (cut short)");
    if (reader.end() == LcmLogReader::End::kCorrupt) log_notes_.push_back("the log ends at a corrupt event");
    if (refused > 0) log_notes_.push_back(std::to_string(refused) + " states that do not decode were passed over");
    if (dropped > 0)
      log_notes_.push_back("only the first " + std::to_string(kMaxLogStates) + " states are shown (" +
                           std::to_string(dropped) + " more)");
    for (const std::string& c : other_states)
      log_notes_.push_back(c + " is in the log but not in the scene: not drawn (--scene)");
    if (states == 0) log_notes_.push_back("no state of the scene's instances in this log");
    for (const std::string& note : log_notes_) err << "lagrangectl view: " << log_ << ": " << note << "\n";
  }

  // GET /api/log?t=SECONDS: every instance's last logged state at or before t.
  void LogFrame(const httplib::Request& req, httplib::Response& res) {
    const std::optional<double> t = ParseFiniteNumber(req.get_param_value("t"));
    if (!t) {
      res.status = 400;
      res.set_content("t: expected a finite number of seconds", "text/plain");
      return;
    }
    json instances = json::array();
    for (std::size_t i = 0; i < tracked_.size(); ++i) {
      const auto& states = logged_[i];
      auto it = std::upper_bound(states.begin(), states.end(), *t,
                                 [](double x, const LoggedState& s) { return x < s.t; });
      if (it == states.begin()) continue;
      const LoggedState& s = *std::prev(it);
      json j = InstanceJson(tracked_[i], s.state, *t - s.t);
      j["log_t"] = s.t;
      const auto& tel = logged_telemetry_[i];
      auto jt = std::upper_bound(tel.begin(), tel.end(), *t, [](double x, const LoggedTelemetry& m) { return x < m.t; });
      if (jt != tel.begin()) {
        j["eps"] = std::prev(jt)->residual;
        j["eps_bound"] = std::prev(jt)->bound;
      }
      const auto& tasks = logged_task_[i];
      auto kt = std::upper_bound(tasks.begin(), tasks.end(), *t, [](double x, const LoggedTask& m) { return x < m.t; });
      if (kt != tasks.begin() && std::prev(kt)->task.run_id == s.state.run_id && tracked_[i].model >= 0)
        j["target"] = TargetJson(std::prev(kt)->task);
      instances.push_back(std::move(j));
    }
    res.set_content(Dump({{"t", *t}, {"instances", instances}}), "application/json");
  }

  int port_ = 8080;
  std::string bind_ = "127.0.0.1";
  std::vector<std::string> scenes_;
  std::string log_, urdf_;
  std::vector<std::string> package_path_;
  std::string three_dir_ = kDefaultThreeDir;
  double rate_ = 60.0;
  int max_clients_ = 8;
  std::vector<std::string> prefixes_;
  LinkOptions bus_;

  Mode mode_ = Mode::kLive;
  std::vector<std::unique_ptr<ViewModel>> models_;
  std::vector<Tracked> tracked_;  // grows only in the bus thread (Listen); handlers hold indices
  std::size_t extra_instances_ = 0;
  std::map<std::size_t, std::pair<status_t, SteadyClock::time_point>> statuses_;  // by prefix index
  std::vector<std::vector<LoggedState>> logged_;
  std::vector<std::vector<LoggedTelemetry>> logged_telemetry_;
  std::vector<std::vector<LoggedTask>> logged_task_;
  double log_duration_ = 0.0;
  std::vector<std::string> log_notes_;
  std::mutex poses_mutex_;  // the models' KinematicsData: one evaluation at a time
  FrameHub hub_;
  std::atomic<int> clients_{0};
};

}  // namespace

std::unique_ptr<Command> MakeViewCommand(CLI::App& parent) { return std::make_unique<ViewCommand>(parent); }

}  // namespace lagrange::cli
