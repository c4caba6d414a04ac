#pragma once
// lagrangectl view's HTTP routes. The page only reads: every method but GET
// and HEAD is refused (405) before its body is read.
//   /                 the page (tools/view/index.html, compiled in)
//   /viewer.js        its script (tools/view/viewer.js, compiled in)
//   /three/...        three.js from its directory (httplib refuses paths that leave it)
//   /api/model        the models' geometry and what the view shows (live, log or urdf)
//   /mesh/M/K         model M's mesh K, re-checked at each request (meshes.hpp)
//   /api/poses?q=..   --urdf: the robot's poses at q
//   /api/log?t=..     --log: every instance at time t
//   /api/stream       live: server-sent events, the newest frame whenever there is one the browser has not
//                     had; at most max_clients at once, more refused (503)

#include <atomic>
#include <string>

#include "tools/view/instance_json.hpp"

namespace httplib {
class Server;
struct Response;
struct Request;
}  // namespace httplib

namespace lagrange::cli::view {

class FrameHub;
class LogView;

// What the routes serve: set up once, read by every request.
struct ViewSite {
  const ViewModels* models = nullptr;
  std::string model_json;       // GET /api/model
  std::string three_dir;        // served at /three
  bool urdf = false;            // --urdf: GET /api/poses
  const LogView* log = nullptr;  // --log: GET /api/log
  FrameHub* hub = nullptr;       // live: GET /api/stream
  int max_clients = 8;           // browsers streaming at once
};

class ViewRoutes {
 public:
  explicit ViewRoutes(ViewSite site) : site_(std::move(site)) {}
  // Installs the routes; `this` must outlive the server's requests.
  void Install(httplib::Server& server);

 private:
  void Mesh(const httplib::Request& req, httplib::Response& res) const;
  void UrdfPoses(const httplib::Request& req, httplib::Response& res) const;
  void LogFrame(const httplib::Request& req, httplib::Response& res) const;
  void Stream(httplib::Response& res);

  ViewSite site_;
  std::atomic<int> clients_{0};
};

}  // namespace lagrange::cli::view
