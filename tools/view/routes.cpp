#include "tools/view/routes.hpp"

#include <optional>
#include <sstream>

#include "plant/plant_factory.hpp"
#include "tools/view/live.hpp"
#include "tools/view/log_view.hpp"
#include "tools/view/page.hpp"

// Last: it includes <resolv.h>, whose macro _res would rename a parameter in Eigen's headers.
#include <httplib.h>

namespace lagrange::cli::view {
namespace {

using nlohmann::json;

// "a,b,.." of `n` finite numbers into `q` (empty text: zeros); false for anything else.
bool ParseJointValues(const std::string& text, VectorXd& q) {
  std::istringstream in(text);
  std::string item;
  Eigen::Index k = 0;
  while (std::getline(in, item, ',')) {
    const std::optional<double> v = ParseFiniteNumber(item);
    if (!v || k >= q.size()) return false;
    q[k++] = *v;
  }
  return k == q.size() || text.empty();
}

}  // namespace

void ViewRoutes::Install(httplib::Server& server) {
  // The page only reads: every other method is refused before its body is read. (cpp-httplib reads a POST's
  // body into memory whole, with no bound on a chunked one, whatever its payload limit.)
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
  server.set_mount_point("/three", site_.three_dir);  // httplib refuses paths that leave the directory
  server.set_file_extension_and_mimetype_mapping("js", "text/javascript");
  server.Get("/api/model", [this](const httplib::Request&, httplib::Response& res) {
    res.set_content(site_.model_json, "application/json");
  });
  server.Get(R"(/mesh/(\d{1,4})/(\d{1,4}))", [this](const httplib::Request& req, httplib::Response& res) { Mesh(req, res); });
  if (site_.urdf)
    server.Get("/api/poses", [this](const httplib::Request& req, httplib::Response& res) { UrdfPoses(req, res); });
  if (site_.log != nullptr)
    server.Get("/api/log", [this](const httplib::Request& req, httplib::Response& res) { LogFrame(req, res); });
  if (site_.hub != nullptr)
    server.Get("/api/stream", [this](const httplib::Request&, httplib::Response& res) { Stream(res); });
}

// A mesh the model was given, when it is still the file that was checked (meshes.hpp).
void ViewRoutes::Mesh(const httplib::Request& req, httplib::Response& res) const {
  const ViewModels& models = *site_.models;
  const std::size_t m = std::stoul(req.matches[1]), k = std::stoul(req.matches[2]);
  if (m >= models.size() || k >= models[m]->mesh_files().size()) {
    res.status = 404;
    return;
  }
  std::optional<std::string> bytes = ReadMesh(models[m]->mesh_files()[k]);
  if (!bytes) {
    res.status = 404;
    return;
  }
  res.set_content(std::move(*bytes), "application/octet-stream");
}

// GET /api/poses?q=a,b,..: the URDF's poses at q (any finite q: the kinematics take it).
void ViewRoutes::UrdfPoses(const httplib::Request& req, httplib::Response& res) const {
  const ViewModel& model = *site_.models->front();
  VectorXd q = VectorXd::Zero(model.num_dofs());
  if (!ParseJointValues(req.get_param_value("q"), q)) {
    res.status = 400;
    res.set_content("q: expected " + std::to_string(q.size()) + " finite numbers", "text/plain");
    return;
  }
  const json instance = {{"model", 0},
                         {"name", model.geometry()["name"]},
                         {"q", Numbers(std::vector<double>(q.data(), q.data() + q.size()))},
                         {"poses", model.Poses(q)}};
  res.set_content(Dump({{"instances", json::array({instance})}}), "application/json");
}

// GET /api/log?t=SECONDS: every instance's last logged state at or before t.
void ViewRoutes::LogFrame(const httplib::Request& req, httplib::Response& res) const {
  const std::optional<double> t = ParseFiniteNumber(req.get_param_value("t"));
  if (!t) {
    res.status = 400;
    res.set_content("t: expected a finite number of seconds", "text/plain");
    return;
  }
  res.set_content(Dump(site_.log->FrameAt(*t)), "application/json");
}

// The stream of one browser: the newest frame whenever there is one it has not had, a comment every second so
// that a closed connection shows.
void ViewRoutes::Stream(httplib::Response& res) {
  if (clients_.fetch_add(1) >= site_.max_clients) {
    clients_.fetch_sub(1);
    res.status = 503;
    res.set_content("lagrangectl view: " + std::to_string(site_.max_clients) +
                        " browsers are watching already (--max-clients)",
                    "text/plain");
    return;
  }
  res.set_header("Cache-Control", "no-cache");
  auto seq = std::make_shared<std::uint64_t>(0);
  FrameHub& hub = *site_.hub;
  res.set_chunked_content_provider(
      "text/event-stream",
      [&hub, seq](std::size_t, httplib::DataSink& sink) {
        const auto frame = hub.Next(*seq, std::chrono::milliseconds(1000));
        if (hub.stopped()) return false;
        const std::string chunk = frame ? "data: " + *frame + "\n\n" : std::string(": alive\n\n");
        return sink.write(chunk.data(), chunk.size());
      },
      [this](bool) { clients_.fetch_sub(1); });
}

}  // namespace lagrange::cli::view
