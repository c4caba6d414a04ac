// `cmake --install` into a fresh prefix gives an installation that works on
// its own: the programs, their default scene under the prefix, every shipped
// scene, the .lcm files, the generated headers, the lcm-spy jar when built,
// and a pkg-config file and a CMake package that a user's own LCM client
// compiles against.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "sim/offline.hpp"
#include "sim/scene.hpp"
#include "tests/support/process.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using testing::ReadFile;
using testing::RunProcess;

// A client of the installed types: encodes a state_t and decodes it back.
constexpr const char* kClient = R"(#include <lagrange/state_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <vector>
int main() {
  lagrange::state_t s{};
  s.num_dofs = 2;
  s.q = {0.5, -0.25};
  s.qd = s.qdd = s.tau = s.q_des = s.qd_des = std::vector<double>(2, 0.0);
  std::vector<unsigned char> buffer(s.getEncodedSize());
  if (s.encode(buffer.data(), 0, static_cast<int>(buffer.size())) < 0) return 1;
  lagrange::state_t back;
  if (back.decode(buffer.data(), 0, static_cast<int>(buffer.size())) < 0) return 2;
  return back.num_dofs == 2 && back.q[1] == -0.25 ? 0 : 3;
}
)";

// Runs a shell command line; its output on failure.
testing::ProcessResult Shell(const std::string& command) { return RunProcess({"/bin/sh", "-c", command}, 120.0); }

// Appended, not "'" + string: g++ 12 warns of an overlap (-Wrestrict) that operator+ cannot have.
std::string Quote(const fs::path& p) { return std::string("'").append(p.string()).append("'"); }

class Install : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    prefix_ = fs::temp_directory_path() / ("lagrange_install_" + std::to_string(::getpid()));
    fs::remove_all(prefix_);
    const auto r = RunProcess({CMAKE_COMMAND, "--install", LAGRANGE_BINARY_DIR, "--prefix", prefix_.string()}, 120.0);
    install_status_ = r.exit_code;
    install_output_ = r.out + r.err;
  }
  static void TearDownTestSuite() { fs::remove_all(prefix_); }
  void SetUp() override { ASSERT_EQ(install_status_, 0) << install_output_; }

  static fs::path prefix_;
  static int install_status_;
  static std::string install_output_;
};

fs::path Install::prefix_;
int Install::install_status_ = -1;
std::string Install::install_output_;

TEST_F(Install, LagrangedRunsItsDefaultSceneFromUnderThePrefix) {
  const fs::path lagranged = prefix_ / "bin/lagranged";
  const auto help = RunProcess({lagranged.string(), "--help"});
  ASSERT_EQ(help.exit_code, 0) << help.err;
  const fs::path scene = prefix_ / "share/lagrange/config/default.yaml";
  std::string config_line;
  for (const std::string& line : testing::Lines(help.out)) {
    if (line.find("--config") != std::string::npos) config_line = line;
  }
  EXPECT_NE(config_line.find(scene.string()), std::string::npos) << help.out;
  EXPECT_EQ(config_line.find(LAGRANGE_SOURCE_DIR), std::string::npos) << config_line;
  // And runs it: a few ticks on the in-process transport, no network needed.
  const auto run = RunProcess({lagranged.string(), "--lcm-url", "inprocess://", "--duration", "0.05"}, 60.0);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find(scene.string()), std::string::npos) << run.err;
}

TEST_F(Install, EveryShippedSceneIsInstalledAndRuns) {
  std::vector<fs::path> scenes;
  for (const auto& entry : fs::directory_iterator(fs::path(LAGRANGE_SOURCE_DIR) / "config")) {
    if (entry.path().extension() == ".yaml") scenes.push_back(entry.path().filename());
  }
  ASSERT_GE(scenes.size(), 7u);
  for (const fs::path& name : scenes) {
    const fs::path installed = prefix_ / "share/lagrange/config" / name;
    ASSERT_TRUE(fs::is_regular_file(installed)) << name << " is not in the top-level CMakeLists.txt's install list";
    // A scene with an external plant or controller needs the bus: lagranged runs it, on the in-process transport.
    const Scene scene = LoadScene(installed.string());
    const bool offline = std::none_of(scene.instances.begin(), scene.instances.end(),
                                      [](const InstanceConfig& c) { return OfflineRefusal(c) != nullptr; });
    const auto r = offline ? RunProcess({(prefix_ / "bin/lagrangectl").string(), "simulate", installed.string(),
                                         "--duration", "0.01", "--csv", (prefix_ / "run.csv").string()})
                           : RunProcess({(prefix_ / "bin/lagranged").string(), "--lcm-url", "inprocess://", "--config",
                                         installed.string(), "--duration", "0.05"},
                                        60.0);
    EXPECT_EQ(r.exit_code, 0) << name << ": " << r.err;
  }
  EXPECT_TRUE(fs::is_regular_file(prefix_ / "lib/systemd/system/lagranged.service"));
  EXPECT_TRUE(fs::is_regular_file(prefix_ / "share/doc/lagrange/README.md"));
}

// Under a prefix other than /usr/local the unit runs that prefix's programs and scene.
TEST_F(Install, TheUnitNamesThePrefixItWasInstalledUnder) {
  const std::string unit = ReadFile(prefix_ / "lib/systemd/system/lagranged.service");
  EXPECT_NE(unit.find("ExecStart=" + (prefix_ / "bin/lagranged").string() + " --config " +
                      (prefix_ / "share/lagrange/config/default.yaml").string()),
            std::string::npos)
      << unit;
  EXPECT_EQ(unit.find("/usr/local/"), std::string::npos) << unit;
}

// The unprivileged unit gets the receive buffer lagranged asks for once the
// installed sysctl file raises the kernel's cap to it (README, "Floods").
TEST_F(Install, TheSysctlFileRaisesTheReceiveBufferCapToWhatLagrangedAsks) {
  const std::string conf = ReadFile(prefix_ / "lib/sysctl.d/60-lagrange.conf");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(conf, m, std::regex("\\nnet\\.core\\.rmem_max = ([0-9]+)\\n"))) << conf;
  EXPECT_EQ(std::stol(m[1]), 2L * 1024 * 1024);
}

// The installed README's links lead somewhere, and the example client's source is there to copy.
TEST_F(Install, TheInstalledReadmesLinksResolveAndTheExampleSourceIsThere) {
  const fs::path doc = prefix_ / "share/doc/lagrange";
  const std::string readme = ReadFile(doc / "README.md");
  const std::regex link(R"(\]\(([^)#:]+)\))");
  int links = 0;
  for (auto it = std::sregex_iterator(readme.begin(), readme.end(), link); it != std::sregex_iterator(); ++it) {
    EXPECT_TRUE(fs::exists(doc / (*it)[1].str())) << (*it)[1].str();
    ++links;
  }
  EXPECT_GT(links, 0);
  EXPECT_TRUE(fs::is_regular_file(doc / "examples/cpp/impedance_client.cpp"));
  EXPECT_TRUE(fs::is_regular_file(doc / "examples/python/external_controller.py"));
}

TEST_F(Install, TheLcmTypesAreInstalledAsDefinitionsHeadersAndJar) {
  int types = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(LAGRANGE_SOURCE_DIR) / "lcmtypes")) {
    if (entry.path().extension() != ".lcm") continue;
    ++types;
    const std::string name = entry.path().stem().string();
    EXPECT_TRUE(fs::is_regular_file(prefix_ / "share/lagrange/lcmtypes" / entry.path().filename())) << name;
    EXPECT_TRUE(fs::is_regular_file(prefix_ / "include/lagrange" / (name + ".hpp"))) << name;
  }
  EXPECT_GE(types, 4);
  if (std::string(LAGRANGE_LCM_JAR).empty()) GTEST_SKIP() << "built without a JDK: no lcm-spy jar to install";
  EXPECT_TRUE(fs::is_regular_file(prefix_ / "share/java/lagrange_lcmtypes.jar"));
}

TEST_F(Install, AClientCompilesAgainstTheInstalledHeadersWithPkgConfig) {
  const fs::path dir = prefix_ / "pkg_client";
  fs::create_directories(dir);
  std::ofstream(dir / "client.cpp") << kClient;
  const std::string env = "PKG_CONFIG_PATH=" + Quote(prefix_ / "share/pkgconfig") + " ";
  const auto flags = Shell(env + "pkg-config --cflags --libs lagrange-lcmtypes");
  ASSERT_EQ(flags.exit_code, 0) << flags.err;
  // Cflags: the installed headers (the .pc file is relocatable: the path goes through its own directory).
  const std::size_t include = flags.out.find("-I");
  ASSERT_NE(include, std::string::npos) << flags.out;
  const std::string include_dir = flags.out.substr(include + 2, flags.out.find(' ', include) - include - 2);
  EXPECT_EQ(fs::canonical(include_dir), fs::canonical(prefix_ / "include")) << flags.out;
  EXPECT_NE(flags.out.find("-llcm"), std::string::npos) << flags.out;
  const auto build = Shell(std::string(CXX_COMPILER) + " -std=c++17 -o " + Quote(dir / "client") + " " +
                           Quote(dir / "client.cpp") + " $(" + env + "pkg-config --cflags --libs lagrange-lcmtypes)");
  ASSERT_EQ(build.exit_code, 0) << build.err;
  const auto run = RunProcess({(dir / "client").string()});
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

// The example client as a user copies it from the installed documentation
// builds against the installation alone: the types, lcm::LCM, libsodium and
// <lagrange/bus_domain.hpp>, the bus domain of signed traffic.
TEST_F(Install, TheInstalledExampleClientBuildsAgainstTheInstallationAlone) {
  const fs::path examples = prefix_ / "share/doc/lagrange/examples/cpp";
  ASSERT_TRUE(fs::is_regular_file(prefix_ / "include/lagrange/bus_domain.hpp"));
  const fs::path dir = prefix_ / "example_copy";
  fs::create_directories(dir);
  for (const char* file : {"impedance_client.cpp", "bus_signing.hpp"}) fs::copy_file(examples / file, dir / file);
  const std::string env = "PKG_CONFIG_PATH=" + Quote(prefix_ / "share/pkgconfig") + " ";
  const auto build = Shell(std::string(CXX_COMPILER) + " -std=c++20 -o " + Quote(dir / "impedance_client") + " " +
                           Quote(dir / "impedance_client.cpp") + " $(" + env +
                           "pkg-config --cflags --libs lagrange-lcmtypes) -lsodium");
  ASSERT_EQ(build.exit_code, 0) << build.err;
  const auto help = RunProcess({(dir / "impedance_client").string(), "--help"});
  EXPECT_EQ(help.exit_code, 0) << help.err;
  EXPECT_NE(help.out.find("--bus-domain"), std::string::npos) << help.out;
}

TEST_F(Install, AClientBuildsWithFindPackageLagrange) {
  const fs::path dir = prefix_ / "cmake_client";
  fs::create_directories(dir);
  std::ofstream(dir / "client.cpp") << kClient;
  std::ofstream(dir / "CMakeLists.txt") << "cmake_minimum_required(VERSION 3.16)\n"
                                           "project(client LANGUAGES CXX)\n"
                                           "find_package(lagrange 0.1 REQUIRED)\n"
                                           "add_executable(client client.cpp)\n"
                                           "target_compile_features(client PRIVATE cxx_std_17)\n"
                                           "target_link_libraries(client PRIVATE lagrange::lcmtypes)\n";
  const auto configure = RunProcess({CMAKE_COMMAND, "-S", dir.string(), "-B", (dir / "build").string(),
                                     "-DCMAKE_PREFIX_PATH=" + prefix_.string(), "-DCMAKE_CXX_COMPILER=" CXX_COMPILER},
                                    120.0);
  ASSERT_EQ(configure.exit_code, 0) << configure.out << configure.err;
  const auto build = RunProcess({CMAKE_COMMAND, "--build", (dir / "build").string()}, 120.0);
  ASSERT_EQ(build.exit_code, 0) << build.out << build.err;
  const auto run = RunProcess({(dir / "build/client").string()});
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

// Debian's python3 finds the package under /usr/local without PYTHONPATH; under
// another prefix the same relative directory holds it, and it imports from
// there alone (no build tree), with the prefix's robot.
TEST_F(Install, ThePythonPackageIsInstalledWhereTheInterpreterLooksUnderThePrefix) {
  const std::string python = LAGRANGE_PYTHON_EXECUTABLE, dir = LAGRANGE_PYTHON_INSTALL_DIR;
  if (python.empty()) GTEST_SKIP() << "built without the Python module";
  const fs::path package = prefix_ / dir / "lagrange";
  for (const char* file : {"__init__.py", "__init__.pyi", "py.typed"}) {
    EXPECT_TRUE(fs::is_regular_file(package / file)) << file;
  }
  const auto path = RunProcess({python, "-c", "import sys; print('\\n'.join(sys.path))"});
  ASSERT_EQ(path.exit_code, 0) << path.err;
  const std::vector<std::string> entries = testing::Lines(path.out);
  if (fs::exists("/etc/debian_version")) {
    EXPECT_NE(std::find(entries.begin(), entries.end(), (fs::path("/usr/local") / dir).string()), entries.end()) << path.out;
  }
  const std::string code = "import lagrange; m = lagrange.Model.from_urdf('" +
                           (prefix_ / "share/lagrange/config/robots/panda.urdf").string() +
                           "'); print(m.num_dofs); print(lagrange.__file__)";
  const auto run = Shell("cd / && PYTHONPATH=" + Quote(prefix_ / dir) + " " + python + " -c \"" + code + "\"");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::string> lines = testing::Lines(run.out);
  ASSERT_EQ(lines.size(), 2u) << run.out;
  EXPECT_EQ(lines[0], "7");
  EXPECT_EQ(fs::path(lines[1]), package / "__init__.py");
}

}  // namespace
}  // namespace lagrange
