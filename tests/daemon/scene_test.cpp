// Scenes: every shipped scene loads and runs offline with finite states;
// every invalid fixture is refused before anything runs, with the file, the
// line, the key and what was expected.

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>


#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>

#include "sim/offline.hpp"
#include "sim/scene.hpp"
#include "sim/yaml_reader.hpp"
#include "tests/support/mujoco_scenes.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> YamlFilesIn(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() == ".yaml") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ShippedScenes, EveryConfigSceneLoadsAndRunsTenSecondsWithFiniteStates) {
  const auto files = YamlFilesIn(fs::path(LAGRANGE_SOURCE_DIR) / "config");
  ASSERT_GE(files.size(), 3u);
  for (const fs::path& file : files) {
    if (testing::NeedsMujocoThisBuildLacks(file)) continue;
    const Scene scene = LoadScene(file.string());
    std::vector<Instance> instances;
    for (const InstanceConfig& c : scene.instances) instances.emplace_back(c);
    bool finite = true;
    const bool ok = RunOffline(instances, scene.period, static_cast<std::int64_t>(std::llround(10.0 / scene.period)),
                               [&](std::size_t, Instance& inst) {
                                 finite = finite && inst.q().allFinite() && inst.qd().allFinite() &&
                                          std::isfinite(inst.KineticEnergy() + inst.PotentialEnergy());
                               });
    EXPECT_TRUE(ok) << file;
    EXPECT_TRUE(finite) << file;
    for (const Instance& inst : instances) EXPECT_NEAR(inst.t(), 10.0, 1e-9) << file;
  }
}

// config/cartpole_lqr_discrete.yaml: at its 0.25 s tick the LQR designed for
// the tick (design: discrete) settles the pole; the continuous-time gain
// held over the same tick never does.
TEST(ShippedScenes, AtACoarseTickOnlyTheDiscreteLqrDesignSettlesThePole) {
  const Scene scene = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/cartpole_lqr_discrete.yaml");
  ASSERT_EQ(scene.instances.size(), 2u);
  std::vector<Instance> instances;
  for (const InstanceConfig& c : scene.instances) instances.emplace_back(c);
  double worst[2] = {0.0, 0.0};  // the largest |θ − π| over the last 10 s of 20
  ASSERT_TRUE(RunOffline(instances, scene.period, static_cast<std::int64_t>(std::llround(20.0 / scene.period)),
                         [&](std::size_t i, Instance& inst) {
                           if (inst.t() > 10.0) {
                             worst[i] = std::max(worst[i], std::abs(std::remainder(inst.q()[1] - std::numbers::pi, 2 * std::numbers::pi)));
                           }
                         }));
  EXPECT_EQ(scene.instances[0].name, "continuous");
  EXPECT_GT(worst[0], 0.1);
  EXPECT_LT(worst[1], 1e-4);
}

// Each fixture's first line is "# expect: <message>"; the error must read
// "<file>:<line>:<column>: <message>" (no position for an empty file).
TEST(InvalidScenes, EveryFixtureIsRefusedWithItsExpectedMessage) {
  const auto files = YamlFilesIn(fs::path(LAGRANGE_SOURCE_DIR) / "tests/fixtures/scenes/invalid");
  ASSERT_GE(files.size(), 20u);
  for (const fs::path& file : files) {
    std::ifstream in(file);
    std::string first;
    std::getline(in, first);
    const std::string prefix = "# expect: ";
    ASSERT_EQ(first.rfind(prefix, 0), 0u) << file << " has no '# expect:' line";
    const std::string expected = first.substr(prefix.size());
    try {
      LoadScene(file.string());
      ADD_FAILURE() << file << " was accepted";
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_EQ(e.file(), file.string());
      EXPECT_NE(what.find(expected), std::string::npos) << "got: " << what << "\nexpected: " << expected;
      const bool positioned = std::regex_search(
          what, std::regex("^" + std::regex_replace(file.string(), std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                           ":[0-9]+:[0-9]+: "));
      if (file.stem() != "empty") {
        EXPECT_TRUE(positioned) << what;
      }
    }
  }
}

TEST(SceneParsing, DefaultsApplyWhereTheSceneIsSilent) {
  const Scene scene = ParseScene("instances:\n  - {name: p, plant: {type: pendulum}}\n", "inline");
  ASSERT_EQ(scene.instances.size(), 1u);
  const InstanceConfig& p = scene.instances[0];
  EXPECT_DOUBLE_EQ(scene.period, 1e-3);
  EXPECT_EQ(p.method, Method::kClosedForm);
  EXPECT_EQ(p.integrator.type, IntegratorType::kRk4);
  EXPECT_TRUE(p.effects.gravity);
  EXPECT_TRUE(p.effects.coriolis);
  EXPECT_FALSE(p.effects.damping);
  EXPECT_EQ(p.q0.size(), 1);
  EXPECT_EQ(p.q0[0], 0.0);
  const auto& params = std::get<PendulumParams>(p.plant.params);
  EXPECT_EQ(params.m, 1.0);
  EXPECT_EQ(params.L, 1.0);
  EXPECT_EQ(params.body, PendulumBody::kPointMass);
}

TEST(SceneParsing, AnEnergyBalanceBoundIsReadWarningByDefaultAndAbsentUnlessGiven) {
  const Scene scene = ParseScene(R"(
instances:
  - {name: a, plant: {type: pendulum}, energy_balance: {bound: 0.5, on_exceed: fault}}
  - {name: b, plant: {type: pendulum}, energy_balance: {bound: 2}, telemetry: false}
  - {name: c, plant: {type: pendulum}}
)",
                                 "inline");
  ASSERT_EQ(scene.instances.size(), 3u);
  ASSERT_TRUE(scene.instances[0].energy_balance);
  EXPECT_EQ(scene.instances[0].energy_balance->bound, 0.5);
  EXPECT_EQ(scene.instances[0].energy_balance->on_exceed, OnResidualExceeded::kFault);
  ASSERT_TRUE(scene.instances[1].energy_balance);
  EXPECT_EQ(scene.instances[1].energy_balance->bound, 2.0);
  EXPECT_EQ(scene.instances[1].energy_balance->on_exceed, OnResidualExceeded::kWarn);
  EXPECT_FALSE(scene.instances[2].energy_balance);
}

TEST(SceneParsing, TheBusKeyFileIsRelativeToTheSceneAndAbsoluteStaysAbsolute) {
  const std::string instances = "instances:\n  - {name: p, plant: {type: pendulum}}\n";
  EXPECT_EQ(ParseScene(instances, "/etc/lagrange/scene.yaml").bus_key_file, "");
  EXPECT_EQ(ParseScene("bus: {key_file: keys/bus.key}\n" + instances, "/etc/lagrange/scene.yaml").bus_key_file,
            "/etc/lagrange/keys/bus.key");
  EXPECT_EQ(ParseScene("bus: {key_file: ../bus.key}\n" + instances, "/etc/lagrange/scenes/a.yaml").bus_key_file,
            "/etc/lagrange/bus.key");
  EXPECT_EQ(ParseScene("bus: {key_file: /srv/bus.key}\n" + instances, "/etc/lagrange/scene.yaml").bus_key_file,
            "/srv/bus.key");
  for (const char* bad : {"bus: {key_file: ''}\n", "bus: {}\n", "bus: {key: a}\n"}) {
    EXPECT_THROW(ParseScene(bad + instances, "scene.yaml"), ConfigError) << bad;
  }
}

TEST(SceneParsing, TheBusDomainAndTheEstopDwellAreReadAndCheckedNamingTheKey) {
  const std::string instances = "instances:\n  - {name: p, plant: {type: pendulum}}\n";
  EXPECT_EQ(ParseScene(instances, "s.yaml").bus_domain, "");
  EXPECT_EQ(ParseScene("bus: {domain: cell-7}\n" + instances, "s.yaml").bus_domain, "cell-7");
  EXPECT_EQ(ParseScene("bus: {key_file: k, domain: cell-7}\n" + instances, "s.yaml").bus_key_file, "k");
  for (const std::string& bad : {std::string("bus: {domain: ''}\n"), "bus: {domain: " + std::string(65, 'd') + "}\n"}) {
    EXPECT_THROW(ParseScene(bad + instances, "s.yaml"), ConfigError) << bad;
  }
  EXPECT_EQ(ParseScene(instances, "s.yaml").instances[0].estop_dwell, kDefaultEstopDwell);
  EXPECT_EQ(ParseScene("instances:\n  - {name: p, plant: {type: pendulum}, estop_dwell: 0}\n", "s.yaml")
                .instances[0]
                .estop_dwell,
            0.0);
  for (const char* dwell : {"-0.1", "3601", ".nan", "soon"}) {
    try {
      ParseScene(std::string("instances:\n  - {name: p, plant: {type: pendulum}, estop_dwell: ") + dwell + "}\n",
                 "s.yaml");
      ADD_FAILURE() << dwell;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("estop_dwell"), std::string::npos) << e.what();
    }
  }
}

TEST(SceneParsing, ChainParametersTakeScalarsOrPerLinkListsInAnyOrder) {
  // 'links' written last still sizes the per-link lists.
  const Scene scene = ParseScene(R"(
instances:
  - name: c
    plant:
      type: chain
      params: {m: [1.0, 2.0, 3.0], L: 0.4, base_angle: -1.5, com: [0.1, 0.2, 0.3], links: 3}
)",
                                 "inline");
  const auto& chain = std::get<ChainParams>(scene.instances[0].plant.params);
  ASSERT_EQ(chain.num_links(), 3);
  EXPECT_EQ(chain.links[2].m, 3.0);
  EXPECT_EQ(chain.links[1].L, 0.4);
  EXPECT_EQ(chain.links[1].com_offset(), 0.2);
  EXPECT_EQ(chain.base_angle, -1.5);
  EXPECT_NEAR(chain.links[0].inertia(), 1.0 * 0.4 * 0.4 / 12.0, 1e-16);  // uniform rod by default
  EXPECT_EQ(scene.instances[0].method, Method::kRecursive);
}

TEST(SceneParsing, EffectsAndIntegratorAreReadIntoTypedFields) {
  const Scene scene = ParseScene(R"(
period: 0.002
instances:
  - name: arm
    plant: {type: arm2, method: lagrangian}
    effects:
      gravity: false
      damping: 0.2
      limits: {lower: [-.inf, -1], upper: [.inf, 1], stiffness: 500}
      disturbance: [{start: 1, duration: 0.1, tau: [1, 0]}]
    integrator: {type: dopri5, substeps: 2, rtol: 1.0e-6, atol: 1.0e-9}
)",
                                 "inline");
  const InstanceConfig& arm = scene.instances[0];
  EXPECT_EQ(scene.period, 0.002);
  EXPECT_EQ(arm.method, Method::kLagrangian);
  EXPECT_FALSE(arm.effects.gravity);
  ASSERT_TRUE(arm.effects.damping);
  EXPECT_EQ((*arm.effects.damping)[1], 0.2);
  ASSERT_TRUE(arm.effects.limits);
  EXPECT_TRUE(std::isinf(arm.effects.limits->lower[0]));
  EXPECT_EQ(arm.effects.limits->stiffness, 500.0);
  ASSERT_EQ(arm.effects.disturbance.size(), 1u);
  EXPECT_EQ(arm.integrator.type, IntegratorType::kDormandPrince);
  EXPECT_EQ(arm.integrator.substeps, 2);
  EXPECT_EQ(arm.integrator.rtol, 1e-6);
}

TEST(SceneParsing, AMissingFileIsRefusedNamingIt) {
  try {
    LoadScene("/nonexistent/scene.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/scene.yaml: cannot be opened (No such file or directory)");
  }
}

// A FIFO would block the reader forever, /dev/zero would read until memory
// runs out: neither is a scene.
TEST(SceneParsing, AFifoADeviceOrAnOversizedFileIsRefusedWithoutWaitingOrReadingItAll) {
  const std::string dir = ::testing::TempDir();
  const std::string fifo = dir + "/scene_fifo.yaml";
  ::unlink(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto refusal = [](const std::string& path) -> std::string {
    try {
      LoadScene(path);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_EQ(refusal(fifo), fifo + ": not a regular file (a FIFO)");
  EXPECT_EQ(refusal("/dev/zero"), "/dev/zero: not a regular file (a character device)");
  const std::string big = dir + "/scene_big.yaml";
  {
    std::ofstream out(big);
    out << "description: \"" << std::string(YamlReader::kMaxSceneBytes, 'x') << "\"\n";
  }
  EXPECT_EQ(refusal(big), big + ": larger than 1 MiB");
  ::unlink(fifo.c_str());
  ::unlink(big.c_str());
}

}  // namespace
}  // namespace lagrange
