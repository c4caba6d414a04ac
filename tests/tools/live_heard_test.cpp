// What lagrangectl says it heard when no daemon answers it (protocol/client.hpp,
// WhatWasHeard): a daemon signing with another key, an unsigned daemon heard
// by a client with a key, a signed daemon heard by one without (send,
// command and watch alike); and, under a channel prefix a daemon uses, the
// instance that is there. Against live lagranged processes on private ports
// 8661-8664; nothing here measures time.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "protocol/signing.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::BackgroundProcess;
using testing::RunCtl;

constexpr double kStartWait = 20.0;  // s: bound on a daemon's start; a pass takes far less
const std::string kWait = "1";       // s: lagrangectl's --wait where nothing it can believe will come

class HeardDaemon : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_heard_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    for (const char* name : {"daemon.key", "other.key"}) WriteNewBusKey((dir_ / name).string());
  }
  void TearDown() override {
    for (auto& d : daemons_) {
      d->Signal(SIGTERM);
      EXPECT_EQ(d->Wait(10.0), 0) << d->Stderr();
    }
    fs::remove_all(dir_);
  }
  std::string Key(const char* name) const { return (dir_ / name).string(); }
  // Starts lagranged on `port` with `extra` options; returns once `ready` (lagrangectl arguments that must succeed
  // against it) does.
  void Start(int port, std::vector<std::string> extra, std::vector<std::string> ready) {
    ASSERT_EQ(testing::PrepareLoopbackMulticast(port), "");
    url_ = testing::TestLcmUrl(port);
    std::vector<std::string> argv = {LAGRANGED_PATH, "--lcm-url", url_, "--log-level", "warn"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    daemons_.push_back(std::make_unique<BackgroundProcess>(argv));
    ready.insert(ready.end(), {"--lcm-url", url_, "--wait", "5"});
    ASSERT_TRUE(testing::WaitUntil([&] { return RunCtl(ready).status == 0; }, kStartWait)) << daemons_.back()->Stderr();
  }
  testing::CtlResult Ctl(std::vector<std::string> args) {
    args.insert(args.end(), {"--lcm-url", url_, "--wait", kWait});
    return RunCtl(args);
  }

  fs::path dir_;
  std::string url_;
  std::vector<std::unique_ptr<BackgroundProcess>> daemons_;
};

// One line on stderr, exit 1, naming what was heard.
void ExpectHeard(const testing::CtlResult& r, const std::string& what) {
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << "got: " << r.err << "expected: " << what;
  EXPECT_EQ(r.err.find("heard no lagranged"), std::string::npos) << r.err;
}

TEST_F(HeardDaemon, AClientWithAnotherKeyIsToldTheDaemonSignsWithAnotherKey) {
  Start(8661, {"--bus-key", Key("daemon.key")}, {"watch", "--frames", "1", "--bus-key", Key("daemon.key")});
  const std::string other =
      "messages signed with another key (their tags do not verify with this client's): give "
      "the daemon's key (--bus-key FILE or LAGRANGE_BUS_KEY_FILE)";
  ExpectHeard(Ctl({"command", "arm", "pause", "--bus-key", Key("other.key")}), other);
  ExpectHeard(Ctl({"send", "arm", "--q", "0.5,0", "--once", "--bus-key", Key("other.key")}), other);
  ExpectHeard(Ctl({"watch", "--frames", "1", "--bus-key", Key("other.key")}), other);
}

TEST_F(HeardDaemon, AClientWithAKeyIsToldTheDaemonIsUnsigned) {
  Start(8662, {}, {"watch", "--frames", "1"});
  const std::string unsigned_daemon =
      "unsigned messages, which a client with a key refuses: the daemon runs without "
      "one (give it --bus-key FILE too, or run this client without a key)";
  ExpectHeard(Ctl({"command", "arm", "pause", "--bus-key", Key("daemon.key")}), unsigned_daemon);
  ExpectHeard(Ctl({"watch", "--frames", "1", "--bus-key", Key("daemon.key")}), unsigned_daemon);
}

TEST_F(HeardDaemon, AClientWithoutAKeyIsToldTheDaemonSigns) {
  Start(8663, {"--bus-key", Key("daemon.key")}, {"watch", "--frames", "1", "--bus-key", Key("daemon.key")});
  unsetenv(kBusKeyEnv);  // without a key: none from the environment either
  const std::string signed_daemon =
      "signed messages, which a client without a key cannot check: its states are "
      "signed; give the daemon's key (--bus-key FILE or LAGRANGE_BUS_KEY_FILE)";
  ExpectHeard(Ctl({"command", "arm", "pause"}), signed_daemon);
  ExpectHeard(Ctl({"watch", "--frames", "1"}), signed_daemon);
}

// The README's two-daemon loop: the plant publishes ARM_STATE without a
// prefix, the controller arm_controller's under CTRL_. Asked for arm under
// CTRL_, lagrangectl names the instance that runs there (and the other arm).
TEST_F(HeardDaemon, AnInstanceMissingUnderAPrefixInUseGetsTheNearestNameThere) {
  const std::string config = std::string(LAGRANGE_SOURCE_DIR) + "/config/";
  Start(8664, {"--config", config + "arm_external_plant.yaml"}, {"watch", "--frames", "1"});
  Start(8664, {"--config", config + "arm_external_controller.yaml", "--channel-prefix", "CTRL_"},
        {"watch", "--frames", "1", "--channel-prefix", "CTRL_"});
  const testing::CtlResult r = Ctl({"send", "arm", "--channel-prefix", "CTRL_", "--q", "0.5,0", "--once"});
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("did you mean 'arm_controller'? (or a lagranged publishes ARM_STATE: without "
                       "--channel-prefix?)"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace lagrange
