// lagrangectl simulate: one CSV row per step with t, q, qd, tau, T, V, from
// a scene file, and the joint names (and a task-space controller's frame)
// beside it; bad scenes and arguments are one line and a non-zero exit; an
// instance that fails lagranged's health check stops at its last healthy row.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "protocol/format.hpp"
#include "sim/scene.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::RunCtl;

struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;  // NaN in the text column
  std::vector<std::string> texts;         // the text column's cells, one per row
  int Column(const std::string& name) const {
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return static_cast<int>(i);
    }
    return -1;
  }
};

// A CSV of numbers but for the column `text_column` (none by default), read as text.
Csv ReadCsv(const fs::path& path, const std::string& text_column = "") {
  std::ifstream in(path);
  Csv csv;
  std::string line;
  std::getline(in, line);
  std::stringstream hs(line);
  for (std::string cell; std::getline(hs, cell, ',');) csv.header.push_back(cell);
  const int text = text_column.empty() ? -1 : csv.Column(text_column);
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::vector<double> row;
    int column = 0;
    for (std::string cell; std::getline(ls, cell, ','); ++column) {
      if (column == text) csv.texts.push_back(cell);
      row.push_back(column == text ? std::nan("") : std::stod(cell));
    }
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

// A floating base: after the joints' columns, the base's pose and twist, the
// centre of mass and the momentum (log2csv's base_state_t names); the centre
// of mass falls on its parabola, c_z(t) = c_z(0) + ċ_z(0) t − ½ g t², with
// ċ(0) the linear momentum over the mass (3.65 kg: the fixture's).
TEST_F(Simulate, AFloatingBasesRowsCarryItsPoseTwistAndACentreOfMassThatFallsAsAParabola) {
  const fs::path csv = dir_ / "tree.csv";
  const auto r = RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/scenes/floating_fall.yaml",
                         "--duration", "0.5", "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv data = ReadCsv(csv);
  ASSERT_EQ(data.rows.size(), 501u);
  for (const char* column : {"q4", "qd4", "kinetic_energy", "position0", "position2", "orientation3", "linear_velocity2",
                             "angular_velocity2", "com2", "linear_momentum2", "angular_momentum2"}) {
    EXPECT_GE(data.Column(column), 0) << column;
  }
  EXPECT_EQ(data.header.size(), 1u + 4 * 5 + 2 + 22);
  const int z = data.Column("com2"), pz = data.Column("linear_momentum2"), w = data.Column("orientation3");
  constexpr double kMass = 3.65, kG = 9.81;
  const double z0 = data.rows[0][z], vz0 = data.rows[0][pz] / kMass;
  double worst = 0.0;
  for (const std::vector<double>& row : data.rows) {
    const double t = row[0];
    worst = std::max(worst, std::abs(row[z] - (z0 + vz0 * t - 0.5 * kG * t * t)));
  }
  EXPECT_LT(worst, 1e-9);
  EXPECT_DOUBLE_EQ(data.rows[0][data.Column("position2")], 1.0);
  EXPECT_LT(data.rows.back()[w], 1.0 - 1e-4);  // it turned
  // plot draws the base's panels from these columns.
  const fs::path png = dir_ / "tree.png";
  const auto p = RunCtl({"plot", csv.string(), "-o", png.string()});
  ASSERT_EQ(p.status, 0) << p.err;
  EXPECT_NE(p.out.find("; base: 501 rows, height 1 to "), std::string::npos) << p.out;
  EXPECT_TRUE(fs::exists(png));
}

TEST_F(Simulate, WritesOneRowPerStepWithStateTorqueAndEnergy) {
  const fs::path csv = dir_ / "pendulum.csv";
  const auto r = RunCtl({"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/pendulum.yaml", "--duration", "2",
                         "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv data = ReadCsv(csv);
  EXPECT_EQ(data.header, (std::vector<std::string>{"t", "q0", "qd0", "q_des0", "tau0", "kinetic_energy", "potential_energy"}));
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

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Beside each CSV, its instance's joint names in q order (FILE.joints.csv): a
// URDF robot's from its file, the others' generated (README, plants).
TEST_F(Simulate, WritesEachInstancesJointNamesBesideItsCsv) {
  const std::string config = std::string(LAGRANGE_SOURCE_DIR) + "/config/";
  auto r =
      RunCtl({"simulate", config + "panda_minjerk.yaml", "--duration", "0.01", "--csv", (dir_ / "panda.csv").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  std::string panda = "joint,name\n";
  for (int j = 0; j < 7; ++j) panda += std::to_string(j) + ",\"panda_joint" + std::to_string(j + 1) + "\"\n";
  EXPECT_EQ(ReadText(dir_ / "panda.joints.csv"), panda);

  // Several instances, and a FILE without ".csv": FILE.NAME and FILE.NAME.joints.csv for each.
  r = RunCtl({"simulate", config + "default.yaml", "--duration", "0.01", "--csv", (dir_ / "run").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(ReadCsv(dir_ / "run.arm").rows.size(), 11u);
  EXPECT_EQ(ReadText(dir_ / "run.arm.joints.csv"), "joint,name\n0,\"q1\"\n1,\"q2\"\n");
  EXPECT_EQ(ReadText(dir_ / "run.cartpole.joints.csv"), "joint,name\n0,\"x\"\n1,\"theta\"\n");
}

// Columns of a task CSV's row: t 0, frame 1 (text), position 2-4, position_des 5-7, error 8-13.
constexpr int kTaskT = 0, kTaskPosition = 2, kTaskTarget = 5, kTaskError = 8;

// FILE.task.csv beside the state CSV `state`, checked for what every task CSV
// holds: log2csv's task columns, one row per state row at its t, `frame` on
// every row, nan at t = 0 (before the first Compute, as its tau is), and each
// later row's error the target minus the position.
Csv ReadTaskCsv(const fs::path& path, const Csv& state, const std::string& frame) {
  const Csv task = ReadCsv(path, "frame");
  EXPECT_EQ(task.header, (std::vector<std::string>{"t", "frame", "position0", "position1", "position2", "position_des0",
                                                   "position_des1", "position_des2", "error0", "error1", "error2",
                                                   "error3", "error4", "error5"}));
  EXPECT_EQ(task.rows.size(), state.rows.size());
  if (task.rows.empty() || task.rows.size() != state.rows.size()) return task;
  EXPECT_EQ(task.texts, std::vector<std::string>(task.rows.size(), "\"" + frame + "\""));
  for (std::size_t k = 0; k < task.rows.size(); ++k) EXPECT_EQ(task.rows[k][kTaskT], state.rows[k][0]) << k;
  for (std::size_t c = kTaskPosition; c < task.rows[0].size(); ++c) EXPECT_TRUE(std::isnan(task.rows[0][c])) << c;
  constexpr double kErrorExact = 1e-12;
  for (std::size_t k = 1; k < task.rows.size(); ++k) {
    const std::vector<double>& row = task.rows[k];
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(row[kTaskError + i], row[kTaskTarget + i] - row[kTaskPosition + i], kErrorExact) << k;
    }
  }
  return task;
}

// Under a task-space controller, simulate writes the frame's position, target
// and error beside the CSV, one row per row, with log2csv's task column names:
// the UR5's flange under operational-space control stays on the scene's
// circle (centre and radius from the scene, the first measured pose its
// start) once the ramp is over, and each error is the target minus the
// position. A joint-space scene writes no task CSV.
TEST_F(Simulate, WritesTheTaskSpaceFramesPathBesideItsCsvOnTheScenesCircle) {
  const std::string config = std::string(LAGRANGE_SOURCE_DIR) + "/config/";
  const fs::path csv = dir_ / "ur5.csv";
  auto r = RunCtl({"simulate", config + "ur5_circle.yaml", "--duration", "2", "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv task = ReadTaskCsv(dir_ / "ur5.task.csv", ReadCsv(csv), "flange");
  ASSERT_EQ(task.rows.size(), 2001u);
  constexpr int kT = kTaskT, kPosition = kTaskPosition;

  const PoseTrajectoryConfig circle = LoadScene(config + "ur5_circle.yaml").instances.at(0).controller.task.trajectory;
  const auto position = [&](std::size_t k) {
    return Eigen::Vector3d(task.rows[k][kPosition], task.rows[k][kPosition + 1], task.rows[k][kPosition + 2]);
  };
  const Eigen::Vector3d start = position(1);  // measured at t = 0
  const Eigen::Vector3d centre = start + circle.center;
  const double radius = circle.center.norm();
  constexpr double kOnCircle = 1e-4;  // m: an exact model under Kp = 400 1/s² keeps it within microns
  for (std::size_t k = 1; k < task.rows.size(); ++k) {
    const std::vector<double>& row = task.rows[k];
    if (row[kT] < circle.ramp) continue;
    const Eigen::Vector3d p = position(k);
    EXPECT_NEAR((p - centre).norm(), radius, kOnCircle) << "t = " << row[kT];
    EXPECT_NEAR((p - centre).dot(circle.normal), 0.0, kOnCircle) << "t = " << row[kT];  // in the circle's plane
  }
  // It goes round: at 0.25 Hz, half a turn from the start by t = 2 s past its 1 s ramp (at least a quarter).
  EXPECT_GT((position(task.rows.size() - 1) - start).norm(), radius);

  r = RunCtl({"simulate", config + "ur5_pd_gravity.yaml", "--duration", "0.01", "--csv", (dir_ / "pd.csv").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "pd.joints.csv"));
  EXPECT_FALSE(fs::exists(dir_ / "pd.task.csv"));
}

// An mpc controller with a frame moves it as a task-space controller does, so
// simulate writes that frame beside the CSV too (lagranged publishes it on
// <NAME>_TASK): the Panda's flange under the shipped reach, measured at each
// row's state, from Franka's ready pose to the scene's target, which every row
// after the first commands; each error is the target minus the position.
TEST_F(Simulate, WritesAnMpcFramesPathToItsTargetBesideItsCsv) {
  const std::string scene = std::string(LAGRANGE_SOURCE_DIR) + "/config/panda_mpc_reach.yaml";
  const fs::path csv = dir_ / "panda.csv";
  auto r = RunCtl({"simulate", scene, "--duration", "1", "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv task = ReadTaskCsv(dir_ / "panda.task.csv", ReadCsv(csv), "panda_link8");
  ASSERT_EQ(task.rows.size(), 1001u);

  const Eigen::Vector3d target =
      LoadScene(scene).instances.at(0).controller.mpc.trajectory.target->position;  // the scene's step
  const auto position = [&](std::size_t k) {
    return Eigen::Vector3d(task.rows[k][kTaskPosition], task.rows[k][kTaskPosition + 1],
                           task.rows[k][kTaskPosition + 2]);
  };
  constexpr double kTargetExact = 1e-12, kReady = 1e-3, kArrived = 5e-3;  // m
  for (std::size_t k = 1; k < task.rows.size(); ++k) {
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(task.rows[k][kTaskTarget + i], target[i], kTargetExact) << k;
  }
  EXPECT_LT((position(1) - Eigen::Vector3d(0.307, 0.0, 0.590)).norm(), kReady) << "Franka's ready pose, 1 ms in";
  EXPECT_LT((position(task.rows.size() - 1) - target).norm(), kArrived) << "the flange at its target by 1 s";
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
  const int T = f.Column("kinetic_energy"), V = f.Column("potential_energy");
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

// The shipped effects demo, without the line of one effect (each sits on its own line).
std::string DemoWithout(const std::string& effect) {
  std::ifstream in(std::string(LAGRANGE_SOURCE_DIR) + "/config/effects_demo.yaml");
  std::string text, line;
  bool dropped = false;
  while (std::getline(in, line)) {
    const std::size_t start = line.find_first_not_of(' ');
    if (start != std::string::npos && line.compare(start, effect.size() + 1, effect + ":") == 0) {
      dropped = true;
      continue;
    }
    text += line + "\n";
  }
  EXPECT_TRUE(dropped) << effect;
  return text;
}

double LargestDifference(const Csv& a, const Csv& b, int n, std::size_t first_row = 0) {
  double largest = 0.0;
  for (std::size_t k = first_row; k < std::min(a.rows.size(), b.rows.size()); ++k) {
    for (int i = 0; i < n; ++i) {
      const int c = a.Column("q" + std::to_string(i));
      largest = std::max(largest, std::abs(a.rows[k][c] - b.rows[k][c]));
    }
  }
  return largest;
}

TEST_F(Simulate, TheEffectsDemoExercisesEveryEffectItLists) {
  const std::string file = std::string(LAGRANGE_SOURCE_DIR) + "/config/effects_demo.yaml";
  const EffectsConfig effects = LoadScene(file).instances.at(0).effects;
  ASSERT_TRUE(effects.damping && effects.friction && effects.limits && effects.saturation);
  ASSERT_EQ(effects.disturbance.size(), 1u);
  const double duration = 8.0;
  const fs::path csv = dir_ / "demo.csv";
  const auto r = RunCtl({"simulate", file, "--duration", std::to_string(duration), "--csv", csv.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv data = ReadCsv(csv);
  const int n = 3;
  const JointLimits& limits = *effects.limits;
  for (int i = 0; i < n; ++i) {
    const std::string j = std::to_string(i);
    const int q = data.Column("q" + j), qd = data.Column("qd" + j), tau = data.Column("tau" + j);
    bool clipped = false, held_above = false, held_below = false, full_friction = false;
    for (const auto& row : data.rows) {
      // Saturation: the applied torque sits at its bound.
      clipped = clipped || std::abs(row[tau]) >= (*effects.saturation)[i] * (1.0 - 1e-12);
      // Limits: the joint is past a stop and the stop's spring-damper pushes it back.
      const double above = row[q] - limits.upper[i], below = row[q] - limits.lower[i];
      held_above = held_above || (above > 0.0 && -limits.stiffness * above - limits.damping * row[qd] < 0.0);
      held_below = held_below || (below < 0.0 && -limits.stiffness * below - limits.damping * row[qd] > 0.0);
      // Friction: past 4 velocity scales, at more than 99.9 % of its Coulomb force.
      full_friction = full_friction || std::abs(row[qd]) > 4.0 * effects.friction->velocity_scale;
    }
    EXPECT_TRUE(clipped) << "joint " << i << " never reached its saturation bound";
    EXPECT_TRUE(held_above) << "joint " << i << " never went past its upper stop";
    EXPECT_TRUE(held_below) << "joint " << i << " never went past its lower stop";
    EXPECT_TRUE(full_friction) << "joint " << i;
  }
  // Each effect matters: the same run without it goes elsewhere. The push
  // changes nothing before it starts.
  const double push = effects.disturbance[0].start;
  for (const std::string effect : {"damping", "friction", "limits", "saturation", "disturbance"}) {
    const fs::path without = Write("without_" + effect + ".yaml", DemoWithout(effect));
    const fs::path other_csv = dir_ / ("without_" + effect + ".csv");
    ASSERT_EQ(
        RunCtl({"simulate", without.string(), "--duration", std::to_string(duration), "--csv", other_csv.string()})
            .status,
        0)
        << effect;
    const Csv other = ReadCsv(other_csv);
    ASSERT_EQ(other.rows.size(), data.rows.size()) << effect;
    EXPECT_GT(LargestDifference(data, other, n), 1e-2) << "without " << effect;
    if (effect == "disturbance") {
      const auto first_push_row = static_cast<std::size_t>(std::llround(push / 1e-3));
      Csv before = data, other_before = other;
      before.rows.resize(first_push_row);
      other_before.rows.resize(first_push_row);
      EXPECT_EQ(LargestDifference(before, other_before, n), 0.0);
      EXPECT_GT(LargestDifference(data, other, n, first_push_row), 1e-2);
    }
  }
}

bool AllFinite(const Csv& csv) {
  for (const auto& row : csv.rows) {
    for (double x : row) {
      if (!std::isfinite(x)) return false;
    }
  }
  return true;
}

TEST_F(Simulate, ADivergingInstanceStopsAtItsLastHealthyRowWithOneLineAndStatusOne) {
  // The elbow hits a stiff stop at 60 rad/s; RK4 at 1 ms is unstable in contact and the
  // energy runs away (lagranged faults the same instance: tests/daemon/stiff_cases_test.cpp).
  // The pendulum beside it runs to the end.
  const fs::path scene = Write("diverging.yaml", R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.0, 0.0], qd: [0.0, 60.0]}
    effects: {gravity: false, limits: {lower: [-10, -1.0], upper: [10, 1.0], stiffness: 1.0e6, damping: 20}}
    integrator: {type: rk4}
  - name: pendulum
    plant: {type: pendulum}
    initial: {q: [1.0]}
)");
  const auto r = RunCtl({"simulate", scene.string(), "--duration", "1", "--csv", (dir_ / "run.csv").string()});
  EXPECT_EQ(r.status, 1);
  const std::vector<std::string> lines = testing::Lines(r.err);
  ASSERT_EQ(lines.size(), 3u) << r.err;  // the two "NAME -> FILE" lines and the fault
  EXPECT_EQ(lines[2].rfind("lagrangectl simulate: arm faulted at t = ", 0), 0u) << lines[2];
  EXPECT_NE(lines[2].find("the energy left its bound (max_energy), |T + V| > "), std::string::npos) << lines[2];
  const Csv arm = ReadCsv(dir_ / "run.arm.csv"), pendulum = ReadCsv(dir_ / "run.pendulum.csv");
  EXPECT_TRUE(AllFinite(arm));
  EXPECT_GT(arm.rows.size(), 10u);
  EXPECT_LT(arm.rows.size(), 1001u);
  EXPECT_NE(lines[2].find("its CSV ends at t = " + FormatDouble(arm.rows.back()[0]) + " s"), std::string::npos)
      << lines[2];
  EXPECT_EQ(pendulum.rows.size(), 1001u);
  EXPECT_TRUE(AllFinite(pendulum));
}

TEST_F(Simulate, AnMpcSceneWhoseSolvesFailSaysHowManyAndWhyAndRunsOn) {
  // The optimiser's explicit Euler at 1 s per knot from 20 rad/s: the Coriolis force, quadratic in
  // q̇, overflows the first rollout within a few knots, so every solve diverges (lagranged's status
  // would say "the mpc solve failed: diverged") and no plan is ever followed. The plant, rk4 at
  // 1 ms with no force, runs on.
  const fs::path scene = Write("failing.yaml", R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0, 0], qd: [20, -20]}
    controller: {type: mpc, horizon: 100, dt: 1.0, integrator: explicit-euler, iterations: 1}
    torque_limits: [5, 5]
)");
  const auto r = RunCtl({"simulate", scene.string(), "--duration", "2.5", "--csv", (dir_ / "run.csv").string()});
  EXPECT_EQ(r.status, 0) << "failed solves are not a fault: " << r.err;
  const std::vector<std::string> lines = testing::Lines(r.err);
  ASSERT_EQ(lines.size(), 1u) << r.err;
  EXPECT_EQ(lines[0], "lagrangectl simulate: arm: 3 of 3 mpc solves failed (diverged 3); offline the last usable "
                      "plan is followed meanwhile (none yet: no force), where lagranged falls back");
  const Csv csv = ReadCsv(dir_ / "run.csv");
  EXPECT_EQ(csv.rows.size(), 2501u);
  EXPECT_TRUE(AllFinite(csv));
}

TEST_F(Simulate, TheEnergyBoundIsTheScenesMaxEnergyAsInLagranged) {
  // |T + V| = m g L cos(1) = 5.3 J at once, above max_energy: faulted at the first step,
  // so the CSV holds only t = 0.
  const fs::path scene = Write("bounded.yaml", R"(
instances:
  - name: p
    plant: {type: pendulum}
    initial: {q: [1.0]}
    max_energy: 0.1
)");
  const auto r = RunCtl({"simulate", scene.string(), "--duration", "1", "--csv", (dir_ / "p.csv").string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err,
            "lagrangectl simulate: p faulted at t = 0.001 s: the energy left its bound (max_energy), |T + V| > 0.1 J; "
            "its CSV ends at t = 0 s, the last healthy step\n");
  EXPECT_EQ(ReadCsv(dir_ / "p.csv").rows.size(), 1u);
}

TEST_F(Simulate, AChainWithAPrismaticJointUnderAPendulumMovesAsTheCartPole) {
  // A slider along +x carrying a 1 m uniform rod of 0.1 kg is the cart-pole (θ = q1 + π/2).
  const fs::path chain = Write("chain.yaml", R"(
instances:
  - name: c
    plant: {type: chain, params: {links: 2, joints: [prismatic, revolute], m: [1.0, 0.1], L: [0.5, 1.0]}}
    initial: {q: [0.0, 0.0], qd: [0.3, 0.0]}
    effects: {damping: [0.2, 0.01]}
    integrator: {type: rk4}
)");
  const fs::path cartpole = Write("cartpole.yaml", R"(
instances:
  - name: c
    plant: {type: cartpole}
    initial: {q: [0.0, 1.5707963267948966], qd: [0.3, 0.0]}
    effects: {damping: [0.2, 0.01]}
    integrator: {type: rk4}
)");
  ASSERT_EQ(RunCtl({"simulate", chain.string(), "--duration", "2", "--csv", (dir_ / "chain.csv").string()}).status, 0);
  ASSERT_EQ(RunCtl({"simulate", cartpole.string(), "--duration", "2", "--csv", (dir_ / "cp.csv").string()}).status, 0);
  const Csv a = ReadCsv(dir_ / "chain.csv"), b = ReadCsv(dir_ / "cp.csv");
  ASSERT_EQ(a.rows.size(), b.rows.size());
  constexpr double kSameMotion = 1e-9;
  for (std::size_t k = 0; k < a.rows.size(); ++k) {
    EXPECT_NEAR(a.rows[k][a.Column("q0")], b.rows[k][b.Column("q0")], kSameMotion) << k;
    EXPECT_NEAR(a.rows[k][a.Column("q1")] + std::acos(0.0), b.rows[k][b.Column("q1")], kSameMotion) << k;
  }
  EXPECT_GT(std::abs(a.rows.back()[a.Column("q1")]), 0.5);  // the pole swung
}

TEST_F(Simulate, BadInputPrintsOneLineAndExitsNonZero) {
  const fs::path negative =
      Write("negative.yaml", "instances:\n  - name: arm\n    plant: {type: arm2, params: {m2: -0.8}}\n");
  const fs::path broken = Write("broken.yaml", "instances: [\n");
  // lagranged refuses it (max_steps 1e5 per tick cannot fit 1 ms): simulate by the same rule.
  const fs::path unbounded =
      Write("unbounded.yaml", "instances:\n  - {name: arm, plant: {type: arm2}, integrator: {type: dopri5}}\n");
  const std::string out = (dir_ / "x.csv").string();
  struct Case {
    std::vector<std::string> args;
    int status;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"simulate", (dir_ / "missing.yaml").string(), "--duration", "1", "--csv", out},
       1,
       "missing.yaml: cannot be opened (No such file or directory)"},
      {{"simulate", negative.string(), "--duration", "1", "--csv", out},
       1,
       "negative.yaml:3:38: instances[0].plant.params.m2: expected a positive number (kg), got -0.8"},
      {{"simulate", broken.string(), "--duration", "1", "--csv", out}, 1, "broken.yaml:2:1: invalid YAML"},
      {{"simulate", unbounded.string(), "--duration", "1", "--csv", out},
       1,
       "unbounded.yaml: the instances' worst case per tick"},
      {{"simulate", negative.string(), "--duration", "-1", "--csv", out},
       2,
       "--duration: expected a positive number, got '-1'"},
      {{"simulate", negative.string(), "--duration", "soon", "--csv", out}, 2, "got 'soon'"},
      {{"simulate", std::string(LAGRANGE_SOURCE_DIR) + "/config/pendulum.yaml", "--duration", "1", "--csv",
        (dir_ / "no/such/dir.csv").string()},
       1,
       "cannot write"},
  };
  for (const Case& c : cases) {
    const auto r = RunCtl(c.args);
    EXPECT_EQ(r.status, c.status) << r.err;
    ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("lagrangectl simulate: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << "got: " << r.err << "expected: " << c.message;
  }
}

// An external plant or controller lives on the bus: simulate says which
// instance of which file cannot run offline, and writes nothing.
TEST_F(Simulate, RefusesASceneThatNeedsTheBusNamingTheFileAndTheInstance) {
  const std::string config = std::string(LAGRANGE_SOURCE_DIR) + "/config/";
  struct Case {
    std::string scene, instance, reason;
  };
  const std::vector<Case> cases = {
      {config + "arm_external_plant.yaml", "arm", "its controller is external"},
      {config + "arm_impedance_client.yaml", "arm", "its controller is external"},
      {config + "arm_external_controller.yaml", "arm_controller", "its plant is external"},
  };
  for (const Case& c : cases) {
    const fs::path csv = dir_ / "run.csv";
    const auto r = RunCtl({"simulate", c.scene, "--duration", "1", "--csv", csv.string()});
    EXPECT_EQ(r.status, 1) << r.err;
    ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(
        r.err.rfind(
            "lagrangectl simulate: " + c.scene + ": instance " + c.instance + " cannot run offline: " + c.reason, 0),
        0u)
        << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_FALSE(fs::exists(csv)) << c.scene;
  }
}

}  // namespace
}  // namespace lagrange
