// lagrangectl eval: the JSON it prints carries the model's M, C, G, qdd, T
// and V; bad input is one clear line and a non-zero exit.

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "plant/eigenvalues.hpp"
#include "plant/free_flyer.hpp"
#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "plant/urdf.hpp"
#include "protocol/format.hpp"
#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::RunCtl;

using Rows = std::vector<std::vector<double>>;
using Numbers = std::vector<double>;

// What `lagrangectl eval ARGS...` prints, parsed.
json Eval(std::vector<std::string> args) {
  args.insert(args.begin(), "eval");
  return json::parse(RunCtl(std::move(args)).out);
}

TEST(Eval, ArmAtTheArticlePoseReportsTheModelsGravityAndMassMatrix) {
  const auto r = RunCtl({"eval", "--plant", "arm2", "--q", "0.7853981633974483,0", "--qd", "0,0"});
  ASSERT_EQ(r.status, 0) << r.err;
  const json out = json::parse(r.out);
  EXPECT_EQ(out.at("method").get<std::string>(), "closed-form");
  const double m1 = 1.0, m2 = 0.8, L1 = 0.6, L2 = 0.5, g = 9.81, c = std::cos(std::numbers::pi / 4);
  const std::vector<double> G = out.at("G").get<Numbers>();
  ASSERT_EQ(G.size(), 2u);
  EXPECT_NEAR(G[0], g * c * (m1 * L1 / 2 + m2 * (L1 + L2 / 2)), 1e-12);
  EXPECT_NEAR(G[1], g * c * m2 * L2 / 2, 1e-12);
  const auto M = out.at("M").get<Rows>();
  EXPECT_NEAR(M[0][0], m1 * L1 * L1 / 3 + m2 * (L1 * L1 + L1 * L2 + L2 * L2 / 3), 1e-14);
  EXPECT_NEAR(M[0][1], M[1][0], 0.0);
  EXPECT_EQ(out.at("T").get<double>(), 0.0);
  // At rest with zero torque, M qdd = −G.
  const std::vector<double> qdd = out.at("qdd").get<Numbers>();
  EXPECT_NEAR(M[0][0] * qdd[0] + M[0][1] * qdd[1], -G[0], 1e-12);
  EXPECT_NEAR(M[1][0] * qdd[0] + M[1][1] * qdd[1], -G[1], 1e-12);
}

TEST(Eval, EveryPrintedNumberReadsBackToTheModelsDouble) {
  // Exact equality is the property: the JSON must carry each double, not a rounding of it.
  const json out = Eval({"--plant", "arm2", "--q", "0.3,-1.2", "--qd", "1e-7,3e5"});
  const auto dynamics = MakeDynamics(DefaultPlantSpec(PlantType::kArm2), Method::kClosedForm);
  const std::unique_ptr<DynamicsData> dynamics_data = dynamics->MakeData();
  const VectorXd qv = (VectorXd(2) << 0.3, -1.2).finished(), qdv = (VectorXd(2) << 1e-7, 3e5).finished();
  MatrixXd M(2, 2), C(2, 2);
  VectorXd G(2);
  dynamics->ComputeMassMatrix(*dynamics_data, qv, M);
  dynamics->ComputeCoriolisMatrix(*dynamics_data, qv, qdv, C);
  dynamics->ComputeGravityForce(*dynamics_data, qv, G);
  const auto Mj = out.at("M").get<Rows>(), Cj = out.at("C").get<Rows>();
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(out.at("G").get<Numbers>()[i], G[i]);
    for (int j = 0; j < 2; ++j) {
      EXPECT_EQ(Mj[i][j], M(i, j));
      EXPECT_EQ(Cj[i][j], C(i, j));
    }
  }
  EXPECT_EQ(out.at("T").get<double>(), dynamics->ComputeKineticEnergy(*dynamics_data, qv, qdv));
  EXPECT_EQ(out.at("V").get<double>(), dynamics->ComputePotentialEnergy(*dynamics_data, qv));
}

TEST(Eval, EveryMethodPrintsTheSameDynamics) {
  for (const std::string plant : {"pendulum", "arm2", "cartpole"}) {
    const std::string q = plant == "pendulum" ? "0.4" : "0.3,-1.2";
    const std::string qd = plant == "pendulum" ? "1.5" : "1.5,-0.7";
    const std::string tau = plant == "pendulum" ? "0.2" : "0.2,-0.1";
    std::vector<json> outputs;
    for (const std::string method : {"closed-form", "lagrangian", "recursive"}) {
      const auto r = RunCtl({"eval", "--plant", plant, "--q", q, "--qd", qd, "--tau", tau, "--method", method});
      ASSERT_EQ(r.status, 0) << r.err;
      outputs.push_back(json::parse(r.out));
      EXPECT_EQ(outputs.back().at("method").get<std::string>(), method);
    }
    for (const auto& o : outputs) {
      for (const char* key : {"G", "qdd"}) {
        const auto a = outputs[0].at(key).get<Numbers>(), b = o.at(key).get<Numbers>();
        for (std::size_t i = 0; i < a.size(); ++i)
          EXPECT_NEAR(a[i], b[i], 1e-11 * (1 + std::abs(a[i]))) << plant << key;
      }
      const auto Ca = outputs[0].at("C").get<Rows>(), Cb = o.at("C").get<Rows>();
      for (std::size_t i = 0; i < Ca.size(); ++i) {
        for (std::size_t j = 0; j < Ca.size(); ++j) EXPECT_NEAR(Ca[i][j], Cb[i][j], 1e-12) << plant;
      }
      EXPECT_NEAR(outputs[0].at("T").get<double>(), o.at("T").get<double>(), 1e-12);
      EXPECT_NEAR(outputs[0].at("V").get<double>(), o.at("V").get<double>(), 1e-12);
    }
  }
}

TEST(Eval, ChainParametersAndLinksShapeTheModel) {
  // Three 0.4 m uniform rods hanging straight down (base_angle −π/2): G = 0, V = −g Σ m y.
  const auto r = RunCtl({"eval", "--plant", "chain", "--links", "3", "--param", "L=0.4", "--param", "m=2", "--param",
                         "base_angle=-1.5707963267948966", "--q", "0,0,0", "--qd", "0,0,0"});
  ASSERT_EQ(r.status, 0) << r.err;
  const json out = json::parse(r.out);
  EXPECT_EQ(out.at("method").get<std::string>(), "recursive");
  EXPECT_EQ(out.at("M").get<Rows>().size(), 3u);
  for (double g : out.at("G").get<Numbers>()) EXPECT_NEAR(g, 0.0, 1e-12);
  EXPECT_NEAR(out.at("V").get<double>(), -9.81 * 2.0 * (0.2 + 0.6 + 1.0), 1e-12);
}

// Found by the scene fuzzer (a shipped chain's first mass mutated to 1.3e119): each link is valid, the
// chain is not (M(0) singular in double precision), and the dynamics' constructor threw past the scene
// reader. Refused at its key in one line, exit 2.
TEST(Eval, AChainWhoseMassesAre1e119ApartIsRefusedAtItsKey) {
  const auto r = RunCtl({"eval", "--plant", "chain", "--links", "3", "--param", "m=1.3e119,0.8,0.5", "--q", "0,0,0",
                         "--qd", "0,0,0"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("--param m: expected links whose masses and inertias give a positive definite mass matrix"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(Eval, ChainParametersTakeOneValuePerLinkAsScenesDo) {
  // Three 0.4 m uniform rods of 1, 2 and 3 kg hanging straight down: V = −g Σ m y_com.
  const auto r = RunCtl({"eval", "--plant", "chain", "--param", "m=1,2,3", "--param", "L=0.4", "--param", "links=3",
                         "--param", "base_angle=-1.5707963267948966", "--q", "0,0,0", "--qd", "0,0,0"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NEAR(json::parse(r.out).at("V").get<double>(), -9.81 * (1.0 * 0.2 + 2.0 * 0.6 + 3.0 * 1.0), 1e-12);
  // A list of equal values is the single value.
  const json list = Eval({"--plant", "chain", "--links", "3", "--param", "m=2,2,2", "--param", "I=0.01,0.01,0.01",
                          "--q", "0.1,0.2,0.3", "--qd", "1,2,3"});
  const json one = Eval({"--plant", "chain", "--links", "3", "--param", "m=2", "--param", "I=0.01", "--q",
                         "0.1,0.2,0.3", "--qd", "1,2,3"});
  EXPECT_EQ(list.at("M").get<Rows>(), one.at("M").get<Rows>());
  EXPECT_EQ(list.at("qdd").get<Numbers>(), one.at("qdd").get<Numbers>());
}

TEST(Eval, AChainWithAPrismaticFirstJointIsTheCartPole) {
  // A slider along +x (1 kg) carrying a 1 m uniform rod of 0.1 kg: the cart-pole's defaults,
  // with the rod's angle from +x, so θ = q1 + π/2. Both chain methods agree with the closed form.
  const double q1 = 0.63;
  const std::string q = "0.3," + FormatDouble(q1), qd = "0.5,-1.3";
  const json cartpole = Eval({"--plant", "cartpole", "--q", "0.3," + FormatDouble(q1 + std::numbers::pi / 2), "--qd",
                              qd, "--tau", "0.4,-0.05"});
  for (const std::string method : {"recursive", "lagrangian"}) {
    const auto r = RunCtl({"eval", "--plant", "chain", "--param", "joints=prismatic,revolute", "--param", "m=1,0.1",
                           "--param", "L=0.5,1", "--q", q, "--qd", qd, "--tau", "0.4,-0.05", "--method", method});
    ASSERT_EQ(r.status, 0) << r.err;
    const json chain = json::parse(r.out);
    constexpr double kSame = 1e-12;
    for (const char* key : {"G", "qdd"}) {
      const auto a = chain.at(key).get<Numbers>(), b = cartpole.at(key).get<Numbers>();
      for (std::size_t i = 0; i < 2; ++i) EXPECT_NEAR(a[i], b[i], kSame) << method << " " << key << i;
    }
    for (const char* key : {"M", "C"}) {
      const auto a = chain.at(key).get<Rows>(), b = cartpole.at(key).get<Rows>();
      for (std::size_t i = 0; i < 2; ++i) {
        for (std::size_t j = 0; j < 2; ++j) EXPECT_NEAR(a[i][j], b[i][j], kSame) << method << " " << key;
      }
    }
    EXPECT_NEAR(chain.at("T").get<double>(), cartpole.at("T").get<double>(), kSame);
    EXPECT_NEAR(chain.at("V").get<double>(), cartpole.at("V").get<double>(), kSame);
  }
}

TEST(Eval, ParametersChangeThePhysics) {
  const json heavy = Eval({"--plant", "pendulum", "--param", "m=3", "--param", "L=2", "--q", "0.5", "--qd", "0"});
  EXPECT_NEAR(heavy.at("M").get<Rows>()[0][0], 3.0 * 4.0, 1e-12);
  EXPECT_NEAR(heavy.at("G").get<Numbers>()[0], 3.0 * 9.81 * 2.0 * std::sin(0.5), 1e-12);
  const json rod = Eval({"--plant", "pendulum", "--param", "body=rod", "--q", "0.5", "--qd", "0"});
  EXPECT_NEAR(rod.at("M").get<Rows>()[0][0], 1.0 / 3.0, 1e-15);
}

struct BadEval {
  std::vector<std::string> args;
  std::string message;  // what the one line must say
};

// Each case: exit 2, nothing on stdout, one line on stderr from "lagrangectl eval: " saying its message.
void ExpectEachRefused(const std::vector<BadEval>& cases) {
  for (const BadEval& c : cases) {
    std::vector<std::string> args = {"eval"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto r = RunCtl(args);
    EXPECT_EQ(r.status, 2) << c.message << "\n" << r.err;
    EXPECT_TRUE(r.out.empty());
    ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("lagrangectl eval: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << "got: " << r.err << "expected: " << c.message;
  }
}

TEST(Eval, BadInputPrintsOneLineNamingTheProblemAndExitsNonZero) {
  const std::vector<BadEval> cases = {
      {{"--plant", "arm3", "--q", "0,0", "--qd", "0,0"},
       "--plant: expected one of pendulum|arm2|cartpole|chain, got 'arm3'"},
      {{"--plant", "arm2", "--q", "0,0", "--qd", "0,0", "--method", "magic"},
       "--method: expected closed-form, lagrangian or recursive, got 'magic'"},
      {{"--plant", "chain", "--q", "0,0", "--qd", "0,0", "--method", "closed-form"}, "chain has no closed-form path"},
      {{"--plant", "arm2", "--q", "0,0,0", "--qd", "0,0"}, "--q: expected 2 values (one per joint), got 3"},
      {{"--plant", "arm2", "--q", "0,0", "--qd", "0"}, "--qd: expected 2 values (one per joint), got 1"},
      {{"--plant", "arm2", "--q", "0,inf", "--qd", "0,0"}, "--q: expected comma-separated finite numbers, got 'inf'"},
      {{"--plant", "arm2", "--q", "0,1x", "--qd", "0,0"}, "got '1x'"},
      {{"--plant", "arm2", "--q", "0,0", "--qd", "0,0", "--tau", "nan,0"},
       "--tau: expected comma-separated finite numbers"},
      {{"--plant", "arm2", "--q", "0,0", "--qd", "0,0", "--tau", "0"},
       "--tau: expected 2 values (one per joint), got 1"},
      {{"--plant", "arm2", "--param", "m1=-1", "--q", "0,0", "--qd", "0,0"},
       "--param m1: expected a positive number (kg), got -1"},
      {{"--plant", "arm2", "--param", "mass=1", "--q", "0,0", "--qd", "0,0"},
       "--param mass: unknown parameter for arm2"},
      {{"--plant", "arm2", "--param", "m1", "--q", "0,0", "--qd", "0,0"}, "--param: expected NAME=VALUE, got 'm1'"},
      {{"--plant", "arm2", "--links", "3", "--q", "0,0", "--qd", "0,0"}, "--links: only a chain has links"},
      {{"--plant", "chain", "--links", "0", "--q", "0", "--qd", "0"},
       "--links: expected a whole number from 1 to 256, got 0"},
      {{"--plant", "arm2", "--qd", "0,0"}, "--q is required"},
      {{"--plant", "chain", "--links", "3", "--param", "m=1,2", "--q", "0,0,0", "--qd", "0,0,0"},
       "--param m: expected 3 values (one per link), got 2"},
      {{"--plant", "chain", "--param", "m=1,-2", "--q", "0,0", "--qd", "0,0"},
       "--param m[1]: expected a positive number (kg), got -2"},
      {{"--plant", "chain", "--param", "g=9.81,9.81", "--q", "0,0", "--qd", "0,0"},
       "--param g: expected a single value, got '9.81,9.81'"},
      {{"--plant", "chain", "--param", "joints=revolute,hinge", "--q", "0,0", "--qd", "0,0"},
       "--param joints[1]: expected revolute or prismatic, got 'hinge'"},
      {{"--plant", "arm2", "--param", "m1=1,2", "--q", "0,0", "--qd", "0,0"},
       "--param m1: expected a finite number, got '1,2'"},
  };
  ExpectEachRefused(cases);
}

// A robot from URDF: the same JSON, with its joints' names in q order.
const std::string kPanda = std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/panda.urdf";
const std::string kPandaPose = "0.3,-0.5,-0.2,-2,0.1,1.6,0.6";
const std::string kPandaVelocity = "0.4,-0.3,0.2,0.5,-0.6,0.7,-0.8";

TEST(EvalUrdf, PrintsTheJointNamesInOrderAndASymmetricPositiveDefiniteMassMatrix) {
  const auto r = RunCtl({"eval", "--urdf", kPanda, "--q", kPandaPose, "--qd", kPandaVelocity});
  ASSERT_EQ(r.status, 0) << r.err;
  const json out = json::parse(r.out);
  EXPECT_EQ(out.at("plant").get<std::string>(), "urdf");
  EXPECT_EQ(out.at("method").get<std::string>(), "recursive");
  EXPECT_EQ(out.at("num_dofs").get<int>(), 7);
  const auto joints = out.at("joints").get<std::vector<std::string>>();
  ASSERT_EQ(joints.size(), 7u);
  for (std::size_t j = 0; j < 7; ++j) EXPECT_EQ(joints[j], "panda_joint" + std::to_string(j + 1));
  const auto rows = out.at("M").get<Rows>();
  ASSERT_EQ(rows.size(), 7u);
  MatrixXd M(7, 7);
  for (int i = 0; i < 7; ++i) {
    ASSERT_EQ(rows[static_cast<std::size_t>(i)].size(), 7u);
    for (int j = 0; j < 7; ++j) M(i, j) = rows[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
  }
  EXPECT_LE((M - M.transpose()).norm(), 1e-14 * M.norm());
  EXPECT_GT(SymmetricEigenvalues(M).minCoeff(), 0.0);
  // T = ½ qdᵀ M qd.
  const VectorXd qd = (VectorXd(7) << 0.4, -0.3, 0.2, 0.5, -0.6, 0.7, -0.8).finished();
  EXPECT_NEAR(out.at("T").get<double>(), 0.5 * qd.dot(M * qd), 1e-12 * out.at("T").get<double>());
}

TEST(EvalUrdf, TheLagrangianAndRecursivePathsAgree) {
  std::vector<json> outputs;
  for (const std::string method : {"recursive", "lagrangian"}) {
    const auto r = RunCtl({"eval", "--urdf", kPanda, "--q", kPandaPose, "--qd", kPandaVelocity, "--tau",
                           "1,2,3,4,0.5,0.6,0.7", "--method", method});
    ASSERT_EQ(r.status, 0) << r.err;
    outputs.push_back(json::parse(r.out));
  }
  const auto Ga = outputs[0].at("G").get<Numbers>(), Gb = outputs[1].at("G").get<Numbers>();
  ASSERT_EQ(Ga.size(), 7u);
  double scale = 0.0;
  for (double g : Ga) scale = std::max(scale, std::abs(g));
  for (std::size_t i = 0; i < 7; ++i) EXPECT_NEAR(Ga[i], Gb[i], 1e-12 * scale) << i;
  const auto Ma = outputs[0].at("M").get<Rows>(), Mb = outputs[1].at("M").get<Rows>();
  for (std::size_t i = 0; i < 7; ++i) {
    for (std::size_t j = 0; j < 7; ++j) EXPECT_NEAR(Ma[i][j], Mb[i][j], 1e-12) << i << "," << j;
  }
  EXPECT_NEAR(outputs[0].at("T").get<double>(), outputs[1].at("T").get<double>(), 1e-12);
  EXPECT_NEAR(outputs[0].at("V").get<double>(), outputs[1].at("V").get<double>(),
              1e-12 * std::abs(outputs[0].at("V").get<double>()));
}

TEST(EvalUrdf, GravityIsTheOptionsVectorAndMassScaleScalesTheRobot) {
  const json standard = Eval({"--urdf", kPanda, "--q", kPandaPose, "--qd", "0,0,0,0,0,0,0"});
  const json weightless = Eval({"--urdf", kPanda, "--gravity", "0,0,0", "--q", kPandaPose, "--qd", "0,0,0,0,0,0,0"});
  const json doubled = Eval({"--urdf", kPanda, "--gravity", "0,0,-19.62", "--param", "mass_scale=1.5", "--q",
                             kPandaPose, "--qd", "0,0,0,0,0,0,0"});
  const auto G = standard.at("G").get<Numbers>();
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_EQ(weightless.at("G").get<Numbers>()[i], 0.0) << i;
    EXPECT_NEAR(doubled.at("G").get<Numbers>()[i], 3.0 * G[i], 1e-12 * (1.0 + std::abs(G[i]))) << i;
    EXPECT_NEAR(doubled.at("M").get<Rows>()[i][i], 1.5 * standard.at("M").get<Rows>()[i][i], 1e-12) << i;
  }
  // At rest under zero torque the robot falls: M qdd = −G.
  EXPECT_GT(std::abs(standard.at("qdd").get<Numbers>()[1]), 0.1);
}

TEST(EvalUrdf, PlanarPlantsHaveGeneratedJointNames) {
  EXPECT_EQ(Eval({"--plant", "arm2", "--q", "0,0", "--qd", "0,0"}).at("joints"), json({"q1", "q2"}));
  EXPECT_EQ(Eval({"--plant", "cartpole", "--q", "0,0", "--qd", "0,0"}).at("joints"), json({"x", "theta"}));
  EXPECT_EQ(Eval({"--plant", "pendulum", "--q", "0", "--qd", "0"}).at("joints"), json({"theta"}));
  EXPECT_EQ(Eval({"--plant", "chain", "--links", "3", "--q", "0,0,0", "--qd", "0,0,0"}).at("joints"),
            json({"q1", "q2", "q3"}));
}

TEST(EvalUrdf, BadInputPrintsOneLineNamingTheProblemAndExitsTwo) {
  const fs::path dir = fs::temp_directory_path() / ("lagrange_eval_urdf_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path floating = dir / "floating.urdf";
  std::ofstream(floating) << R"(<robot name="f"><link name="a"/><joint name="free" type="floating">)"
                             R"(<parent link="a"/><child link="b"/></joint><link name="b"><inertial><mass value="1"/>)"
                             R"(<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link></robot>)";
  const std::string zeros = "0,0,0,0,0,0,0";
  const std::vector<BadEval> cases = {
      {{"--urdf", (dir / "none.urdf").string(), "--q", "0", "--qd", "0"}, "--urdf: " + (dir / "none.urdf").string()},
      {{"--urdf", floating.string(), "--q", "0", "--qd", "0"}, "--urdf: " + floating.string() + ": "},
      {{"--urdf", kPanda, "--plant", "arm2", "--q", "0", "--qd", "0"}, "--plant excludes --urdf"},
      {{"--q", "0", "--qd", "0"}, "expected --plant TYPE or --urdf FILE"},
      {{"--urdf", kPanda, "--gravity", "0,-9.81", "--q", zeros, "--qd", zeros},
       "--gravity: expected gx,gy,gz (3 numbers, m/s²), got 2"},
      {{"--urdf", kPanda, "--gravity", "0,0,down", "--q", zeros, "--qd", zeros}, "got 'down'"},
      {{"--plant", "arm2", "--gravity", "0,0,-9.81", "--q", "0,0", "--qd", "0,0"}, "--gravity: only with --urdf"},
      {{"--urdf", kPanda, "--links", "3", "--q", zeros, "--qd", zeros}, "--links: a urdf robot has the joints"},
      {{"--urdf", kPanda, "--param", "mass_scale=-1", "--q", zeros, "--qd", zeros},
       "--param mass_scale: expected a positive number"},
      {{"--urdf", kPanda, "--param", "mass_scale=1e308", "--q", zeros, "--qd", zeros},
       "--param mass_scale: expected a factor from 1e-06 to 1e+06, got 1e+308"},
      {{"--urdf", kPanda, "--param", "m1=2", "--q", zeros, "--qd", zeros},
       "--param m1: unknown parameter for urdf (expected one of gravity, mass_scale)"},
      {{"--urdf", kPanda, "--q", "0,0,0,0,0,0", "--qd", zeros}, "--q: expected 7 values (one per joint), got 6"},
      {{"--urdf", kPanda, "--q", zeros, "--qd", zeros, "--method", "closed-form"},
       "--method: a urdf robot has no closed-form path"},
      {{"--plant", "urdf", "--q", "0", "--qd", "0"},
       "--plant: expected one of pendulum|arm2|cartpole|chain, got 'urdf'"},
  };
  ExpectEachRefused(cases);
  fs::remove_all(dir);
}

// --derivatives: the model's exact derivatives, each double as the library
// computes it, for every method; the methods agree with each other.
TEST(EvalDerivatives, EveryMethodPrintsTheLibrarysDerivativesAndTheyAgree) {
  struct Case {
    std::vector<std::string> args;
    PlantSpec spec;
    std::vector<Method> methods;
    std::string q, qd, tau;
  };
  const std::vector<Case> cases = {
      {{"--plant", "arm2"},
       DefaultPlantSpec(PlantType::kArm2),
       {Method::kClosedForm, Method::kLagrangian, Method::kRecursive},
       "0.3,-1.2",
       "1.5,-0.7",
       "0.2,-0.1"},
      {{"--urdf", kPanda},
       UrdfPlantSpec(std::make_shared<const UrdfRobot>(LoadUrdf(kPanda))),
       {Method::kRecursive, Method::kLagrangian},
       kPandaPose,
       kPandaVelocity,
       "1,2,3,4,0.5,0.6,0.7"},
  };
  const char* keys[] = {"dqdd_dq", "dqdd_dqd", "dqdd_dtau", "dtau_dq", "dtau_dqd"};
  for (const Case& c : cases) {
    std::vector<std::map<std::string, MatrixXd>> printed;
    for (Method method : c.methods) {
      std::vector<std::string> args = c.args;
      for (const std::string& a : {std::string("--q"), c.q, std::string("--qd"), c.qd, std::string("--tau"), c.tau,
                                   std::string("--method"), std::string(ToString(method)), std::string("--derivatives")}) {
        args.push_back(a);
      }
      const json out = Eval(args);
      const int n = out.at("num_dofs").get<int>();
      const json& d = out.at("derivatives");
      std::map<std::string, MatrixXd> m;
      for (const char* key : keys) {
        const Rows rows = d.at(key).get<Rows>();
        ASSERT_EQ(rows.size(), static_cast<std::size_t>(n)) << key;
        m[key] = MatrixXd(n, n);
        for (int i = 0; i < n; ++i) {
          for (int j = 0; j < n; ++j) m[key](i, j) = rows[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
        }
      }
      // The library's doubles at the same state, ∂tau at the printed qdd.
      const std::unique_ptr<Dynamics> model = MakeDynamics(c.spec, method);
      const std::unique_ptr<DynamicsData> data = model->MakeData();
      const auto vector = [n](const std::string& text) {
        VectorXd v(n);
        std::stringstream ss(text);
        std::string item;
        for (int i = 0; i < n && std::getline(ss, item, ','); ++i) v[i] = std::stod(item);
        return v;
      };
      const VectorXd q = vector(c.q), qd = vector(c.qd), tau = vector(c.tau);
      VectorXd qdd(n);
      MatrixXd a(n, n), b(n, n), e(n, n), f(n, n), g(n, n), M(n, n);
      model->ComputeForwardDynamicsDerivatives(*data, q, qd, tau, DynamicsTerms{}, qdd, a, b, e);
      const Numbers printed_qdd = out.at("qdd").get<Numbers>();
      for (int i = 0; i < n; ++i) EXPECT_EQ(printed_qdd[static_cast<std::size_t>(i)], qdd[i]);
      model->ComputeInverseDynamicsDerivatives(*data, q, qd, qdd, DynamicsTerms{}, f, g, M);
      EXPECT_EQ(m["dqdd_dq"], a) << ToString(method);
      EXPECT_EQ(m["dqdd_dqd"], b) << ToString(method);
      EXPECT_EQ(m["dqdd_dtau"], e) << ToString(method);
      EXPECT_EQ(m["dtau_dq"], f) << ToString(method);
      EXPECT_EQ(m["dtau_dqd"], g) << ToString(method);
      printed.push_back(std::move(m));
    }
    for (std::size_t k = 1; k < printed.size(); ++k) {
      for (const char* key : keys) {
        const MatrixXd& x = printed[0][key];
        EXPECT_LT((printed[k][key] - x).norm(), 1e-10 * std::max(1.0, x.norm())) << c.args[1] << " " << key;
      }
    }
  }
}

TEST(EvalDerivatives, DerivativesWithFramesOrWithoutAStateAreRefused) {
  const std::vector<BadEval> cases = {
      {{"--plant", "arm2", "--frames", "--derivatives"}, "--frames excludes --derivatives"},
      {{"--plant", "arm2", "--derivatives"}, "--q is required"},
  };
  ExpectEachRefused(cases);
}

// --frame NAME: the frame's pose, world-aligned Jacobian and J̇ qd; --frames: the names.
TEST(EvalFrames, TheArmsTipIsTheClosedForm) {
  const double L1 = 0.6, L2 = 0.5, q1 = 0.3, q2 = -1.1, w1 = 0.7, w2 = -0.4;
  const json out = Eval({"--plant", "arm2", "--q", "0.3,-1.1", "--qd", "0.7,-0.4", "--frame", "tip"});
  const json& tip = out.at("frames").at("tip");
  const double c1 = std::cos(q1), s1 = std::sin(q1), c12 = std::cos(q1 + q2), s12 = std::sin(q1 + q2);
  const Numbers p = tip.at("position").get<Numbers>();
  ASSERT_EQ(p.size(), 3u);
  EXPECT_NEAR(p[0], L1 * c1 + L2 * c12, 1e-15);
  EXPECT_NEAR(p[1], L1 * s1 + L2 * s12, 1e-15);
  EXPECT_EQ(p[2], 0.0);
  const Rows R = tip.at("rotation").get<Rows>();
  EXPECT_NEAR(R[0][0], c12, 1e-15);
  EXPECT_NEAR(R[1][0], s12, 1e-15);
  const Rows J = tip.at("jacobian").get<Rows>();
  ASSERT_EQ(J.size(), 6u);
  ASSERT_EQ(J[0].size(), 2u);
  EXPECT_NEAR(J[0][0], -L1 * s1 - L2 * s12, 1e-15);
  EXPECT_NEAR(J[1][1], L2 * c12, 1e-15);
  EXPECT_EQ(J[5], Numbers({1.0, 1.0}));
  const Numbers bias = tip.at("jdot_qdot").get<Numbers>();
  ASSERT_EQ(bias.size(), 6u);
  EXPECT_NEAR(bias[0], -L1 * c1 * w1 * w1 - L2 * c12 * (w1 + w2) * (w1 + w2), 1e-14);
  EXPECT_NEAR(bias[1], -L1 * s1 * w1 * w1 - L2 * s12 * (w1 + w2) * (w1 + w2), 1e-14);
}

TEST(EvalFrames, EveryPrintedFrameNumberReadsBackToTheModelsDouble) {
  const json out = Eval({"--urdf", kPanda, "--q", kPandaPose, "--qd", kPandaVelocity, "--frame", "panda_link8",
                         "--frame", "panda_link0", "--frame", "panda_link4"});
  const Kinematics model(LoadUrdf(kPanda).tree);
  const auto data = model.MakeData();
  const auto values = [](const std::string& list) {
    VectorXd v(7);
    std::stringstream in(list);
    for (int i = 0; i < 7; ++i) {
      std::string item;
      std::getline(in, item, ',');
      v[i] = std::stod(item);
    }
    return v;
  };
  model.ComputeFrameKinematics(*data, values(kPandaPose), values(kPandaVelocity));
  ASSERT_EQ(out.at("frames").size(), 3u);
  for (const std::string name : {"panda_link8", "panda_link0", "panda_link4"}) {
    SCOPED_TRACE(name);
    const int k = *model.FrameIndex(name);
    const json& f = out.at("frames").at(name);
    const Rows R = f.at("rotation").get<Rows>(), J = f.at("jacobian").get<Rows>();
    const Numbers p = f.at("position").get<Numbers>(), bias = f.at("jdot_qdot").get<Numbers>();
    ASSERT_EQ(J.size(), 6u);
    for (int r = 0; r < 6; ++r) {
      ASSERT_EQ(J[r].size(), 7u);
      for (int c = 0; c < 7; ++c) EXPECT_EQ(J[r][c], data->jacobian(k, FrameAxes::kWorldAligned)(r, c));
      EXPECT_EQ(bias[r], data->bias_acceleration(k, FrameAxes::kWorldAligned)[r]);
    }
    for (int r = 0; r < 3; ++r) {
      EXPECT_EQ(p[r], data->position(k)[r]);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(R[r][c], data->rotation(k)(r, c));
    }
  }
  // The root link is the world.
  EXPECT_EQ(out.at("frames").at("panda_link0").at("position").get<Numbers>(), Numbers({0.0, 0.0, 0.0}));
}

TEST(EvalFrames, FramesListsEveryFrameNameWithoutAState) {
  EXPECT_EQ(Eval({"--plant", "arm2", "--frames"}).at("frame_names"), json({"link1", "link2", "tip"}));
  EXPECT_EQ(Eval({"--plant", "cartpole", "--frames"}).at("frame_names"), json({"cart", "pole", "pole_tip"}));
  EXPECT_EQ(Eval({"--plant", "pendulum", "--frames"}).at("frame_names"), json({"bob"}));
  EXPECT_EQ(Eval({"--plant", "chain", "--links", "3", "--frames"}).at("frame_names"),
            json({"link1", "link2", "link3", "tip"}));
  const json ur5 = Eval({"--urdf", std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/ur5.urdf", "--frames"});
  EXPECT_EQ(ur5.at("frame_names").back(), "flange");
  EXPECT_EQ(Eval({"--urdf", kPanda, "--frames"}).at("frame_names").size(), 9u);
}

TEST(EvalFrames, AnUnknownFrameIsOneLineNamingItAndExitsTwo) {
  const std::string zeros = "0,0,0,0,0,0,0";
  const std::vector<BadEval> cases = {
      {{"--plant", "arm2", "--q", "0,0", "--qd", "0,0", "--frame", "tip", "--frame", "hand"},
       "--frame: no frame 'hand' in this plant"},
      {{"--urdf", kPanda, "--q", zeros, "--qd", zeros, "--frame", "panda_hand"},
       "--frame: no frame 'panda_hand' in this plant"},
      {{"--plant", "arm2", "--q", "0,0", "--qd", "0,0", "--frame", "a\nb"}, "--frame: no frame 'a\\nb'"},
      {{"--plant", "arm2", "--frames", "--frame", "tip"}, "--frame excludes --frames"},
      {{"--plant", "arm2", "--qd", "0,0", "--frame", "tip"}, "--q is required"},
  };
  ExpectEachRefused(cases);
}

TEST(Eval, TheInstalledBinaryExitsNonZeroWithOneLineOnBadInput) {
  const auto bad = testing::RunProcess({LAGRANGECTL_PATH, "eval", "--plant", "arm2", "--q", "0", "--qd", "0,0"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err, "lagrangectl eval: --q: expected 2 values (one per joint), got 1\n");
  const auto good = testing::RunProcess({LAGRANGECTL_PATH, "eval", "--plant", "pendulum", "--q", "0", "--qd", "0"});
  EXPECT_EQ(good.exit_code, 0);
  EXPECT_EQ(json::parse(good.out).at("G").get<Numbers>()[0], 0.0);
}

// ---------------------------------------------------------------------------
// --floating-base: a URDF robot on a free base.

// The fixtures brick.urdf (a free body) and two_arms.urdf (a base with two
// joints), and a massless one in a directory of this process.
class EvalFloatingBase : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_eval_floating_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "massless.urdf") << R"(<robot name="m"><link name="hull"/></robot>)";
  }
  void TearDown() override { fs::remove_all(dir_); }
  static std::string File(const std::string& name) {
    return std::string(LAGRANGE_SOURCE_DIR) + "/tests/fixtures/urdf/" + name;
  }
  std::string Massless() const { return (dir_ / "massless.urdf").string(); }

  fs::path dir_;
};

constexpr double kG = 9.81;
// The base turned a quarter turn about the world's x: base y is world z.
const std::string kQuarterTurnX = "0.7071067811865476,0,0,0.7071067811865476";

// At rest a free body falls: v̇_b = Rᵀ g in base axes, no angular acceleration.
TEST_F(EvalFloatingBase, AFreeBodyAtRestFallsWithGravityInBaseAxes) {
  const json out =
      Eval({"--urdf", File("brick.urdf"), "--floating-base", "--q", "0,0,1," + kQuarterTurnX, "--qd", "0,0,0,0,0,0"});
  EXPECT_TRUE(out.at("floating_base").get<bool>());
  EXPECT_EQ(out.at("method").get<std::string>(), "recursive");
  EXPECT_EQ(out.at("num_dofs").get<int>(), 0);
  EXPECT_EQ(out.at("num_positions").get<int>(), 7);
  EXPECT_EQ(out.at("num_velocities").get<int>(), 6);
  const Numbers qdd = out.at("qdd").get<Numbers>();
  ASSERT_EQ(qdd.size(), 6u);
  // Rᵀ (0, 0, −g) with R = Rx(π/2): (0, −g, 0).
  const Numbers expected = {0.0, -kG, 0.0, 0.0, 0.0, 0.0};
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(qdd[i], expected[i], 1e-12) << i;
  EXPECT_NEAR(out.at("M").get<Rows>()[1][1], 2.0, 1e-15);
  EXPECT_NEAR(out.at("V").get<double>(), 2.0 * kG * 1.0, 1e-12);  // V = m g z of its centre of mass
  EXPECT_EQ(out.at("T").get<double>(), 0.0);
}

TEST_F(EvalFloatingBase, TheCountsAreNqAndNvAndTheJointBlockOfMIsTheFixedRobots) {
  const std::string joints = "0.4,-0.05";
  const json floating = Eval({"--urdf", File("two_arms.urdf"), "--floating-base", "--q",
                              "0.3,-0.2,0.5,0.1,0.2,0.3,0.9273618495495703," + joints, "--qd",
                              "0.1,0.2,0.3,-0.4,0.5,-0.6,1,2", "--frame", "b"});
  const json fixed = Eval({"--urdf", File("two_arms.urdf"), "--q", joints, "--qd", "1,2"});
  EXPECT_EQ(floating.at("num_positions").get<int>(), 2 + 7);
  EXPECT_EQ(floating.at("num_velocities").get<int>(), 2 + 6);
  EXPECT_EQ(fixed.at("num_positions").get<int>(), 2);
  EXPECT_EQ(floating.at("joints"), json({"ja", "jb"}));
  const Rows M = floating.at("M").get<Rows>(), M_fixed = fixed.at("M").get<Rows>();
  ASSERT_EQ(M.size(), 8u);
  for (std::size_t i = 0; i < 2; ++i) {
    for (std::size_t j = 0; j < 2; ++j) EXPECT_NEAR(M[6 + i][6 + j], M_fixed[i][j], 1e-12) << i << "," << j;
  }
  EXPECT_EQ(floating.at("Cv").get<Numbers>().size(), 8u);
  EXPECT_EQ(floating.at("G").get<Numbers>().size(), 8u);
  const Rows J = floating.at("frames").at("b").at("jacobian").get<Rows>();
  ASSERT_EQ(J.size(), 6u);
  EXPECT_EQ(J[0].size(), 8u);
  // T = ½ vᵀ M v.
  const Numbers v = {0.1, 0.2, 0.3, -0.4, 0.5, -0.6, 1, 2};
  double T = 0.0;
  for (std::size_t i = 0; i < 8; ++i) {
    for (std::size_t j = 0; j < 8; ++j) T += 0.5 * v[i] * M[i][j] * v[j];
  }
  EXPECT_NEAR(floating.at("T").get<double>(), T, 1e-12 * T);
}

TEST_F(EvalFloatingBase, AQuaternionTypedWithFourDigitsIsNormalised) {
  const std::vector<std::string> rest = {"--qd", "0,0,0,0.1,0.2,0.3", "--frame", "brick"};
  const json typed = Eval({"--urdf", File("brick.urdf"), "--floating-base", "--q", "0,0,0,0.7071,0,0,0.7071", rest[0],
                           rest[1], rest[2], rest[3]});
  const json exact = Eval({"--urdf", File("brick.urdf"), "--floating-base", "--q", "0,0,0," + kQuarterTurnX, rest[0],
                           rest[1], rest[2], rest[3]});
  const Rows R = typed.at("frames").at("brick").at("rotation").get<Rows>();
  const Rows R_exact = exact.at("frames").at("brick").at("rotation").get<Rows>();
  for (std::size_t i = 0; i < 3; ++i) {
    for (std::size_t j = 0; j < 3; ++j) EXPECT_NEAR(R[i][j], R_exact[i][j], 1e-15) << i << "," << j;
  }
  const Numbers qdd = typed.at("qdd").get<Numbers>(), qdd_exact = exact.at("qdd").get<Numbers>();
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(qdd[i], qdd_exact[i], 1e-12) << i;
}

TEST_F(EvalFloatingBase, BadInputPrintsOneLineNamingTheProblemAndExitsTwo) {
  const std::string brick = File("brick.urdf"), two = File("two_arms.urdf");
  const std::string q = "0,0,0,0,0,0,1", v = "0,0,0,0,0,0";
  const std::vector<BadEval> cases = {
      {{"--urdf", brick, "--floating-base", "--q", "0,0,0,0,0,1", "--qd", v},
       "--q: expected 7 values (nq = nv + 1: the base's x,y,z, its quaternion qx,qy,qz,qw, then 0 joints), got 6"},
      {{"--urdf", two, "--floating-base", "--q", q + ",0,0", "--qd", v},
       "--qd: expected 8 values (nv: the base's linear then angular entries, in base axes, then 2 joints), got 6"},
      {{"--urdf", brick, "--floating-base", "--q", q, "--qd", v, "--tau", "1"}, "--tau: expected 6 values"},
      {{"--urdf", brick, "--floating-base", "--q", "0,0,0,0,0,0,2", "--qd", v},
       "--q: the quaternion qx,qy,qz,qw (values 4 to 7) has norm 2; expected a unit quaternion (to 1e-04, then "
       "normalised)"},
      {{"--urdf", brick, "--floating-base", "--q", "0,0,0,0,0,0,0", "--qd", v}, "has norm 0;"},
      {{"--urdf", brick, "--floating-base", "--q", q, "--qd", v, "--method", "closed-form"},
       "--method: a floating base has the recursive and lagrangian paths, got 'closed-form'"},
      {{"--urdf", brick, "--floating-base", "--q", q, "--qd", v, "--method", "euler"},
       "--method: a floating base has the recursive and lagrangian paths, got 'euler'"},
      {{"--plant", "arm2", "--floating-base", "--q", "0,0", "--qd", "0,0"}, "--floating-base: only with --urdf FILE"},
      {{"--urdf", brick, "--floating-base", "--q", q, "--qd", v, "--derivatives"},
       "--derivatives: not with --floating-base yet"},
      {{"--urdf", brick, "--floating-base", "--q", q, "--qd", v, "--param", "mass_scale=1e9"},
       "--param mass_scale: expected a factor from 1e-06 to 1e+06, got 1000000000"},
      {{"--urdf", brick, "--floating-base", "--q", q, "--qd", v, "--param", "gravity=0,0,1"},
       "--param gravity: a urdf robot's gravity is --gravity gx,gy,gz"},
      {{"--urdf", brick, "--floating-base", "--q", q, "--qd", v, "--frame", "world"}, "--frame: no frame 'world'"},
      {{"--urdf", Massless(), "--floating-base", "--q", q, "--qd", v},
       "--urdf: " + Massless() + ": link 'hull': a floating base needs mass > 0 kg"},
  };
  ExpectEachRefused(cases);
}

// Every entry of a against b's to `tol`, relative to the larger magnitude (at least 1).
void ExpectNumbersNear(const Numbers& a, const Numbers& b, double tol, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a[i], b[i], tol * std::max({1.0, std::abs(a[i]), std::abs(b[i])})) << what << "[" << i << "]";
  }
}

// The Lagrangian (Euler–Poincaré) path and the recursive one are independent
// derivations: M, C v, G, v̇, T and V agree to 1e-10, on a base with two arms
// and on the same with a third arm whose joint mimics the first (nq, nv count
// degrees of freedom, not joints: 9 and 8 for its 3 joints).
TEST_F(EvalFloatingBase, TheLagrangianAndRecursivePathsAgree) {
  struct Case {
    std::string file, q, v, tau;
    int dofs;
  };
  const std::vector<Case> cases = {
      {File("two_arms.urdf"), "0.3,-0.2,0.5,0.1,0.2,0.3,0.9273618495495703,0.4,-0.05", "0.1,0.2,0.3,-0.4,0.5,-0.6,1,2",
       "0.5,-1,2,0.1,0.2,-0.3,0.7,-0.2", 2},
      {File("mimic_arms.urdf"), "0.3,-0.2,0.5,0.1,0.2,0.3,0.9273618495495703,0.4,-0.05",
       "0.1,0.2,0.3,-0.4,0.5,-0.6,1,2", "0.5,-1,2,0.1,0.2,-0.3,0.7,-0.2", 2},
  };
  for (const Case& c : cases) {
    const std::vector<std::string> state = {"--urdf", c.file, "--floating-base", "--q", c.q, "--qd", c.v, "--tau", c.tau};
    std::vector<std::string> lagrangian = state;
    lagrangian.insert(lagrangian.end(), {"--method", "lagrangian"});
    const json r = Eval(state), l = Eval(lagrangian);
    EXPECT_EQ(r.at("method").get<std::string>(), "recursive");
    EXPECT_EQ(l.at("method").get<std::string>(), "lagrangian");
    EXPECT_EQ(l.at("num_positions").get<int>(), c.dofs + 7) << c.file;
    EXPECT_EQ(l.at("num_velocities").get<int>(), c.dofs + 6) << c.file;
    const Rows M = l.at("M").get<Rows>(), M_r = r.at("M").get<Rows>();
    ASSERT_EQ(M.size(), M_r.size()) << c.file;
    for (std::size_t i = 0; i < M.size(); ++i) ExpectNumbersNear(M[i], M_r[i], 1e-10, c.file + " M row");
    for (const char* key : {"Cv", "G", "qdd"}) {
      ExpectNumbersNear(l.at(key).get<Numbers>(), r.at(key).get<Numbers>(), 1e-10, c.file + " " + key);
    }
    ExpectNumbersNear({l.at("T").get<double>(), l.at("V").get<double>()},
                      {r.at("T").get<double>(), r.at("V").get<double>()}, 1e-10, c.file + " T, V");
    // Not a trivial agreement: the state moves the robot.
    EXPECT_GT(std::abs(r.at("Cv").get<Numbers>()[0]), 1e-3) << c.file;
  }
}

// --param mass_scale=S scales every body's mass and inertia, the base's too, as a scene's params do: M, G,
// C v, T and V scale by S exactly (a power of two), and v̇ under a zero τ is unchanged.
TEST_F(EvalFloatingBase, MassScaleScalesTheBaseAndTheJointsAlike) {
  const std::vector<std::string> state = {"--urdf",
                                          File("two_arms.urdf"),
                                          "--floating-base",
                                          "--q",
                                          "0.3,-0.2,0.5,0.1,0.2,0.3,0.9273618495495703,0.4,-0.05",
                                          "--qd",
                                          "0.1,0.2,0.3,-0.4,0.5,-0.6,1,2"};
  std::vector<std::string> scaled_args = state;
  scaled_args.insert(scaled_args.end(), {"--param", "mass_scale=4"});
  const json one = Eval(state), four = Eval(scaled_args);
  const Rows M1 = one.at("M").get<Rows>(), M4 = four.at("M").get<Rows>();
  ASSERT_EQ(M1.size(), 8u);
  for (std::size_t i = 0; i < M1.size(); ++i) {
    for (std::size_t j = 0; j < M1.size(); ++j) EXPECT_DOUBLE_EQ(M4[i][j], 4 * M1[i][j]) << i << "," << j;
  }
  for (const char* key : {"Cv", "G"}) {
    const Numbers a = one.at(key).get<Numbers>(), b = four.at(key).get<Numbers>();
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(b[i], 4 * a[i], 1e-12 * (1 + std::abs(a[i]))) << key;
  }
  EXPECT_NEAR(four.at("T").get<double>(), 4 * one.at("T").get<double>(), 1e-12);
  EXPECT_NEAR(four.at("V").get<double>(), 4 * one.at("V").get<double>(), 1e-12);
  ExpectNumbersNear(four.at("qdd").get<Numbers>(), one.at("qdd").get<Numbers>(), 1e-12, "qdd");
  EXPECT_GT(M1[0][0], 5.0);  // the base's 5 kg and the arms' 1.5 kg: the base is in M
  // A free body alone (no joints): its 2 kg scaled to 4 kg.
  const json brick = Eval({"--urdf", File("brick.urdf"), "--floating-base", "--q", "0,0,1,0,0,0,1", "--qd",
                           "0,0,0,0,0,0", "--param", "mass_scale=2"});
  EXPECT_DOUBLE_EQ(brick.at("M").get<Rows>()[0][0], 4.0);
  EXPECT_DOUBLE_EQ(brick.at("G").get<Numbers>()[2], 4.0 * kG);
}

// A floating frame's jdot_qdot is J̇ v at v̇ = 0: the rate of J(q(t)) v along q(t) = q ⊕ t v (SE(3)'s
// exponential of the constant body twist, the joints at constant rate), by central differences of the
// Jacobians eval prints at q ⊕ ±h v, on the turning arm `a` and the sliding `b`.
TEST_F(EvalFloatingBase, FramesJdotQdotIsTheRateOfTheJacobianTimesV) {
  const std::string file = File("two_arms.urdf");
  Eigen::VectorXd q0(9), v(8);
  q0 << 0.3, -0.2, 0.5, 0.1, 0.2, 0.3, 0.9273618495495703, 0.4, -0.05;
  v << 0.1, 0.2, 0.3, -0.4, 0.5, -0.6, 1, 2;
  const auto list = [](const Eigen::VectorXd& x) {
    std::string text;
    for (double e : x) {
      if (!text.empty()) text += ',';
      text += FormatDouble(e);
    }
    return text;
  };
  const auto eval_at = [&](const Eigen::VectorXd& q) {
    return Eval({"--urdf", file, "--floating-base", "--q", list(q), "--qd", list(v), "--frame", "a", "--frame", "b"});
  };
  const double h = 1e-5;
  Eigen::VectorXd q_plus(9), q_minus(9);
  Integrate(q0, v, h, q_plus);
  Integrate(q0, v, -h, q_minus);
  const json at0 = eval_at(q0), plus = eval_at(q_plus), minus = eval_at(q_minus);
  for (const char* frame : {"a", "b"}) {
    const auto Jv = [&](const json& out) {
      const Rows J = out.at("frames").at(frame).at("jacobian").get<Rows>();
      Numbers r(6, 0.0);
      for (std::size_t i = 0; i < 6; ++i) {
        for (std::size_t k = 0; k < J[i].size(); ++k) r[i] += J[i][k] * v[static_cast<Eigen::Index>(k)];
      }
      return r;
    };
    const Numbers up = Jv(plus), down = Jv(minus);
    Numbers rate(6);
    for (std::size_t i = 0; i < 6; ++i) rate[i] = (up[i] - down[i]) / (2 * h);
    const Numbers jdot_v = at0.at("frames").at(frame).at("jdot_qdot").get<Numbers>();
    ExpectNumbersNear(jdot_v, rate, 1e-6, std::string("jdot_qdot of ") + frame);
    EXPECT_GT(std::abs(jdot_v[0]) + std::abs(jdot_v[1]) + std::abs(jdot_v[2]), 1e-2) << frame;  // not zero
  }
}

TEST_F(EvalFloatingBase, FramesListsTheBaseLinkFirst) {
  const json out = Eval({"--urdf", File("two_arms.urdf"), "--floating-base", "--frames"});
  EXPECT_EQ(out.at("frame_names"), json({"body", "a", "b"}));
}

}  // namespace
}  // namespace lagrange
