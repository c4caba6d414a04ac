// lagrangectl view: a live 3-D view of every instance on the bus, of an
// lcm-logger recording (--log), or of a URDF alone with a slider per joint
// (--urdf), served as a web page (tools/view/index.html, viewer.js) by
// cpp-httplib with server-sent events; three.js comes from Debian's
// libjs-three, served from its directory, so nothing is fetched from the
// internet. The command wires the view's parts together:
//   view_model     what is drawn of a plant, and its poses by the plant's own kinematics
//   meshes         a URDF's mesh files, confined to its package and checked
//   instance_json  what the page is sent of an instance (poses, a floating base's, setpoint ghost, task target)
//   live           the bus: states, telemetry, task states, floating bases; frames at --rate (FrameHub)
//   log_view       --log: a recording, an instance at any time t
//   routes         the HTTP routes; http_gate: the connections (deadlines, caps, refusals)
// It only listens: it never publishes.

#include <chrono>
#include <filesystem>
#include <memory>
#include <thread>

#include <nlohmann/json.hpp>

#include "base/escape.hpp"
#include "plant/urdf.hpp"
#include "protocol/channels.hpp"
#include "sim/default_scene.hpp"
#include "sim/scene.hpp"
#include "tools/bus_options.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/interrupt.hpp"
#include "tools/view/instance_json.hpp"
#include "tools/view/live.hpp"
#include "tools/view/log_view.hpp"
#include "tools/view/routes.hpp"
#include "tools/view/view_model.hpp"

// Last: it includes <resolv.h>, whose macro _res would rename a parameter in Eigen's headers.
#include "tools/view/http_gate.hpp"

namespace lagrange::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using view::ViewInstance;

constexpr const char* kDefaultThreeDir = "/usr/share/javascript/three";
constexpr int kSpareThreads = 4;  // pool threads beyond the streams: the page, its scripts, meshes, poses

// What the page's own URL takes: only in the page (viewer.js) and here.
constexpr const char* kPageOptions = R"(The page's URL takes options, e.g. http://127.0.0.1:8080/?frames=1&frames_max=30:
  frames=1       draw every frame's axes (x red, y green, z blue) from the start
  frames_max=N   live: stop listening after N frames that drew an instance. A headless browser's
                 --screenshot or --dump-dom waits for the page's loads to end, and the live stream never
                 ends: without frames_max it never finishes, e.g.
                   chromium --headless=new --use-angle=swiftshader --enable-unsafe-swiftshader \
                     --virtual-time-budget=3000 --screenshot=view.png 'http://127.0.0.1:8080/?frames_max=30'
  t=SECONDS      --log: the time shown first (the logger's clock, from its first event)
  q=a,b,..       --urdf: the joints' values shown first, one per joint
  probe=1        count the canvas's pixels that are not background into #lagrange-probe after each draw
--bind other than a loopback address (127.0.0.1, ::1) serves the page, unauthenticated, to every host that
can reach this one; lagrangectl view warns when it starts so.)";

// Whether `address` reaches only this host.
bool IsLoopback(const std::string& address) {
  return address.rfind("127.", 0) == 0 || address == "::1" || address == "localhost";
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
    app_->add_flag("--floating-base", floating_base_,
                   "With --urdf: read its root link as a free base (as eval --floating-base), drawn at the origin "
                   "on a ground");
    app_->add_option("--package-path", package_path_,
                     "Directories holding the packages of a URDF's package:// meshes (repeatable, searched in "
                     "order); meshes are served only from under these and the URDF's folder");
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
    app_->footer(kPageOptions);
  }

  int Run(std::ostream& out, std::ostream& err) override {
    CheckOptions();
    LoadModels();
    if (mode_ == Mode::kLog) log_view_ = std::make_unique<view::LogView>(log_, models_, instances_, bus_, err);
    if (!IsLoopback(bind_)) {
      err << "lagrangectl view: WARNING: --bind " << Escape(bind_)
          << " serves this view to every host that can reach this one, with no login and no encryption: anyone "
             "there sees every instance on the bus; bind 127.0.0.1 (the default) and reach it through "
             "`ssh -L PORT:127.0.0.1:PORT HOST` unless the network is yours alone"
          << std::endl;
    }
    view::ViewRoutes routes(Site());
    view::GatedServer server(max_clients_ + kSpareThreads);
    routes.Install(server);
    Bind(server);
    // Serving (an error before is one line): visuals not drawn, meshes missing or refused, as on the page.
    for (const auto& model : models_) {
      for (const auto& line : model->geometry()["missing"])
        err << "lagrangectl view: " << Escape(model->name()) << ": " << line.get<std::string>() << "\n";
    }
    std::thread http([&] { server.listen_after_bind(); });
    out << "lagrangectl view: http://" << (bind_ == "0.0.0.0" ? "127.0.0.1" : bind_) << ":" << port_ << "/"
        << (mode_ == Mode::kLive ? "" : mode_ == Mode::kLog ? " (log " + Escape(log_) + ")" : " (urdf)")
        << " (Ctrl-C stops)" << std::endl;
    Serve(server, http);
    return 0;
  }

 private:
  enum class Mode { kLive, kLog, kUrdf };

  void CheckOptions() {
    if (!urdf_.empty() && (!log_.empty() || !scenes_.empty()))
      throw UsageError("--urdf shows a robot alone: it takes no --log or --scene");
    if (floating_base_ && urdf_.empty())
      throw UsageError("--floating-base is --urdf's: a scene says which bases float (floating_base: true)");
    if (!fs::is_regular_file(fs::path(three_dir_) / "build/three.module.js"))
      throw UsageError("three.js not found in " + Escape(three_dir_) +
                       " (expected build/three.module.js; install Debian's libjs-three or give --three DIR)");
    if (prefixes_.empty()) prefixes_.push_back("");
    if (!scenes_.empty() && scenes_.size() != 1 && scenes_.size() != prefixes_.size())
      throw UsageError("give one --scene, or one per --channel-prefix (" + std::to_string(prefixes_.size()) + ")");
    mode_ = !urdf_.empty() ? Mode::kUrdf : !log_.empty() ? Mode::kLog : Mode::kLive;
  }

  // The models to draw: the URDF alone, or every instance of the scene(s) under each channel prefix.
  void LoadModels() {
    if (mode_ == Mode::kUrdf) {
      // UrdfError: one line naming the file. A floating base is drawn by its joints' model at the origin.
      std::shared_ptr<const UrdfRobot> robot =
          std::make_shared<const UrdfRobot>(LoadUrdf(urdf_, {.floating_base = floating_base_}));
      if (floating_base_ && robot->tree.num_joints() == 0)
        throw UrdfError(Escape(urdf_) + ": no moving joint: a free body alone is not drawn (a scene refuses one too)");
      if (floating_base_) robot = FixedBaseOf(*robot);
      models_.push_back(std::make_unique<view::ViewModel>(robot->name, UrdfPlantSpec(robot),
                                                          view::ViewModelOptions{package_path_, {}, floating_base_}));
      return;
    }
    if (scenes_.empty()) scenes_.push_back(DefaultScenePath());
    std::vector<Scene> scenes;
    for (const std::string& file : scenes_) scenes.push_back(LoadScene(file));  // ConfigError: one line
    for (std::size_t d = 0; d < prefixes_.size(); ++d) {
      for (const InstanceConfig& instance : scenes[scenes.size() == 1 ? 0 : d].instances) {
        const ViewInstance i{prefixes_[d], instance.name, static_cast<int>(models_.size())};
        models_.push_back(std::make_unique<view::ViewModel>(
            i.Label(), instance.plant,
            view::ViewModelOptions{package_path_, instance.torque_limits, instance.floating.has_value()}));
        instances_.push_back(i);
      }
    }
  }

  void Bind(view::GatedServer& server) const {
    // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, with which a second view on the same
    // port binds too and the kernel shares the browsers between them.
    server.set_socket_options([](socket_t sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    if (!server.bind_to_port(bind_.c_str(), port_))
      throw std::runtime_error("cannot listen on " + Escape(bind_) + ":" + std::to_string(port_) +
                               " (in use, or not an address of this host)");
    server.RaiseListenBacklog();
  }

  view::ViewSite Site() {
    view::ViewSite site;
    site.models = &models_;
    site.model_json = view::Dump(ModelJson());
    site.three_dir = three_dir_;
    site.urdf = mode_ == Mode::kUrdf;
    site.log = log_view_.get();
    site.hub = mode_ == Mode::kLive ? &hub_ : nullptr;
    site.max_clients = max_clients_;
    return site;
  }

  // GET /api/model: every model's geometry, and what the view shows.
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
    if (log_view_) j["log"] = log_view_->Info();
    if (mode_ == Mode::kLive) {
      json prefixes = json::array();
      for (const std::string& p : prefixes_) prefixes.push_back(Escape(p));
      j["bus"] = {{"url", Escape(bus_.Url())}, {"prefixes", prefixes}};
    }
    return j;
  }

  // Until Ctrl-C: the bus's frames (live), or nothing but the server (log, urdf); then the server stops.
  void Serve(view::GatedServer& server, std::thread& http) {
    CatchInterrupt();
    const auto stop = [&] {
      hub_.Stop();
      server.stop();
      http.join();
    };
    try {
      if (mode_ == Mode::kLive)
        view::LiveView(models_, instances_, prefixes_, bus_).Run(rate_, hub_);
      else
        while (!Interrupted()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    } catch (...) {
      stop();
      throw;
    }
    stop();
  }

  int port_ = 8080;
  std::string bind_ = "127.0.0.1";
  std::vector<std::string> scenes_;
  std::string log_, urdf_;
  bool floating_base_ = false;
  std::vector<std::string> package_path_;
  std::string three_dir_ = kDefaultThreeDir;
  double rate_ = 60.0;
  int max_clients_ = 8;
  std::vector<std::string> prefixes_;
  LinkOptions bus_;

  Mode mode_ = Mode::kLive;
  view::ViewModels models_;
  std::vector<ViewInstance> instances_;  // the scenes' (live and log)
  std::unique_ptr<view::LogView> log_view_;
  view::FrameHub hub_;
};

}  // namespace

std::unique_ptr<Command> MakeViewCommand(CLI::App& parent) { return std::make_unique<ViewCommand>(parent); }

}  // namespace lagrange::cli
