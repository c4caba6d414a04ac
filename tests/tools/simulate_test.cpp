// lagrangectl simulate: one CSV row per step with t, q, qd, tau, T, V, from
// a scene file; bad scenes and arguments are one line and a non-zero exit.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::RunCtl;

struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  int Column(const std::string& name) const {
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return static_cast<int>(i);
    }
    return -1;
  }
};

Csv ReadCsv(const fs::path& path) {
  std::ifstream in(path);
  Csv csv;
  std::string line;
  std::getline(in, line);
  std::stringstream hs(line);
  for (std::string cell; std::getline(hs, cell, ',');) csv.header.push_back(cell);
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::vector<double> row;
    for (std::string cell; std::getline(ls, cell, ',');) row.push_back(std::stod(cell));
    csv.rows.push_back(row);
  }
  return csv;
}

class Simulate : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_simulate_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  fs::path dir_;
};

TEST_F(Simulate, WritesOneRowPerStepWithStateTorqueAndEnergy) {
  const fs::path csv = dir_ / "pendulum.csv";
  const auto r = RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/pendulum.yaml", "--duration", "2",
                         "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv data = ReadCsv(csv);
  EXPECT_EQ(data.header, (std::vector<std::string>{"t", "q0", "qd0", "qdes0", "tau0", "T", "V"}));
  ASSERT_EQ(data.rows.size(), 2001u);  // t = 0 and 2000 steps of 1 ms
  for (std::size_t k = 0; k < data.rows.size(); ++k) EXPECT_NEAR(data.rows[k][0], k * 1e-3, 1e-12);
  // Released at 90 degrees with no torque: T + V stays at −m g L cos(π/2) = 0 (variational integrator).
  for (const auto& row : data.rows) {
    EXPECT_EQ(row[4], 0.0);
    EXPECT_NEAR(row[5] + row[6], 0.0, 1e-3);
  }
  EXPECT_NEAR(data.rows[0][1], std::acos(0.0), 1e-15);
  EXPECT_LT(data.rows[300][1], 1.2);  // it swings down
}

TEST_F(Simulate, ASceneWithSeveralInstancesWritesOneCsvEach) {
  const fs::path csv = dir_ / "run.csv";
  const auto r = RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml", "--duration", "0.5",
                         "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* name : {"arm", "cartpole"}) {
    const Csv data = ReadCsv(dir_ / (std::string("run.") + name + ".csv"));
    EXPECT_EQ(data.rows.size(), 501u) << name;
    EXPECT_EQ(data.header.size(), 11u) << name;
    EXPECT_GE(data.Column("qd1"), 0);
  }
}

TEST_F(Simulate, EffectsInTheSceneShapeTheRun) {
  // The same release with and without damping: damping loses energy, monotonically.
  const std::string base = R"(
instances:
  - name: p
    plant: {type: pendulum}
    initial: {q: [1.0]}
)";
  const fs::path free = Write("free.yaml", base);
  const fs::path damped = Write("damped.yaml", base + "    effects: {damping: [0.5]}\n");
  ASSERT_EQ(RunCtl({"simulate", free.string(), "--duration", "3", "--csv", (dir_ / "f.csv").string()}).status, 0);
  ASSERT_EQ(RunCtl({"simulate", damped.string(), "--duration", "3", "--csv", (dir_ / "d.csv").string()}).status, 0);
  const Csv f = ReadCsv(dir_ / "f.csv"), d = ReadCsv(dir_ / "d.csv");
  const int T = f.Column("T"), V = f.Column("V");
  const double e0 = f.rows[0][T] + f.rows[0][V];
  EXPECT_NEAR(f.rows.back()[T] + f.rows.back()[V], e0, 1e-6);
  double previous = e0;
  for (const auto& row : d.rows) {
    const double e = row[T] + row[V];
    EXPECT_LE(e, previous + 1e-12);
    previous = e;
  }
  EXPECT_LT(previous, e0 - 1.0);
}

TEST_F(Simulate, BadInputPrintsOneLineAndExitsNonZero) {
  const fs::path negative = Write("negative.yaml", "instances:\n  - name: arm\n    plant: {type: arm2, params: {m2: -0.8}}\n");
  const fs::path broken = Write("broken.yaml", "instances: [\n");
  const std::string out = (dir_ / "x.csv").string();
  struct Case {
    std::vector<std::string> args;
    int status;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"simulate", (dir_ / "missing.yaml").string(), "--duration", "1", "--csv", out}, 1, "missing.yaml: cannot read the file"},
      {{"simulate", negative.string(), "--duration", "1", "--csv", out}, 1,
       "negative.yaml:3:38: instances[0].plant.params.m2: expected a positive number (kg), got -0.8"},
      {{"simulate", broken.string(), "--duration", "1", "--csv", out}, 1, "broken.yaml:2:1: invalid YAML"},
      {{"simulate", negative.string(), "--duration", "-1", "--csv", out}, 2, "--duration: expected a positive number of seconds, got '-1'"},
      {{"simulate", negative.string(), "--duration", "soon", "--csv", out}, 2, "got 'soon'"},
      {{"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/pendulum.yaml", "--duration", "1", "--csv",
        (dir_ / "no/such/dir.csv").string()}, 1, "cannot write"},
  };
  for (const Case& c : cases) {
    const auto r = RunCtl(c.args);
    EXPECT_EQ(r.status, c.status) << r.err;
    ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("lagrangectl simulate: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << "got: " << r.err << "expected: " << c.message;
  }
}

}  // namespace
}  // namespace lagrange
