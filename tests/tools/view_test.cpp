// lagrangectl view. ViewBrowser.*: the page in a real browser (Debian's
// chromium, headless, software WebGL through SwiftShader) against
// lagrangectl view serving a URDF, a live lagranged on a private LCM port,
// and a log: the canvas is not blank, the page names the instances and their
// modes, and every pose the page drew equals the plant's own kinematics at the
// q it was drawn for to 1e-9. ViewTest.*: the server's answers to bad input,
// without a browser.
//
// The page writes what it drew into #lagrange-drawn (JSON: per instance, each
// frame object's three.js matrix, column-major) and, with ?probe=1, its
// canvas's non-background pixel count and a checksum into #lagrange-probe;
// chromium --dump-dom prints the document once --virtual-time-budget has run
// out, and a live page stops listening after ?frames_max=N frames so the
// budget can run out.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <lagrange/base_state_t.hpp>
#include <lagrange/mpc_t.hpp>
#include <lagrange/state_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <regex>
#include <thread>

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include "plant/floating_dynamics.hpp"
#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "sim/scene.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"
#include "tools/view/instance_json.hpp"
#include "tools/view/view_model.hpp"

// Last: it includes <resolv.h>, whose macro _res would rename a parameter in Eigen's headers.
#include <httplib.h>

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::BackgroundProcess;

constexpr double kPoseTolerance = 1e-9;
const std::string kVisualArm = std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/urdf/view/visual_arm.urdf";
const std::string kDefaultScene = std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml";
// A floating tree (5 joints, no <visual>) thrown upward from 1 m, turning, with no ground: instance `tree`.
const std::string kFloatingScene = std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/scenes/floating_fall.yaml";

std::string Chromium() {
  for (const char* path : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (access(path, X_OK) == 0) return path;
  }
  return "";
}

// The text of <pre id="ID"> in a dumped document, entities decoded.
std::string PreText(const std::string& dom, const std::string& id) {
  const std::string open = "<pre id=\"" + id + "\"";
  std::size_t at = dom.find(open);
  if (at == std::string::npos) return "";
  at = dom.find('>', at);
  const std::size_t end = dom.find("</pre>", at);
  if (at == std::string::npos || end == std::string::npos) return "";
  std::string text = dom.substr(at + 1, end - at - 1);
  for (const auto& [entity, c] : std::vector<std::pair<std::string, std::string>>{
           {"&lt;", "<"}, {"&gt;", ">"}, {"&quot;", "\""}, {"&nbsp;", " "}, {"&amp;", "&"}}) {
    for (std::size_t p = text.find(entity); p != std::string::npos; p = text.find(entity, p + 1))
      text.replace(p, entity.size(), c);
  }
  return text;
}

// A TCP connection to 127.0.0.1:`port`, or -1.
int Connect(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd >= 0 && connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) return fd;
  if (fd >= 0) close(fd);
  return -1;
}

void SendAll(int fd, const std::string& bytes) {
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n <= 0) return;
    done += static_cast<std::size_t>(n);
  }
}

// A three.js column-major matrix against a kinematics pose: R, p and the bottom row.
void ExpectPose(const json& m, const Eigen::Matrix3d& R, const Eigen::Vector3d& p, const std::string& what) {
  ASSERT_TRUE(m.is_array() && m.size() == 16u) << what << ": " << m.dump();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(m[j * 4 + i].get<double>(), R(i, j), kPoseTolerance) << what;
    EXPECT_NEAR(m[12 + i].get<double>(), p(i), kPoseTolerance) << what;
    EXPECT_EQ(m[i * 4 + 3].get<double>(), 0.0) << what;
  }
  EXPECT_EQ(m[15].get<double>(), 1.0) << what;
}

// Every frame the page drew for `q` equals the kinematics' pose at q.
void ExpectPosesOf(const Kinematics& kinematics, const json& drawn, const json& q, const std::string& what) {
  ASSERT_TRUE(q.is_array() && static_cast<int>(q.size()) == kinematics.num_dofs()) << what;
  VectorXd qv(kinematics.num_dofs());
  for (int k = 0; k < qv.size(); ++k) qv[k] = q[static_cast<std::size_t>(k)].get<double>();
  auto data = kinematics.MakeData();
  kinematics.ComputeFramePlacements(*data, qv);
  ASSERT_TRUE(drawn.is_array() && static_cast<int>(drawn.size()) == kinematics.num_frames()) << what;
  for (int f = 0; f < kinematics.num_frames(); ++f) {
    ExpectPose(drawn[static_cast<std::size_t>(f)], data->rotation(f), data->position(f),
               what + " frame " + kinematics.frame_names()[static_cast<std::size_t>(f)]);
  }
}

Kinematics SceneKinematics(const std::string& instance, const std::string& file = kDefaultScene) {
  const Scene scene = LoadScene(file);
  for (const InstanceConfig& c : scene.instances)
    if (c.name == instance) return Kinematics(MakeRigidTree(c.plant));
  throw std::runtime_error("no instance " + instance);
}

// A floating instance's model as lagranged steps it (FloatingTreeOf): the independent placement of its frames.
FloatingDynamics SceneFloatingDynamics(const std::string& instance, const std::string& file) {
  const Scene scene = LoadScene(file);
  for (const InstanceConfig& c : scene.instances) {
    if (c.name == instance && c.floating)
      return FloatingDynamics(FloatingTreeOf(*c.floating, std::get<UrdfParams>(c.plant.params)));
  }
  throw std::runtime_error("no floating instance " + instance);
}

// A base's pose as the page is sent it ({p, q: x y z w}) and the joints, as FloatingDynamics' full q.
VectorXd FloatingQ(const json& base, const json& joints) {
  VectorXd q(kFreeFlyerNq + static_cast<Eigen::Index>(joints.size()));
  for (int k = 0; k < 3; ++k) q[k] = base["p"][static_cast<std::size_t>(k)].get<double>();
  for (int k = 0; k < 4; ++k) q[3 + k] = base["q"][static_cast<std::size_t>(k)].get<double>();
  for (std::size_t k = 0; k < joints.size(); ++k)
    q[kFreeFlyerNq + static_cast<Eigen::Index>(k)] = joints[k].get<double>();
  return q;
}

// Every frame in `drawn` equals FloatingDynamics' placement at the full q (the base's pose, then the joints):
// `column_major` the page's three.js matrices (16 numbers), else the server's poses (R row by row, then p).
void ExpectFloatingPosesOf(const FloatingDynamics& dynamics, const json& drawn, const VectorXd& q, bool column_major,
                           const std::string& what) {
  auto data = dynamics.MakeData();
  dynamics.ComputeFramePlacements(*data, q);
  const auto& frames = dynamics.tree().frames;
  ASSERT_TRUE(drawn.is_array() && drawn.size() == frames.size()) << what << ": " << drawn.dump();
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const auto k = static_cast<int>(f);
    const std::string frame = what + " frame " + frames[f].name;
    if (column_major) {
      ExpectPose(drawn[f], data->frame_rotation(k), data->frame_position(k), frame);
      continue;
    }
    ASSERT_EQ(drawn[f].size(), 12u) << frame;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        EXPECT_NEAR(drawn[f][static_cast<std::size_t>(i * 3 + j)].get<double>(), data->frame_rotation(k)(i, j),
                    kPoseTolerance)
            << frame;
      EXPECT_NEAR(drawn[f][static_cast<std::size_t>(9 + i)].get<double>(), data->frame_position(k)(i), kPoseTolerance)
          << frame;
    }
  }
}

base_state_t BaseState(std::int64_t run, std::int64_t tick, double t, const Eigen::Vector3d& p,
                       const Eigen::Quaterniond& q) {
  base_state_t b{};
  b.run_id = run;
  b.tick = tick;
  b.t = t;
  for (int k = 0; k < 3; ++k) b.position[k] = p[k];
  const double xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
  std::copy_n(xyzw, 4, b.orientation);
  return b;
}

// The floating tree's state: joints q, setpoint q_des, under pd, running.
state_t TreeState(std::int64_t run, std::int64_t tick, const std::vector<double>& q, const std::vector<double>& q_des) {
  state_t s{};
  s.run_id = run;
  s.tick = tick;
  s.t = 1e-3 * static_cast<double>(tick);
  s.num_dofs = static_cast<std::int32_t>(q.size());
  s.q = q;
  s.q_des = q_des;
  s.qd = s.qdd = s.tau = s.qd_des = std::vector<double>(q.size(), 0.0);
  s.controller = "pd";
  s.mode = state_t::MODE_RUNNING;
  return s;
}

template <class Message>
std::vector<std::uint8_t> Encoded(const Message& m) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

void ExpectStreamedPosesOf(const Kinematics& kinematics, const json& poses, const std::vector<double>& q,
                           const std::string& what);

class ViewTest : public ::testing::Test {
 protected:
  // Starts lagrangectl view on 127.0.0.1:`port` and waits for its model to answer.
  void StartView(std::vector<std::string> args, int port) {
    port_ = port;
    args.insert(args.begin(), LAGRANGECTL_PATH);
    args.insert(args.begin() + 1, "view");
    for (const std::string& a : std::initializer_list<std::string>{"--port", std::to_string(port), "--bind", "127.0.0.1"})
      args.push_back(a);
    view_ = std::make_unique<BackgroundProcess>(args);
    httplib::Client client("127.0.0.1", port);
    for (int i = 0; i < 200; ++i) {
      if (auto r = client.Get("/api/model"); r && r->status == 200) {
        model_ = json::parse(r->body);
        return;
      }
      ASSERT_TRUE(view_->Running()) << view_->Stderr();
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    FAIL() << "lagrangectl view did not answer on port " << port << ": " << view_->Stderr();
  }
  void TearDown() override {
    if (view_) {
      view_->Signal(SIGINT);
      EXPECT_EQ(view_->Wait(10.0), 0) << view_->Stderr();
    }
    std::error_code error;
    if (!profile_.empty()) fs::remove_all(profile_, error);
  }
  // The page at `query` in headless chromium: the document after `budget_ms` of virtual time.
  std::string DumpDom(const std::string& query, int budget_ms = 4000) { return Chrome(query, budget_ms, "--dump-dom"); }
  // The same, as a PNG in `path` (its folder made first: chromium writes nothing, and says
  // nothing, when it is missing, as in the Release tree of scripts/test, which has no tests/tools/).
  void Screenshot(const std::string& query, const std::string& path, int budget_ms) {
    std::error_code error;
    fs::create_directories(fs::path(path).parent_path(), error);
    fs::remove(path, error);
    Chrome(query, budget_ms, "--screenshot=" + path);
  }
  std::string Chrome(const std::string& query, int budget_ms, const std::string& what) {
    if (profile_.empty()) {
      profile_ = (fs::temp_directory_path() / ("lagrange_view_test_" + std::to_string(getpid()) + "_" +
                                               std::to_string(port_)))
                     .string();
    }
    // --no-sandbox: chromium refuses to run as root (CI containers) with its sandbox; the page is our own.
    const testing::ProcessResult r = testing::RunProcess(
        {Chromium(), "--headless=new", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox",
         "--user-data-dir=" + profile_, "--window-size=1000,700", "--virtual-time-budget=" + std::to_string(budget_ms),
         what, "http://127.0.0.1:" + std::to_string(port_) + "/" + query},
        60.0);
    // No EXPECT here: the tests load the page again when a load drew nothing (a loaded machine), and
    // assert on what the page drew.
    if (r.exit_code != 0) std::fprintf(stderr, "chromium: exit %d: %s\n", r.exit_code, r.err.substr(0, 500).c_str());
    return r.out;
  }
  // DumpDom until the page has drawn `instance` (at most `attempts` loads): a loaded machine may
  // let the virtual-time budget run out before the page's fetches return.
  std::string DumpDomUntilDrawn(const std::string& query, const std::string& instance, int attempts = 3) {
    std::string dom;
    for (int a = 0; a < attempts; ++a) {
      dom = DumpDom(query);
      const std::string text = PreText(dom, "lagrange-drawn");
      if (!text.empty() && json::parse(text).contains(instance)) break;
    }
    return dom;
  }
  // What the page drew ({} when it drew nothing, or the load failed: the callers assert on its contents).
  static json Drawn(const std::string& dom) {
    const std::string text = PreText(dom, "lagrange-drawn");
    return text.empty() ? json::object() : json::parse(text);
  }
  static json Probe(const std::string& dom) {
    const std::string text = PreText(dom, "lagrange-probe");
    return text.empty() ? json::object() : json::parse(text);
  }

  int port_ = 0;
  std::string profile_;
  json model_;
  std::unique_ptr<BackgroundProcess> view_;
};

class ViewBrowser : public ViewTest {
 protected:
  void SetUp() override {
    if (Chromium().empty()) GTEST_SKIP() << "no chromium (Debian's chromium package)";
  }
};

TEST_F(ViewBrowser, UrdfPosesDrawnAreTheKinematicsAndAMissingMeshStillDraws) {
  StartView({"--urdf", kVisualArm}, 18360);
  const std::string dom = DumpDomUntilDrawn("?q=0.4,-0.7,1.1&probe=1&frames=1", "visual_arm");
  const json drawn = Drawn(dom);
  ASSERT_TRUE(drawn.contains("visual_arm")) << drawn.dump();
  const json& arm = drawn["visual_arm"];
  EXPECT_EQ(arm["q"], json::array({0.4, -0.7, 1.1}));
  const UrdfRobot robot = LoadUrdf(kVisualArm);
  ExpectPosesOf(Kinematics(robot.tree), arm["measured"], arm["q"], "urdf");
  // The hand's pose is not the identity: the q reached the kinematics.
  EXPECT_GT(std::abs(arm["measured"][3][12].get<double>() - 0.0), 0.05);
  EXPECT_GT(Probe(dom).value("nonblank", 0), 2000);
  // The missing Collada mesh is named; the STL and the Collada mesh beside the file loaded (no "did not load").
  EXPECT_NE(dom.find("package://absent/meshes/elbow.dae"), std::string::npos);
  EXPECT_EQ(dom.find("did not load"), std::string::npos);
  // A slider per joint, named as the file names them.
  for (const char* joint : {"shoulder", "elbow", "wrist"}) EXPECT_NE(dom.find(joint), std::string::npos) << joint;
}

TEST_F(ViewBrowser, LiveViewNamesInstancesAndFollowsTheArmToANewSetpoint) {
  constexpr int kLcmPort = 8360;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn"});
  StartView({"--lcm-url", url, "--scene", kDefaultScene}, 18361);
  const Kinematics arm_kinematics = SceneKinematics("arm"), cart_kinematics = SceneKinematics("cartpole");

  json before;
  std::string dom;
  for (int attempt = 0; attempt < 20 && !before.contains("arm"); ++attempt) {  // until lagranged is up
    dom = DumpDom("?probe=1&frames_max=3", 3000);
    before = Drawn(dom);
  }
  ASSERT_TRUE(before.contains("arm") && before.contains("cartpole")) << before.dump();
  EXPECT_NE(dom.find("running"), std::string::npos);
  EXPECT_NE(dom.find("computed-torque"), std::string::npos);
  ExpectPosesOf(arm_kinematics, before["arm"]["measured"], before["arm"]["q"], "arm");
  ExpectPosesOf(arm_kinematics, before["arm"]["ghost"], before["arm"]["q_des"], "arm setpoint");
  ExpectPosesOf(cart_kinematics, before["cartpole"]["measured"], before["cartpole"]["q"], "cartpole");
  const json probe_before = Probe(dom);
  EXPECT_GT(probe_before.value("nonblank", 0), 2000);

  const testing::CtlResult sent = testing::RunCtl({"send", "arm", "--q", "-0.5,1.2", "--for", "1", "--lcm-url", url});
  ASSERT_EQ(sent.status, 0) << sent.err;
  dom = DumpDomUntilDrawn("?probe=1&frames_max=3", "arm");
  const json after = Drawn(dom);
  ASSERT_TRUE(after.contains("arm")) << after.dump();
  ExpectPosesOf(arm_kinematics, after["arm"]["measured"], after["arm"]["q"], "arm after the setpoint");
  // The arm went to the setpoint (computed torque, ω = 10 rad/s: settled within the second it was sent)...
  EXPECT_NEAR(after["arm"]["q"][0].get<double>(), -0.5, 0.02);
  EXPECT_NEAR(after["arm"]["q"][1].get<double>(), 1.2, 0.02);
  // ...and the picture changed with it.
  EXPECT_NE(Probe(dom).value("checksum", -1), probe_before.value("checksum", -1));
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(10.0), 0);
}

// The README's picture: the Panda (its own lagranged, under --channel-prefix PANDA_, holding
// a pose under Cartesian impedance after a 2 s move) beside the arm and the cart-pole of the
// default scene, one view of two daemons. Its 7-joint poses are the spatial kinematics' to
// 1e-9, and its controller's target frame is drawn where the scene puts it (no joint ghost:
// the controller follows the target, not q_des).
TEST_F(ViewBrowser, ScreenshotOfThePandaAndTheArm) {
  constexpr int kLcmPort = 8368;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  const std::string panda_scene = std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_cartesian_impedance.yaml";
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn"});
  BackgroundProcess panda({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn", "--config", panda_scene,
                           "--channel-prefix", "PANDA_"});
  StartView({"--lcm-url", url, "--channel-prefix", "", "--scene", kDefaultScene, "--channel-prefix", "PANDA_",
             "--scene", panda_scene},
            18369);
  // Until both daemons are drawn and the Panda's 2 s move to its target is over.
  const auto ready = [](const json& d) {
    return d.contains("arm") && d.contains("PANDA_ panda") && d["PANDA_ panda"].value("t", 0.0) > 2.2;
  };
  json drawn;
  for (int attempt = 0; attempt < 20 && !ready(drawn); ++attempt) {
    drawn = Drawn(DumpDom("?frames_max=3", 3000));
    if (!ready(drawn)) std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  ASSERT_TRUE(ready(drawn)) << drawn.dump();
  const json& p = drawn["PANDA_ panda"];
  const Kinematics panda_kinematics = SceneKinematics("panda", panda_scene);
  ExpectPosesOf(panda_kinematics, p["measured"], p["q"], "panda");
  EXPECT_FALSE(p.contains("ghost")) << "a task-space controller follows its target, not q_des";
  ExpectPosesOf(SceneKinematics("arm"), drawn["arm"]["measured"], drawn["arm"]["q"], "arm");
  // The target: the scene's, drawn at its position with its orientation (w, x, y, z).
  ASSERT_TRUE(p.contains("target")) << p.dump();
  EXPECT_EQ(p["target"]["frame"], "panda_link8");
  const Eigen::Quaterniond orientation(0.0, 0.9238795325112867, -0.3826834323650898, 0.0);
  ExpectPose(p["target"]["matrix"], orientation.toRotationMatrix(), Eigen::Vector3d(0.40, 0.10, 0.50), "target");
  Screenshot("?frames_max=30", VIEW_SCREENSHOT_PATH, 3000);
  std::ifstream png(VIEW_SCREENSHOT_PATH, std::ios::binary);
  char magic[8] = {};
  png.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG") << VIEW_SCREENSHOT_PATH;
  for (BackgroundProcess* d : {&daemon, &panda}) {
    d->Signal(SIGTERM);
    EXPECT_EQ(d->Wait(10.0), 0);
  }
}

// The UR5 runs a Cartesian circle under operational-space control (config/ur5_circle.yaml): its
// controller follows the flange's task target, and q_des, the joint setpoint it does not use, stays
// at the start pose, 0.49 rad from the arm. The page draws the target where the flange is (the
// controller tracks it within micrometres) and no ghost of q_des.
TEST_F(ViewBrowser, UnderATaskSpaceControllerDrawsTheTaskTargetAndNoJointGhost) {
  constexpr int kLcmPort = 8600;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  const std::string scene = std::string(LAGRANGE_SOURCE_DIR) + "/config/ur5_circle.yaml";
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn", "--config", scene});
  StartView({"--lcm-url", url, "--scene", scene}, 18405);
  const auto ready = [](const json& d) { return d.contains("ur5") && d["ur5"].value("t", 0.0) > 1.5; };
  json drawn;
  for (int attempt = 0; attempt < 20 && !ready(drawn); ++attempt) {  // until lagranged is up and the ramp is over
    drawn = Drawn(DumpDom("?frames_max=3", 3000));
    if (!ready(drawn)) std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  ASSERT_TRUE(ready(drawn)) << drawn.dump();
  const json& ur5 = drawn["ur5"];
  const Kinematics kinematics = SceneKinematics("ur5", scene);
  ExpectPosesOf(kinematics, ur5["measured"], ur5["q"], "ur5");
  EXPECT_FALSE(ur5.contains("ghost")) << ur5.dump();
  ASSERT_TRUE(ur5.contains("target")) << ur5.dump();
  EXPECT_EQ(ur5["target"]["frame"], "flange");
  // The target is where the flange is: within the 0.16 mm the circle moves per tick, for the
  // few ticks between the state and the task state the frame was made of.
  const int flange = kinematics.FrameIndex("flange").value_or(-1);
  ASSERT_GE(flange, 0);
  const json& m = ur5["measured"][static_cast<std::size_t>(flange)];
  const Eigen::Vector3d drawn_flange(m[12].get<double>(), m[13].get<double>(), m[14].get<double>());
  const Eigen::Vector3d target(ur5["target"]["p"][0].get<double>(), ur5["target"]["p"][1].get<double>(),
                               ur5["target"]["p"][2].get<double>());
  EXPECT_LT((target - drawn_flange).norm(), 5e-3) << "target " << target.transpose() << ", flange "
                                                   << drawn_flange.transpose();
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(10.0), 0);
}

// A log written here: the arm's state every millisecond, q = (0.1 k, −0.05 k) at k ms, a
// malformed packet among them, a state of an instance the scene lacks, and a controller
// name that is markup.
std::string WriteArmLog(const fs::path& path) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;
  for (int k = 0; k <= 10; ++k) {
    state_t s{};
    s.run_id = 42;
    s.tick = k;
    s.t = 1e-3 * k;
    s.num_dofs = 2;
    s.q = {0.1 * k, -0.05 * k};
    s.qd = s.qdd = s.tau = {0.0, 0.0};
    s.q_des = {0.3, -0.2};
    s.qd_des = {0.0, 0.0};
    // A hostile controller name: markup and a terminal escape, which must reach the page as text.
    s.controller = "pd<img src=x onerror=\"document.title='owned'\">\x1b[2J";
    s.mode = state_t::MODE_RUNNING;
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(s.getEncodedSize()));
    s.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    events.emplace_back(k == 3 ? "STRANGER_STATE" : "ARM_STATE", bytes);
    if (k == 6) events.emplace_back("ARM_STATE", std::vector<std::uint8_t>{1, 2, 3});
  }
  testing::WriteLcmLog(path.string(), events);
  return path.string();
}

TEST_F(ViewBrowser, LogShowsTheLoggedPoseAtTheChosenTime) {
  const fs::path log = fs::temp_directory_path() / ("lagrange_view_log_" + std::to_string(getpid()) + ".lcm");
  WriteArmLog(log);
  StartView({"--log", log.string(), "--scene", kDefaultScene}, 18362);
  // Events k at (k + 1) ms in the logger's clock: t = 5.5 ms shows the state of k = 5.
  const std::string dom = DumpDomUntilDrawn("?t=0.0055&probe=1", "arm");
  fs::remove(log);
  const json drawn = Drawn(dom);
  ASSERT_TRUE(drawn.contains("arm")) << drawn.dump();
  EXPECT_EQ(drawn["arm"]["q"], json::array({0.1 * 5, -0.05 * 5}));
  ExpectPosesOf(SceneKinematics("arm"), drawn["arm"]["measured"], drawn["arm"]["q"], "logged arm");
  ExpectPosesOf(SceneKinematics("arm"), drawn["arm"]["ghost"], json::array({0.3, -0.2}), "logged setpoint");
  EXPECT_GT(Probe(dom).value("nonblank", 0), 2000);
  EXPECT_NE(dom.find("STRANGER_STATE is in the log but not in the scene"), std::string::npos);
  EXPECT_NE(dom.find("1 states that do not decode were passed over"), std::string::npos);
  // The bus's strings are text on the page: no element made of them, the escape written out.
  EXPECT_EQ(dom.find("<img"), std::string::npos);
  EXPECT_EQ(dom.find("owned</title>"), std::string::npos);
  EXPECT_NE(dom.find("pd&lt;img src=x"), std::string::npos);
  EXPECT_NE(dom.find("\\x1b[2J"), std::string::npos);
}

// A log written here: the swing-up's cart-pole under mpc, its state every millisecond (tick k at k ms,
// x = 0.01 k), and after the state of 4 ms a plan (sequence 7) of two knots, to θ = 3.14 at 2 s.
void WriteCartPolePlanLog(const fs::path& log) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;  // event i at (i + 1) ms
  const auto add = [&](const std::string& channel, const auto& m) {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    events.emplace_back(channel, bytes);
  };
  for (int k = 0; k <= 10; ++k) {
    state_t s{};
    s.run_id = 42;
    s.tick = k;
    s.t = 1e-3 * k;
    s.num_dofs = 2;
    s.q = {0.01 * k, 0.1};
    s.qd = s.qdd = s.tau = s.q_des = s.qd_des = {0.0, 0.0};
    s.controller = "mpc";
    add("CARTPOLE_STATE", s);
    if (k == 4) {  // logged at 5 ms, after the state of 4 ms
      mpc_t plan{};
      plan.run_id = 42;
      plan.t = 0.004;
      plan.controller = "mpc";
      plan.plan = 7;
      plan.status = "max-iterations";
      plan.followed = true;
      plan.num_states = 4;
      plan.num_knots = 2;
      plan.knot_t = {0.004, 2.004};
      plan.knot_x = {{0.04, 0.1, 0, 0}, {0.0, 3.14, 0, 0}};
      add("CARTPOLE_MPC", plan);
    }
  }
  testing::WriteLcmLog(log.string(), events);
}

// The page draws a logged plan: each frame's path through its knots (the record the page keeps of what it drew).
TEST_F(ViewBrowser, LogDrawsTheMpcPlanAsAPathPerFrame) {
  const fs::path log = fs::temp_directory_path() / ("lagrange_view_mpc_page_" + std::to_string(getpid()) + ".lcm");
  WriteCartPolePlanLog(log);
  StartView({"--log", log.string(), "--scene", std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_mpc_swingup.yaml"},
            8931);
  const std::string dom = DumpDomUntilDrawn("?t=0.0095&probe=1", "cartpole");
  fs::remove(log);
  const json drawn = Drawn(dom);
  ASSERT_TRUE(drawn.contains("cartpole")) << drawn.dump();
  ASSERT_TRUE(drawn["cartpole"].contains("plan")) << drawn.dump();
  EXPECT_EQ(drawn["cartpole"]["plan"]["sequence"], 7);
  EXPECT_EQ(drawn["cartpole"]["plan"]["paths"], model_["models"][0]["frames"].size()) << "a path per frame";
}

// A floating base in the page: the tree of floating_fall.yaml, its state and base state published here
// at a base pose neither the scene's start nor the origin, drawn on a ground at z = 0; the body (the
// base's own frame) is drawn at the published pose itself, and every frame where FloatingDynamics
// places it at that pose and the joints: the whole robot is where its base is. (That the drawing moves
// with a moving base: ViewTest.StreamsAFloatingInstanceOfLagrangedPlacedByItsMovingBase.)
TEST_F(ViewBrowser, AFloatingBaseIsDrawnWhereItsPublishedBaseIsOnAGround) {
  constexpr int kLcmPort = 9141;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  StartView({"--lcm-url", url, "--scene", kFloatingScene}, 9162);
  EXPECT_EQ(model_["models"][0]["floating_base"], true);
  const FloatingDynamics dynamics = SceneFloatingDynamics("tree", kFloatingScene);
  ASSERT_EQ(dynamics.tree().frames.front().name, "body") << "the root link, the base, is the first frame";
  const std::vector<double> q = {0.3, -0.2, -0.4, 0.5, 0.05};
  const Eigen::Vector3d p(0.4, -0.3, 0.7);
  const Eigen::Quaterniond r(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, -0.5).normalized()));
  std::atomic<bool> stop{false};
  std::thread daemon([&] {  // the tree's states and base states, as lagranged publishes them every tick
    lcm::LCM lcm(url);
    for (std::int64_t tick = 1; !stop; ++tick) {
      const state_t s = TreeState(21, tick, q, {0, 0, 0, 0, 0});
      lcm.publish("TREE_STATE", &s);
      const base_state_t b = BaseState(21, tick, s.t, p, r);
      lcm.publish("TREE_BASE", &b);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  const auto drawn = [](const json& d) { return d.contains("tree") && d["tree"].contains("measured"); };
  json d;
  for (int attempt = 0; attempt < 10 && !drawn(d); ++attempt) d = Drawn(DumpDom("?frames_max=3", 3000));
  stop = true;
  daemon.join();
  ASSERT_TRUE(drawn(d)) << d.dump() << view_->Stderr();
  const json& tree = d["tree"];
  ExpectPose(tree["measured"][0], r.toRotationMatrix(), p, "the body, the base");
  ExpectFloatingPosesOf(dynamics, tree["measured"], FloatingQ(tree["base"], tree["q"]), true, "tree");
  ExpectFloatingPosesOf(dynamics, tree["ghost"], FloatingQ(tree["base"], tree["q_des"]), true, "tree's setpoint");
  ASSERT_TRUE(tree.contains("ground")) << tree.dump();
  EXPECT_EQ(tree["ground"]["z"], 0.0);
}

// ---- the server, without a browser ----

// view --log: the plan logged on CARTPOLE_MPC is sent with the cart-pole's states logged after it, not before.
TEST_F(ViewTest, ALoggedPlanIsSentWithTheStatesLoggedAfterItAndNotBefore) {
  const fs::path log = fs::temp_directory_path() / ("lagrange_view_mpc_log_" + std::to_string(getpid()) + ".lcm");
  WriteCartPolePlanLog(log);
  StartView({"--log", log.string(), "--scene", std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_mpc_swingup.yaml"},
            8930);
  httplib::Client client("127.0.0.1", 8930);
  const auto frame = [&](const char* t) {
    const auto r = client.Get((std::string("/api/log?t=") + t).c_str());
    EXPECT_TRUE(r && r->status == 200);
    const json j = r ? json::parse(r->body) : json::object();
    return j.contains("instances") && !j["instances"].empty() ? j["instances"][0] : json::object();
  };
  const json before = frame("0.0045"), after = frame("0.0095");
  fs::remove(log);
  EXPECT_EQ(before.value("tick", -1), 4);
  EXPECT_FALSE(before.contains("plan")) << before.dump();
  ASSERT_TRUE(after.contains("plan")) << after.dump();
  EXPECT_EQ(after["plan"]["sequence"], 7);
  ASSERT_FALSE(after["plan"]["paths"].empty());
  EXPECT_EQ(after["plan"]["paths"][0].size(), 2u);
}

// An mpc controller's plan (mpc_t) as the page is sent it: every frame's path through the plan's knots, by
// the scene's kinematics, starting where the state puts the frames; sent only with a state of its run and
// controller that follows it within its horizon, and never for knots that are not the model's.
TEST_F(ViewTest, AnMpcPlanIsSentAsEachFramesPathThroughItsKnotsOnlyWithTheStateItBelongsTo) {
  const Scene scene = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_mpc_swingup.yaml");
  cli::view::ViewModels models;
  const cli::view::ViewModelOptions options{{}, scene.instances[0].torque_limits};
  models.push_back(std::make_unique<cli::view::ViewModel>("cartpole", scene.instances[0].plant, options));
  state_t s{};
  s.run_id = 9;
  s.t = 0.05;
  s.num_dofs = 2;
  s.q = {0.1, 0.5};
  for (auto* v : {&s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(2, 0.0);
  s.controller = "mpc";
  mpc_t plan{};
  plan.run_id = 9;
  plan.t = 0.04;
  plan.controller = "mpc";
  plan.plan = 3;
  plan.status = "converged";
  plan.followed = true;
  plan.num_states = 4;
  plan.num_knots = 3;
  plan.knot_t = {0.04, 1.04, 2.04};
  plan.knot_x = {{0.1, 0.5, 0, 0}, {0.2, 1.5, 0, 0}, {0.0, 3.1, 0, 0}};
  const cli::view::ViewInstance instance{"", "cartpole", 0};
  const json j = cli::view::InstanceJson(instance, models, s, 0.0, nullptr, &plan);
  ASSERT_TRUE(j.contains("plan")) << j.dump();
  EXPECT_EQ(j["plan"]["sequence"], 3);
  EXPECT_EQ(j["plan"]["status"], "converged");
  const json& paths = j["plan"]["paths"];
  ASSERT_EQ(paths.size(), j["poses"].size()) << "a path per frame";
  for (std::size_t f = 0; f < paths.size(); ++f) {
    ASSERT_EQ(paths[f].size(), 3u);
    const json end = models[0]->Poses(Eigen::Vector2d(0.0, 3.1));
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(paths[f][0][a].get<double>(), j["poses"][f][9 + a].get<double>(), 1e-12) << "starts at the state";
      EXPECT_NEAR(paths[f][2][a].get<double>(), end[f][9 + a].get<double>(), 1e-12) << "ends at the last knot";
    }
  }
  // Not the state's: another run, another controller, not followed, run out; knots not the model's.
  for (int k = 0; k < 5; ++k) {
    mpc_t other = plan;
    if (k == 0) other.run_id = 8;
    if (k == 1) other.controller = "lqr";
    if (k == 2) other.followed = false;
    if (k == 3) other.knot_t.back() = 0.045;
    if (k == 4) other.num_states = 6;
    EXPECT_FALSE(cli::view::InstanceJson(instance, models, s, 0.0, nullptr, &other).contains("plan")) << k;
  }
  mpc_t hostile = plan;
  hostile.knot_x[1] = {std::nan(""), 0, 0, 0};
  EXPECT_TRUE(cli::view::PlanJson(*models[0], hostile).is_null());
  hostile.knot_x[1] = {0, 0};
  EXPECT_TRUE(cli::view::PlanJson(*models[0], hostile).is_null());
}

// A floating base as the page is sent it: every frame (and the setpoint's ghost) in the world where
// FloatingDynamics places it at the full q (the base's pose, then the joints); without a base state of
// the state's run and time, or with one that is no pose, the instance is named and not drawn. A fixed
// base ignores a base state.
TEST_F(ViewTest, AFloatingBaseIsPlacedInTheWorldByItsBaseStateAsFloatingDynamicsPlacesIt) {
  const Scene scene = LoadScene(kFloatingScene);
  const InstanceConfig& c = scene.instances[0];
  ASSERT_TRUE(c.floating.has_value());
  cli::view::ViewModels models;
  models.push_back(
      std::make_unique<cli::view::ViewModel>("tree", c.plant, cli::view::ViewModelOptions{{}, c.torque_limits, true}));
  EXPECT_EQ(models[0]->geometry()["floating_base"], true);
  const FloatingDynamics dynamics = SceneFloatingDynamics("tree", kFloatingScene);
  const state_t s = TreeState(5, 200, {0.3, -0.2, -0.4, 0.5, 0.05}, {0.1, 0.2, 0.3, -0.4, 0.02});
  const Eigen::Quaterniond r(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, -0.5).normalized()));
  const base_state_t base = BaseState(5, 200, s.t, {0.4, -0.3, 0.7}, r);
  const cli::view::ViewInstance instance{"", "tree", 0};
  const json j = cli::view::InstanceJson(instance, models, s, 0.0, nullptr, nullptr, &base);
  ASSERT_TRUE(j.contains("poses") && j.contains("base")) << j.dump();
  EXPECT_EQ(j["base"]["p"], json::array({0.4, -0.3, 0.7}));
  EXPECT_EQ(j["base"]["tick"], 200);
  ExpectFloatingPosesOf(dynamics, j["poses"], FloatingQ(j["base"], j["q"]), false, "tree");
  ExpectFloatingPosesOf(dynamics, j["ghost"], FloatingQ(j["base"], j["q_des"]), false, "tree's setpoint");
  // Not drawn: no base state, another run's, one 0.5 s of simulated time off, a quaternion off unit, a NaN.
  std::vector<std::pair<std::optional<base_state_t>, std::string>> refused = {{std::nullopt, "TREE_BASE"}};
  base_state_t other = base;
  other.run_id = 6;
  refused.emplace_back(other, "TREE_BASE");
  other = base;
  other.t += 0.5;
  refused.emplace_back(other, "TREE_BASE");
  other = base;
  for (double& x : other.orientation) x *= 1.01;
  refused.emplace_back(other, "not unit");
  other = base;
  other.position[2] = std::nan("");
  refused.emplace_back(other, "not finite");
  for (const auto& [b, why] : refused) {
    const json n = cli::view::InstanceJson(instance, models, s, 0.0, nullptr, nullptr, b ? &*b : nullptr);
    EXPECT_FALSE(n.contains("poses") || n.contains("ghost")) << n.dump();
    EXPECT_EQ(n["name"], "tree");
    EXPECT_NE(n.value("note", "").find(why), std::string::npos) << n.dump();
  }
  // A fixed base (the default scene's arm) is drawn by its joints alone, whatever base state comes with it.
  const Scene arm_scene = LoadScene(kDefaultScene);
  cli::view::ViewModels fixed;
  fixed.push_back(
      std::make_unique<cli::view::ViewModel>("arm", arm_scene.instances[0].plant, cli::view::ViewModelOptions{}));
  EXPECT_EQ(fixed[0]->geometry()["floating_base"], false);
  state_t arm = TreeState(5, 200, {0.4, -0.3}, {0.0, 0.0});
  const json a = cli::view::InstanceJson({"", "arm", 0}, fixed, arm, 0.0, nullptr, nullptr, &base);
  EXPECT_FALSE(a.contains("base"));
  ExpectStreamedPosesOf(SceneKinematics(arm_scene.instances[0].name), a["poses"], {0.4, -0.3}, "arm");
}

// view --log of a floating base: each state is drawn at the base state of its own tick, logged just after
// it (so after the time asked for), and a state logged before any base state of its run is not drawn.
TEST_F(ViewTest, ALoggedFloatingBaseIsDrawnAtTheBaseStateOfItsStatesTick) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> events;  // event i at (i + 1) ms
  for (int k = 0; k <= 10; ++k) {
    events.emplace_back("TREE_STATE", Encoded(TreeState(3, k, {0.1 * k, 0, 0, 0, 0}, {0, 0, 0, 0, 0})));
    if (k >= 3) {  // none for the first three ticks
      const Eigen::Vector3d p(0.01 * k, 0.0, 1.0 - 0.001 * k);
      events.emplace_back("TREE_BASE", Encoded(BaseState(3, k, 1e-3 * k, p, Eigen::Quaterniond::Identity())));
    }
  }
  const fs::path log = fs::temp_directory_path() / ("lagrange_view_base_log_" + std::to_string(getpid()) + ".lcm");
  testing::WriteLcmLog(log.string(), events);
  StartView({"--log", log.string(), "--scene", kFloatingScene}, 9163);
  httplib::Client client("127.0.0.1", 9163);
  const auto tree_at = [&](double t) {
    const auto r = client.Get(("/api/log?t=" + std::to_string(t)).c_str());
    EXPECT_TRUE(r && r->status == 200);
    const json j = r ? json::parse(r->body) : json::object();
    return j.contains("instances") && !j["instances"].empty() ? j["instances"][0] : json::object();
  };
  // Events 0..2 are the states of ticks 0..2, then a state and its base per tick: tick k >= 3's state is
  // event 2k - 3, logged 2k - 3 ms after the first, and its base 1 ms later.
  const json fifth = tree_at(1e-3 * (2 * 5 - 3) + 5e-4);  // between state 5 and its base
  fs::remove(log);
  ASSERT_EQ(fifth.value("tick", -1), 5) << fifth.dump();
  ASSERT_TRUE(fifth.contains("base") && fifth.contains("poses")) << fifth.dump();
  EXPECT_EQ(fifth["base"]["tick"], 5);
  ExpectFloatingPosesOf(SceneFloatingDynamics("tree", kFloatingScene), fifth["poses"],
                        FloatingQ(fifth["base"], fifth["q"]), false, "logged tree");
  const json first = tree_at(1.5e-3);  // tick 1: no base state logged yet
  EXPECT_EQ(first.value("tick", -1), 1) << first.dump();
  EXPECT_FALSE(first.contains("poses")) << first.dump();
  EXPECT_NE(first.value("note", "").find("TREE_BASE"), std::string::npos) << first.dump();
}

// lagranged runs the floating tree (thrown up and falling, no ground): the view says its model floats,
// and streams it placed by the base states lagranged publishes, which move.
TEST_F(ViewTest, StreamsAFloatingInstanceOfLagrangedPlacedByItsMovingBase) {
  constexpr int kLcmPort = 9142;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn", "--config", kFloatingScene});
  StartView({"--lcm-url", url, "--scene", kFloatingScene}, 9164);
  EXPECT_EQ(model_["models"][0]["floating_base"], true);
  const FloatingDynamics dynamics = SceneFloatingDynamics("tree", kFloatingScene);
  std::vector<json> trees;  // the first frame that drew it, and one at least 0.1 s of simulated time later
  std::string stream;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (trees.size() < 2 && std::chrono::steady_clock::now() < end) {
    httplib::Client c("127.0.0.1", 9164);
    c.set_read_timeout(2, 0);
    c.Get("/api/stream", [&](const char* data, std::size_t n) {
      stream.append(data, n);
      for (std::size_t e = stream.find("\n\n"); e != std::string::npos; e = stream.find("\n\n")) {
        if (stream.rfind("data: ", 0) == 0) {
          const json frame = json::parse(stream.substr(6, e - 6));
          for (const json& i : frame["instances"]) {
            if (i["name"] != "tree" || !i.contains("poses")) continue;
            if (trees.empty() || (trees.size() < 2 && i["t"].get<double>() > trees[0]["t"].get<double>() + 0.1))
              trees.push_back(i);
          }
        }
        stream.erase(0, e + 2);
      }
      return trees.size() < 2 && std::chrono::steady_clock::now() < end;
    });
  }
  ASSERT_EQ(trees.size(), 2u) << view_->Stderr() << daemon.Stderr();
  for (const json& tree : trees) {
    EXPECT_LE(std::abs(tree["base"]["t"].get<double>() - tree["t"].get<double>()), 0.1) << tree.dump();
    ExpectFloatingPosesOf(dynamics, tree["poses"], FloatingQ(tree["base"], tree["q"]), false, "tree");
  }
  EXPECT_NE(trees[0]["base"]["p"], trees[1]["base"]["p"]) << "thrown, the base moves";
  EXPECT_NE(trees[0]["poses"][0], trees[1]["poses"][0]);
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(10.0), 0);
}

// view --urdf --floating-base: a file whose <joint type="floating"> frees its pelvis from the world
// (refused without the flag, in one line naming the joint) is drawn by its joints' model with the base at
// the origin, as FloatingDynamics places it there, on a ground; its skeleton has no rod from the world,
// which is no frame, to the base. A free body alone (no moving joint) is refused in one line.
TEST_F(ViewTest, ReadsAFloatingUrdfWithFloatingBase) {
  const std::string file = std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/urdf/view/floating_leg.urdf";
  const testing::CtlResult fixed = testing::RunCtl({"view", "--urdf", file, "--port", "9166"});
  EXPECT_NE(fixed.status, 0);
  EXPECT_NE(fixed.err.find("joint 'float': type 'floating'"), std::string::npos) << fixed.err;
  const testing::CtlResult brick =
      testing::RunCtl({"view", "--urdf", std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/urdf/brick.urdf",
                       "--floating-base", "--port", "9166"});
  EXPECT_NE(brick.status, 0);
  EXPECT_NE(brick.err.find("brick.urdf: no moving joint"), std::string::npos) << brick.err;
  EXPECT_EQ(std::count(brick.err.begin(), brick.err.end(), '\n'), 1) << brick.err;
  StartView({"--urdf", file, "--floating-base"}, 9165);
  const json& model = model_["models"][0];
  EXPECT_EQ(model["floating_base"], true);
  EXPECT_EQ(model["dofs"], 1);
  for (const json& shape : model["shapes"]) {
    if (shape["type"] == "rod") {
      EXPECT_GE(shape["from"].get<int>(), 0) << shape.dump();
    }
  }
  httplib::Client client("127.0.0.1", 9165);
  const auto r = client.Get("/api/poses?q=0.5");
  ASSERT_TRUE(r && r->status == 200);
  const json leg = json::parse(r->body)["instances"][0];
  const json origin = {{"p", {0, 0, 0}}, {"q", {0, 0, 0, 1}}};
  const UrdfRobot robot = LoadUrdf(file, {.floating_base = true});
  ExpectFloatingPosesOf(FloatingDynamics(robot.tree), leg["poses"], FloatingQ(origin, leg["q"]), false, "leg");
}

TEST_F(ViewTest, RefusesAFileThatIsNotALog) {
  const fs::path bad = fs::temp_directory_path() / ("lagrange_view_notalog_" + std::to_string(getpid()));
  std::ofstream(bad) << "not a log\n";
  const testing::CtlResult r = testing::RunCtl({"view", "--log", bad.string(), "--port", "18363"});
  fs::remove(bad);
  EXPECT_EQ(r.status, 1) << r.err;
  ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
  EXPECT_NE(r.err.find("is not an LCM log"), std::string::npos) << r.err;
}

TEST_F(ViewTest, RefusesAMissingThreeJsDirectoryInOneLine) {
  const testing::CtlResult r =
      testing::RunCtl({"view", "--urdf", kVisualArm, "--three", "/nonexistent/three", "--port", "18364"});
  EXPECT_EQ(r.status, 2) << r.err;
  ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
  EXPECT_NE(r.err.find("three.js not found in /nonexistent/three"), std::string::npos) << r.err;
}

TEST_F(ViewTest, SaysInOneLineWhenItsPortIsTaken) {
  StartView({"--urdf", kVisualArm}, 18378);
  const testing::CtlResult r = testing::RunCtl({"view", "--urdf", kVisualArm, "--port", "18378", "--bind", "127.0.0.1"});
  EXPECT_EQ(r.status, 1) << r.err;
  ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
  EXPECT_NE(r.err.find("cannot listen on 127.0.0.1:18378"), std::string::npos) << r.err;
}

TEST_F(ViewTest, RefusesABadUrdfInOneLine) {
  const testing::CtlResult r = testing::RunCtl({"view", "--urdf", "/nonexistent.urdf", "--port", "18365"});
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
}

// Visuals the viewer cannot draw are each named on the page, in one line, and the robot is
// drawn without them: nothing about a <visual> stops the view.
TEST_F(ViewTest, VisualsItCannotDrawAreNamedAndSkipped) {
  const fs::path dir = fs::temp_directory_path() / ("lagrange_view_visuals_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::string urdf = testing::ReadFile(kVisualArm);
  const auto replace = [&](const std::string& from, const std::string& to) {
    const std::size_t at = urdf.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    urdf.replace(at, from.size(), to);
  };
  replace("<box size=\"0.2 0.2 0.05\"/>", "<box size=\"0.2 nan\"/>");
  replace("<sphere radius=\"0.03\"/>", "<capsule radius=\"0.03\" length=\"0.1\"/>");
  replace("meshes/tetra.stl", "meshes/tetra.obj");
  std::ofstream(dir / "robot.urdf") << urdf;
  fs::create_directories(dir / "meshes");
  std::ofstream(dir / "meshes" / "tetra.obj") << "v 0 0 0\n";
  fs::copy_file(fs::path(kVisualArm).parent_path() / "meshes" / "marker.dae", dir / "meshes" / "marker.dae");
  StartView({"--urdf", (dir / "robot.urdf").string()}, 18376);
  fs::remove_all(dir);
  const json& missing = model_["models"][0]["missing"];
  const std::string all = missing.dump();
  EXPECT_EQ(missing.size(), 4u) << all;  // the three above and the package:// mesh
  EXPECT_NE(all.find("link 'base' <visual> 1: <box size> is not 3 finite numbers; not drawn"), std::string::npos) << all;
  EXPECT_NE(all.find("geometry 'capsule' is not box, cylinder, sphere or mesh; not drawn"), std::string::npos) << all;
  EXPECT_NE(all.find("mesh 'meshes/tetra.obj' is neither STL nor Collada (.dae); its frame is drawn"), std::string::npos)
      << all;
  // What it can draw is still there: the two cylinders and the Collada marker.
  EXPECT_EQ(model_["models"][0]["shapes"].size(), 3u) << model_["models"][0]["shapes"].dump();
}

TEST_F(ViewTest, PosesForBadJointValuesAreRefusedNotComputed) {
  StartView({"--urdf", kVisualArm}, 18366);
  httplib::Client client("127.0.0.1", 18366);
  for (const char* q : {"1,2", "1,2,3,4", "nan,0,0", "1e999,0,0", "a,b,c"}) {
    auto r = client.Get((std::string("/api/poses?q=") + q).c_str());
    ASSERT_TRUE(r) << q;
    EXPECT_EQ(r->status, 400) << q;
  }
  auto ok = client.Get("/api/poses?q=0.1,0.2,0.3");
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, 200);
  // The server serves only the files it was given: the three.js directory and the URDF's resolved meshes.
  EXPECT_EQ(client.Get("/three/../../../../etc/passwd")->status, 404);
  EXPECT_EQ(client.Get("/mesh/0/0")->status, 200);
  EXPECT_EQ(client.Get("/mesh/0/1")->status, 200);
  EXPECT_EQ(client.Get("/mesh/0/2")->status, 404);
  EXPECT_EQ(client.Get("/mesh/7/0")->status, 404);
}

// The page only reads: any other method is refused before its body is read, so nothing a client sends
// is held (cpp-httplib would read a POST's body whole, a chunked one without any bound, and route it: 404).
TEST_F(ViewTest, RefusesEveryMethodButGetBeforeReadingItsBody) {
  constexpr int kPort = 18470;
  signal(SIGPIPE, SIG_IGN);  // the view closes a refused request's connection: a client still sending gets EPIPE
  StartView({"--urdf", kVisualArm}, kPort);
  const auto post = httplib::Client("127.0.0.1", kPort).Post("/api/poses", "q=0,0,0", "text/plain");
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 405);
  EXPECT_EQ(post->get_header_value("Allow"), "GET, HEAD");
  const auto put = httplib::Client("127.0.0.1", kPort).Put("/", "q=1", "text/plain");
  ASSERT_TRUE(put);
  EXPECT_EQ(put->status, 405);
  // A body of 1 MB, and a chunked one of no stated length: refused as soon as the headers are in (or the
  // connection closed under the client still sending), never read to its end and routed.
  const auto big = httplib::Client("127.0.0.1", kPort).Post("/", std::string(1 << 20, 'x'), "text/plain");
  if (big) {
    EXPECT_EQ(big->status, 405);
  }
  std::size_t sent = 0;
  const std::string chunk(1 << 16, 'x');
  const auto chunked = httplib::Client("127.0.0.1", kPort)
                           .Post(
                               "/api/model",
                               [&](std::size_t, httplib::DataSink& sink) {
                                 if (sent >= (16u << 20)) {
                                   sink.done();
                                   return true;
                                 }
                                 sent += chunk.size();
                                 return sink.write(chunk.data(), chunk.size());
                               },
                               "application/octet-stream");
  if (chunked) {
    EXPECT_EQ(chunked->status, 405);
  }
  // The view serves on.
  const auto model = httplib::Client("127.0.0.1", kPort).Get("/api/model");
  ASSERT_TRUE(model);
  EXPECT_EQ(model->status, 200);
}

TEST_F(ViewTest, StreamsToAtMostMaxClientsAndOutlivesOneThatLeaves) {
  constexpr int kLcmPort = 8366;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  StartView({"--lcm-url", testing::TestLcmUrl(kLcmPort), "--scene", kDefaultScene, "--max-clients", "2"}, 18367);
  // Two browsers stream (each its own connection, held open by a thread reading the stream)...
  std::atomic<bool> stop{false};
  std::atomic<int> chunks{0};
  std::vector<std::thread> readers;
  for (int i = 0; i < 2; ++i) {
    readers.emplace_back([&] {
      httplib::Client c("127.0.0.1", 18367);
      c.set_read_timeout(5, 0);
      c.Get("/api/stream", [&](const char*, std::size_t) {
        ++chunks;
        return !stop.load();  // false: the browser leaves mid-stream
      });
    });
  }
  for (int i = 0; i < 100 && chunks.load() < 4; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_GE(chunks.load(), 4);
  // ...a third is refused while they do...
  httplib::Client third("127.0.0.1", 18367);
  auto refused = third.Get("/api/stream");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 503);
  EXPECT_NE(refused->body.find("--max-clients"), std::string::npos);
  // ...and once they leave, a new one is served.
  stop = true;
  for (std::thread& t : readers) t.join();
  std::atomic<int> later{0};
  for (int i = 0; i < 50 && later.load() == 0; ++i) {
    httplib::Client c("127.0.0.1", 18367);
    auto r = c.Get("/api/stream", [&](const char*, std::size_t) {
      ++later;
      return false;
    });
    if (later.load() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_GT(later.load(), 0);
}

// lagranged runs the default scene (the arm, the cart-pole); the view is given a scene of the
// pendulum alone: the daemon's instances are listed, as text, and not drawn.
TEST_F(ViewTest, InstancesTheSceneLacksAreNamedNotDrawn) {
  constexpr int kLcmPort = 8372;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn"});
  StartView({"--lcm-url", url, "--scene", std::string(LAGRANGE_SOURCE_DIR) + "/config/pendulum.yaml"}, 18373);
  // The stream's events ("data: JSON\n\n"), however the chunks fall, until one names the arm.
  std::string stream, frame;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < end && frame.find("\"arm\"") == std::string::npos) {
    httplib::Client c("127.0.0.1", 18373);
    c.set_read_timeout(2, 0);
    c.Get("/api/stream", [&](const char* data, std::size_t n) {
      stream.append(data, n);
      for (std::size_t e = stream.find("\n\n"); e != std::string::npos; e = stream.find("\n\n")) {
        if (stream.rfind("data: ", 0) == 0) frame = stream.substr(6, e - 6);
        stream.erase(0, e + 2);
      }
      return frame.find("\"arm\"") == std::string::npos && std::chrono::steady_clock::now() < end;
    });
  }
  ASSERT_NE(frame.find("\"arm\""), std::string::npos) << frame;
  const json j = json::parse(frame);
  for (const json& instance : j["instances"]) {
    EXPECT_EQ(instance["model"], -1) << instance.dump();
    EXPECT_FALSE(instance.contains("poses"));
    EXPECT_NE(instance["note"].get<std::string>().find("not in the scene: not drawn"), std::string::npos);
  }
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(10.0), 0);
}

// Reads the view's stream for at most `seconds`, calling `on_arm` with the arm
// of each frame that draws it (its instance has poses), until `on_arm` returns false.
void ForEachStreamedArm(int port, double seconds, const std::function<bool(const json&)>& on_arm) {
  std::string stream;
  bool more = true;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (more && std::chrono::steady_clock::now() < end) {
    httplib::Client c("127.0.0.1", port);
    c.set_read_timeout(2, 0);
    c.Get("/api/stream", [&](const char* data, std::size_t n) {
      stream.append(data, n);
      for (std::size_t e = stream.find("\n\n"); more && e != std::string::npos; e = stream.find("\n\n")) {
        if (stream.rfind("data: ", 0) == 0) {
          const json frame = json::parse(stream.substr(6, e - 6));
          for (const json& i : frame["instances"])
            if (more && i["name"] == "arm" && i.contains("poses")) more = on_arm(i);
        }
        stream.erase(0, e + 2);
      }
      return more && std::chrono::steady_clock::now() < end;
    });
  }
}

// The arm's frames from the stream for `seconds`: the q of every frame that drew it.
std::vector<std::vector<double>> StreamedArmQ(int port, double seconds) {
  std::vector<std::vector<double>> qs;
  ForEachStreamedArm(port, seconds, [&](const json& arm) {
    qs.push_back(arm["q"].get<std::vector<double>>());
    return true;
  });
  return qs;
}

// lagranged and the view share a key; a forger publishes unsigned arm states meanwhile: the view
// draws the daemon's arm and never the forger's.
TEST_F(ViewTest, OnASignedBusDrawsOnlySignedStates) {
  constexpr int kLcmPort = 8374;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  const fs::path key = fs::temp_directory_path() / ("lagrange_view_key_" + std::to_string(getpid()));
  fs::remove(key);
  ASSERT_EQ(testing::RunCtl({"keygen", key.string()}).status, 0);
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn", "--bus-key", key.string()});
  StartView({"--lcm-url", url, "--scene", kDefaultScene, "--bus-key", key.string()}, 18375);
  std::atomic<bool> stop{false};
  std::thread forger([&] {
    lcm::LCM lcm(url);
    state_t s{};
    s.run_id = 7;
    s.num_dofs = 2;
    s.q = {2.5, 2.5};
    s.qd = s.qdd = s.tau = s.q_des = s.qd_des = {0.0, 0.0};
    s.controller = "forged";
    while (!stop) {
      ++s.tick;
      lcm.publish("ARM_STATE", &s);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  std::vector<std::vector<double>> qs;
  for (int i = 0; i < 10 && qs.empty(); ++i) qs = StreamedArmQ(18375, 1.0);
  stop = true;
  forger.join();
  fs::remove(key);
  ASSERT_FALSE(qs.empty()) << view_->Stderr() << daemon.Stderr();
  for (const auto& q : qs) EXPECT_NE(q, std::vector<double>({2.5, 2.5}));
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(10.0), 0);
}

// An emergency stop, cleared at once: the frames sent afterwards still say when it happened.
TEST_F(ViewTest, KeepsTheMomentAnInstanceWasStopped) {
  constexpr int kLcmPort = 8376;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  BackgroundProcess daemon({LAGRANGED_PATH, "--lcm-url", url, "--log-level", "warn"});
  StartView({"--lcm-url", url, "--scene", kDefaultScene}, 18377);
  ASSERT_EQ(testing::RunCtl({"command", "arm", "estop", "--lcm-url", url}).status, 0);
  ASSERT_EQ(testing::RunCtl({"command", "arm", "clear", "--lcm-url", url}).status, 0);
  json arm;
  std::string stream;
  httplib::Client c("127.0.0.1", 18377);
  c.set_read_timeout(5, 0);
  c.Get("/api/stream", [&](const char* data, std::size_t n) {
    stream.append(data, n);
    for (std::size_t e = stream.find("\n\n"); e != std::string::npos; e = stream.find("\n\n")) {
      if (stream.rfind("data: ", 0) == 0) {
        const json frame = json::parse(stream.substr(6, e - 6));
        for (const json& i : frame["instances"])
          if (i["name"] == "arm") arm = i;
      }
      stream.erase(0, e + 2);
    }
    return arm.is_null() || arm["mode"] != "hold";  // the first frames may predate the clear
  });
  ASSERT_FALSE(arm.is_null());
  EXPECT_EQ(arm["mode"], "hold");  // cleared: estop leaves into hold
  ASSERT_TRUE(arm.contains("event")) << arm.dump();
  EXPECT_EQ(arm["event"]["mode"], "estop");
  EXPECT_LT(arm["event"]["tick"].get<std::int64_t>(), arm["tick"].get<std::int64_t>());
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(10.0), 0);
}

// The arm as the view streams it while `publish` sends its states: the first frame of at most
// `seconds` that draws it and satisfies `done` (or the last that drew it).
json StreamedArmUntil(int port, double seconds, const std::function<bool(const json&)>& done) {
  json arm;
  ForEachStreamedArm(port, seconds, [&](const json& a) {
    arm = a;
    return !done(arm);
  });
  return arm;
}

// Every frame's pose in a streamed instance (R row by row, then p: 12 numbers) equals the
// kinematics' at q.
void ExpectStreamedPosesOf(const Kinematics& kinematics, const json& poses, const std::vector<double>& q,
                           const std::string& what) {
  auto data = kinematics.MakeData();
  kinematics.ComputeFramePlacements(*data, Eigen::Map<const VectorXd>(q.data(), static_cast<Eigen::Index>(q.size())));
  ASSERT_TRUE(poses.is_array() && static_cast<int>(poses.size()) == kinematics.num_frames()) << what;
  for (int f = 0; f < kinematics.num_frames(); ++f) {
    const json& m = poses[static_cast<std::size_t>(f)];
    ASSERT_EQ(m.size(), 12u) << what;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(m[i * 3 + j].get<double>(), data->rotation(f)(i, j), kPoseTolerance);
      EXPECT_NEAR(m[9 + i].get<double>(), data->position(f)(i), kPoseTolerance) << what << " frame " << f;
    }
  }
}

// The plant half of a two-process loop (config/arm_external_plant.yaml) runs the arm under the
// external controller: while running it applies the torques streamed to it, and its q_des is only
// the hold it falls back to, followed by nothing, so no ghost is drawn of it; once held (streamed
// torques timed out) the hold follows q_des and its ghost is drawn there. The states are the
// view's input as such a daemon publishes them (controller "external", mode running, then hold).
TEST_F(ViewTest, UnderTheExternalControllerDrawsNoGhostWhileItAppliesStreamedTorques) {
  constexpr int kLcmPort = 8601;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  StartView({"--lcm-url", url, "--scene", kDefaultScene}, 18406);
  std::atomic<std::int8_t> mode{state_t::MODE_RUNNING};
  std::atomic<bool> stop{false};
  std::thread plant([&] {
    lcm::LCM lcm(url);
    state_t s{};
    s.run_id = 11;
    s.num_dofs = 2;
    s.q = {0.4, -0.3};
    s.q_des = {0.0, 0.0};  // the hold: where the arm started, 0.5 rad away
    s.qd = s.qdd = s.tau = s.qd_des = {0.0, 0.0};
    s.controller = "external";
    while (!stop) {
      ++s.tick;
      s.t = 1e-3 * static_cast<double>(s.tick);
      s.mode = mode;
      lcm.publish("ARM_STATE", &s);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  const json running = StreamedArmUntil(18406, 20.0, [](const json& a) { return a["mode"] == "running"; });
  mode = state_t::MODE_HOLD;
  const json held = StreamedArmUntil(18406, 20.0, [](const json& a) { return a["mode"] == "hold"; });
  stop = true;
  plant.join();
  ASSERT_EQ(running.value("mode", ""), "running") << running.dump() << view_->Stderr();
  EXPECT_EQ(running["controller"], "external");
  EXPECT_FALSE(running.contains("ghost")) << "the external controller, running, follows no joint setpoint: "
                                          << running.dump();
  ASSERT_EQ(held.value("mode", ""), "hold") << held.dump();
  ASSERT_TRUE(held.contains("ghost")) << "held, it follows q_des: " << held.dump();
  const Kinematics kinematics = SceneKinematics("arm");
  ExpectStreamedPosesOf(kinematics, held["ghost"], {0.0, 0.0}, "arm's hold");
  ExpectStreamedPosesOf(kinematics, held["poses"], {0.4, -0.3}, "arm");
}

TEST_F(ViewTest, ListensAndNeverPublishes) {
  constexpr int kLcmPort = 8370;
  ASSERT_EQ(testing::PrepareLoopbackMulticast(kLcmPort), "");
  const std::string url = testing::TestLcmUrl(kLcmPort);
  lcm::LCM lcm(url);
  ASSERT_TRUE(lcm.good());
  int heard = 0;
  lcm.subscribeFunction(".*", +[](const lcm::ReceiveBuffer*, const std::string&, int* n) { ++*n; }, &heard);
  StartView({"--lcm-url", url, "--scene", kDefaultScene}, 18371);
  std::atomic<int> chunks{0};
  std::thread browser([&] {  // a browser streaming meanwhile
    httplib::Client c("127.0.0.1", 18371);
    c.Get("/api/stream", [&](const char*, std::size_t) { return ++chunks < 20; });
  });
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (std::chrono::steady_clock::now() < end) lcm.handleTimeout(50);
  browser.join();
  EXPECT_GE(chunks.load(), 20);
  EXPECT_EQ(heard, 0);
  // The subscriber hears what is published on that bus: the test can fail.
  const char byte = 1;
  lcm.publish("LAGRANGE_TEST_VIEW", &byte, 1);
  for (int i = 0; i < 20 && heard == 0; ++i) lcm.handleTimeout(50);
  EXPECT_EQ(heard, 1);
}

// ---- the connections: slow, idle and oversized clients ----

// 30 clients send a request header a byte at a time and go on (slowloris) while a browser asks
// for the page: cpp-httplib alone gave each a thread of its --max-clients + 4 for as long as it
// went on, and the page was never answered. The gate holds them apart from the threads and
// closes each when its header is not in within its deadline.
TEST_F(ViewTest, AnswersThePageWhileThirtySlowlorisClientsTrickleTheirHeaders) {
  constexpr int kPort = 18400;
  StartView({"--urdf", kVisualArm}, kPort);
  std::vector<int> slow;
  for (int i = 0; i < 30; ++i) {
    const int fd = Connect(kPort);
    ASSERT_GE(fd, 0) << i;
    SendAll(fd, "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ");
    slow.push_back(fd);
  }
  std::atomic<bool> stop{false};
  std::thread trickle([&] {
    while (!stop) {
      for (int fd : slow) send(fd, "a", 1, MSG_NOSIGNAL | MSG_DONTWAIT);
      for (int i = 0; i < 5 && !stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // they are in
  httplib::Client browser("127.0.0.1", kPort);
  browser.set_connection_timeout(30);
  browser.set_read_timeout(30);
  const auto page = browser.Get("/");
  stop = true;
  trickle.join();
  for (int fd : slow) close(fd);
  ASSERT_TRUE(page) << "no answer within 30 s";
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("viewer.js"), std::string::npos);
}

// 1000 clients connect and say nothing, and stay: the page is still answered. (cpp-httplib alone
// gave each idle connection a thread for its keep-alive timeout, 5 s, one --max-clients + 4 at a
// time: the page waited minutes.) The gate keeps at most 32 waiting connections of one address,
// closing the oldest for a new one.
TEST_F(ViewTest, AnswersThePageWhileAThousandIdleConnectionsStayOpen) {
  constexpr int kPort = 18401, kIdle = 1000;
  rlimit files{};
  ASSERT_EQ(getrlimit(RLIMIT_NOFILE, &files), 0);
  files.rlim_cur = std::max<rlim_t>(files.rlim_cur, std::min<rlim_t>(files.rlim_max, 4096));
  setrlimit(RLIMIT_NOFILE, &files);  // the test's connections, and the view's (it inherits the limit)
  ASSERT_EQ(getrlimit(RLIMIT_NOFILE, &files), 0);
  if (files.rlim_cur < 2 * kIdle + 200) GTEST_SKIP() << "open files limited to " << files.rlim_cur;
  StartView({"--urdf", kVisualArm}, kPort);
  std::vector<int> idle;
  for (int i = 0; i < kIdle; ++i) {
    const int fd = Connect(kPort);
    ASSERT_GE(fd, 0) << i << ": " << std::strerror(errno);
    idle.push_back(fd);
  }
  httplib::Client browser("127.0.0.1", kPort);
  browser.set_connection_timeout(30);
  browser.set_read_timeout(30);
  const auto page = browser.Get("/");
  for (int fd : idle) close(fd);
  ASSERT_TRUE(page) << "no answer within 30 s";
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("viewer.js"), std::string::npos);
}

// A request header that does not end within 16 KiB is answered 431 and closed (httplib would read
// header lines without end), and the view serves on.
TEST_F(ViewTest, RefusesARequestHeaderLongerThan16KiB) {
  constexpr int kPort = 18402;
  StartView({"--urdf", kVisualArm}, kPort);
  const int fd = Connect(kPort);
  ASSERT_GE(fd, 0);
  std::string header = "GET / HTTP/1.1\r\n";
  while (header.size() < (16u << 10)) header += "X-Filler: 0123456789abcdef0123456789abcdef\r\n";
  header.resize(16u << 10);  // exactly the bound, no blank line: all of it read, none left over
  SendAll(fd, header);
  timeval timeout{30, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  std::string reply;
  char buffer[1024];
  for (ssize_t n; (n = recv(fd, buffer, sizeof buffer, 0)) > 0;) reply.append(buffer, static_cast<std::size_t>(n));
  close(fd);
  EXPECT_TRUE(reply.starts_with("HTTP/1.1 431 ")) << reply.substr(0, 200);
  const auto model = httplib::Client("127.0.0.1", kPort).Get("/api/model");
  ASSERT_TRUE(model);
  EXPECT_EQ(model->status, 200);
}

// ---- a robot package's meshes ----

// A binary STL of `triangles` triangles whose count field says `count`.
std::string BinaryStl(std::uint32_t triangles, std::uint32_t count) {
  std::string bytes(80, ' ');
  bytes.replace(0, 6, "binary");
  for (int k = 0; k < 4; ++k) bytes += static_cast<char>((count >> (8 * k)) & 0xff);
  return bytes + std::string(50 * triangles, '\0');
}

// A package whose URDF names meshes inside it and out of it, directly, by "..", by symlinks (one to
// /etc/shadow) and through --package-path, and files whose bytes are not what their names say. Only
// the meshes whose canonical path lies under the URDF's folder or a --package-path, and whose bytes
// are an STL or Collada file, are served; each of the others is named on the page, not drawn, its
// link's frame drawn instead. A mesh swapped for a symlink after the start is not served either.
TEST_F(ViewTest, ServesOnlyMeshesInsideTheRobotsPackageThatAreMeshes) {
  const fs::path base = fs::temp_directory_path() / ("lagrange_view_package_" + std::to_string(getpid()));
  fs::remove_all(base);
  for (const char* dir : {"secret", "robot/meshes", "share/pkg/meshes"}) fs::create_directories(base / dir);
  const std::string mesh = BinaryStl(1, 1), secret = BinaryStl(2, 2);
  std::ofstream(base / "secret/secret.stl") << secret;
  std::ofstream(base / "outside.stl") << secret;
  std::ofstream(base / "robot/meshes/ok.stl") << mesh;
  std::ofstream(base / "share/pkg/meshes/ok.stl") << mesh;
  std::ofstream(base / "robot/meshes/fake.stl") << "root:x:0:0:root:/root:/bin/bash\n";
  std::ofstream(base / "robot/meshes/short.stl") << BinaryStl(1, 5);
  std::ofstream(base / "robot/meshes/fake.dae") << "<?xml version=\"1.0\"?>\n<html><body>no mesh</body></html>\n";
  fs::create_symlink("ok.stl", base / "robot/meshes/in_link.stl");
  fs::create_symlink("../../secret/secret.stl", base / "robot/meshes/out_link.stl");
  fs::create_symlink("/etc/shadow", base / "robot/meshes/shadow.stl");
  fs::create_symlink("../../../secret/secret.stl", base / "share/pkg/meshes/escape.stl");
  const std::vector<std::string> meshes = {
      "meshes/ok.stl", "meshes/in_link.stl", "package://pkg/meshes/ok.stl",  // served
      "../outside.stl", "meshes/out_link.stl", "meshes/shadow.stl", "package://pkg/meshes/escape.stl",
      "file://" + (base / "secret/secret.stl").string(), "meshes/fake.stl", "meshes/short.stl", "meshes/fake.dae"};
  std::string visuals;
  for (const std::string& m : meshes) visuals += "<visual><geometry><mesh filename=\"" + m + "\"/></geometry></visual>";
  std::ofstream(base / "robot/robot.urdf")
      << "<robot name=\"package_arm\"><link name=\"base\">" << visuals << "</link>"
      << "<link name=\"arm\"><inertial><origin xyz=\"0.1 0 0\"/><mass value=\"1\"/>"
      << "<inertia ixx=\"0.001\" ixy=\"0\" ixz=\"0\" iyy=\"0.001\" iyz=\"0\" izz=\"0.001\"/></inertial></link>"
      << "<joint name=\"j\" type=\"revolute\"><parent link=\"base\"/><child link=\"arm\"/><axis xyz=\"0 0 1\"/>"
      << "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint></robot>";
  constexpr int kPort = 18403;
  StartView({"--urdf", (base / "robot/robot.urdf").string(), "--package-path", (base / "share").string()}, kPort);
  const json& model = model_["models"][0];
  EXPECT_EQ(model["shapes"].size(), 3u) << model["shapes"].dump();
  const std::string missing = model["missing"].dump();
  EXPECT_EQ(model["missing"].size(), meshes.size() - 3) << missing;
  for (std::size_t k = 3; k < meshes.size(); ++k) {
    const std::string name = "mesh '" + meshes[k] + "' ";
    const std::size_t at = missing.find(name);
    ASSERT_NE(at, std::string::npos) << name << " in " << missing;
    EXPECT_NE(missing.find("; its frame is drawn", at), std::string::npos) << name;
    const std::string why = k < 8 ? "leads outside the URDF's folder and every --package-path: not served"
                                  : k == 10 ? "is not a Collada file" : "is not an STL file";
    EXPECT_EQ(missing.find(why, at), at + name.size()) << name << " in " << missing;
  }
  httplib::Client client("127.0.0.1", kPort);
  for (int k = 0; k < 3; ++k) {
    const auto r = client.Get(("/mesh/0/" + std::to_string(k)).c_str());
    ASSERT_TRUE(r) << k;
    EXPECT_EQ(r->status, 200) << k;
    EXPECT_EQ(r->body, mesh) << k;
  }
  EXPECT_EQ(client.Get("/mesh/0/3")->status, 404);
  // Swapped for a symlink out after the check: the file served is no longer the file checked.
  fs::remove(base / "robot/meshes/ok.stl");
  fs::create_symlink("../../secret/secret.stl", base / "robot/meshes/ok.stl");
  const auto swapped = client.Get("/mesh/0/0");
  ASSERT_TRUE(swapped);
  EXPECT_EQ(swapped->status, 404);
  EXPECT_NE(swapped->body, secret);
  fs::remove_all(base);
}

// --bind beyond this host is said loudly on stderr when the view starts. (Here the port is taken
// on 127.0.0.1, so the view warns, then cannot listen: nothing is ever served beyond loopback.)
TEST_F(ViewTest, WarnsLoudlyWhenBoundToEveryAddress) {
  StartView({"--urdf", kVisualArm}, 18404);
  const testing::CtlResult r = testing::RunCtl({"view", "--urdf", kVisualArm, "--port", "18404", "--bind", "0.0.0.0"});
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("lagrangectl view: WARNING: --bind 0.0.0.0 serves this view to every host that can reach "
                       "this one, with no login and no encryption"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("cannot listen on 0.0.0.0:18404"), std::string::npos) << r.err;
}

// The page's URL options (a live screenshot never finishes without frames_max) are in --help.
TEST_F(ViewTest, HelpNamesThePagesUrlOptions) {
  const testing::CtlResult r = testing::RunCtl({"view", "--help"});
  EXPECT_EQ(r.status, 0) << r.err;
  for (const char* option : {"frames=1", "frames_max=N", "t=SECONDS", "q=a,b,..", "probe=1", "never finishes"})
    EXPECT_NE(r.out.find(option), std::string::npos) << option << " in " << r.out;
}

}  // namespace
}  // namespace lagrange
