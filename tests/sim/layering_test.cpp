// The folders are the architecture (STYLE.md, "The shape we want"), read from
// the source tree's #include lines and CMakeLists.txt files: base ← plant ←
// controllers ← sim and base ← protocol ← sim (the protocol needs the wire's
// vocabulary, base/, and no dynamics), and sim/ below daemon/, tools/ and python/;
// tools/, python/ and the test support include no daemon/ header and link no
// daemon target; inside sim/ and daemon/ dependencies run one way. So an
// include back up fails here (in milliseconds), not in review.
//
// A unit is a header with its source (sim/scene.hpp and sim/scene.cpp are
// the unit sim/scene); unit A depends on unit B when a file of A includes
// B's header. Two units that depend on each other, directly or through
// others, are one knot: neither can be built, tested or read without the other.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

namespace lagrange {
namespace {

namespace fs = std::filesystem;

const fs::path kRoot = LAGRANGE_SOURCE_DIR;

struct Include {
  std::string file;    // the including file, relative to the source root ("sim/scene.cpp")
  std::string header;  // what it includes, as written ("sim/scene_control.hpp")
};

// Every .hpp, .cpp and .hpp.in under `dir` (relative to the source root), recursively, relative to the root.
std::vector<std::string> SourcesUnder(const std::string& dir) {
  std::vector<std::string> out;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(kRoot / dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && (name.ends_with(".hpp") || name.ends_with(".cpp") || name.ends_with(".hpp.in"))) {
      out.push_back(fs::relative(e.path(), kRoot).string());
    }
  }
  return out;
}

// Every quoted #include of every source under `dir`.
std::vector<Include> IncludesUnder(const std::string& dir) {
  static const std::regex kInclude(R"re(^\s*#\s*include\s*"([^"]+)")re");
  std::vector<Include> out;
  for (const std::string& file : SourcesUnder(dir)) {
    std::ifstream in(kRoot / file);
    std::string line;
    std::smatch m;
    while (std::getline(in, line)) {
      if (std::regex_search(line, m, kInclude)) out.push_back({file, m[1]});
    }
  }
  return out;
}

// "sim/scene" for "sim/scene.hpp" or "sim/scene.cpp".
std::string UnitOf(const std::string& path) { return path.substr(0, path.find('.')); }

// The includes of `dirs` that name a header under any of `forbidden`, one per line.
std::string IncludesOf(const std::vector<std::string>& dirs, const std::vector<std::string>& forbidden) {
  std::string found;
  for (const std::string& dir : dirs) {
    for (const Include& i : IncludesUnder(dir)) {
      for (const std::string& f : forbidden) {
        if (i.header.starts_with(f)) found += i.file + " includes " + i.header + "\n";
      }
    }
  }
  return found;
}

using Graph = std::map<std::string, std::set<std::string>>;  // unit → the units it depends on

// The dependencies between the units of `dirs` (edges to units outside them left out).
Graph UnitGraph(const std::vector<std::string>& dirs) {
  Graph graph;
  std::vector<Include> all;
  for (const std::string& dir : dirs) {
    for (const std::string& file : SourcesUnder(dir)) graph[UnitOf(file)];
    for (const Include& i : IncludesUnder(dir)) all.push_back(i);
  }
  for (const Include& i : all) {
    const std::string from = UnitOf(i.file), to = UnitOf(i.header);
    if (from != to && graph.contains(to)) graph[from].insert(to);
  }
  return graph;
}

// The knots of `graph`: its strongly connected components of more than one
// unit (Tarjan's algorithm), each sorted.
std::vector<std::vector<std::string>> Knots(const Graph& graph) {
  std::map<std::string, int> index, low;
  std::vector<std::string> stack;
  std::set<std::string> on_stack;
  std::vector<std::vector<std::string>> knots;
  int next = 0;
  std::function<void(const std::string&)> visit = [&](const std::string& v) {
    index[v] = low[v] = next++;
    stack.push_back(v);
    on_stack.insert(v);
    for (const std::string& w : graph.at(v)) {
      if (!index.contains(w)) {
        visit(w);
        low[v] = std::min(low[v], low[w]);
      } else if (on_stack.contains(w)) {
        low[v] = std::min(low[v], index[w]);
      }
    }
    if (low[v] != index[v]) return;
    std::vector<std::string> component;
    std::string w;
    do {
      w = stack.back();
      stack.pop_back();
      on_stack.erase(w);
      component.push_back(w);
    } while (w != v);
    if (component.size() > 1) {
      std::sort(component.begin(), component.end());
      knots.push_back(component);
    }
  };
  for (const auto& [unit, _] : graph) {
    if (!index.contains(unit)) visit(unit);
  }
  return knots;
}

// "sim/a → sim/b, sim/b → sim/a": the edges inside a knot.
std::string Describe(const Graph& graph, const std::vector<std::string>& knot) {
  std::string text;
  for (const std::string& from : knot) {
    for (const std::string& to : graph.at(from)) {
      if (std::binary_search(knot.begin(), knot.end(), to)) text += (text.empty() ? "" : ", ") + from + " → " + to;
    }
  }
  return text;
}

TEST(Layering, TheSimulatorIncludesNothingAboveIt) {
  EXPECT_EQ(IncludesOf({"sim"}, {"daemon/", "tools/", "python/", "tests/"}), "");
}

TEST(Layering, ToolsPythonAndTheTestSupportIncludeNoDaemonHeader) {
  EXPECT_EQ(IncludesOf({"tools", "python", "tests/support"}, {"daemon/"}), "");
}

// The lines of the CMakeLists.txt `files` (relative to the source root) that
// name the target `target`, comments left out, one per line.
std::string LinesNaming(const std::vector<std::string>& files, const std::string& target) {
  const std::regex word("(^|[^A-Za-z0-9_])" + target + "($|[^A-Za-z0-9_])");
  std::string found;
  for (const std::string& file : files) {
    std::ifstream in(kRoot / file);
    EXPECT_TRUE(in.is_open()) << file;
    std::string line;
    while (std::getline(in, line)) {
      const std::string code = line.substr(0, line.find('#'));
      if (std::regex_search(code, word)) found += file + ": " + line + "\n";
    }
  }
  return found;
}

TEST(Layering, ToolsPythonAndTheTestSupportLinkNoDaemonTarget) {
  // tests/CMakeLists.txt defines the test-support libraries; the daemon's own tests are in tests/daemon/.
  // daemon/ has two targets: lagrange_daemon and the tick alone, lagrange_runtime (which the scene fuzzer links).
  EXPECT_EQ(LinesNaming({"tools/CMakeLists.txt", "python/CMakeLists.txt", "tests/CMakeLists.txt",
                         "tests/tools/CMakeLists.txt", "tests/python/CMakeLists.txt"},
                        "lagrange_(daemon|runtime)"),
            "");
  // The scan reads the files (a scan that read nothing would pass anything).
  EXPECT_NE(LinesNaming({"daemon/CMakeLists.txt"}, "lagrange_daemon"), "");
  EXPECT_NE(LinesNaming({"daemon/CMakeLists.txt"}, "lagrange_runtime"), "");
}

TEST(Layering, ThePlantAndTheControllersIncludeNothingAboveThem) {
  EXPECT_EQ(IncludesOf({"plant"}, {"controllers/", "protocol/", "sim/", "daemon/", "tools/", "python/", "tests/"}), "");
  EXPECT_EQ(IncludesOf({"controllers"}, {"protocol/", "sim/", "daemon/", "tools/", "python/", "tests/"}), "");
}

TEST(Layering, TheBaseIncludesNothingButItself) {
  EXPECT_EQ(IncludesOf({"base"}, {"plant/", "controllers/", "protocol/", "sim/", "daemon/", "tools/", "python/",
                                  "tests/"}),
            "");
}

TEST(Layering, TheProtocolIncludesNothingAboveIt) {
  EXPECT_EQ(IncludesOf({"protocol"}, {"sim/", "daemon/", "tools/", "python/", "tests/"}), "");
}

// A bus client (lagrangectl's live commands, the Python client, the view) needs the wire, not the dynamics: the
// protocol speaks the wire's vocabulary (base/) and includes and links nothing of plant/ or controllers/.
TEST(Layering, TheProtocolNeedsNoDynamics) {
  EXPECT_EQ(IncludesOf({"protocol"}, {"plant/", "controllers/"}), "");
  for (const char* target : {"lagrange_plant", "lagrange_urdf", "lagrange_mujoco", "lagrange_controllers"}) {
    EXPECT_EQ(LinesNaming({"protocol/CMakeLists.txt"}, target), "") << target;
  }
  // The scans read the files (a scan that read nothing would pass anything).
  EXPECT_NE(LinesNaming({"protocol/CMakeLists.txt"}, "lagrange_base"), "");
  EXPECT_NE(IncludesOf({"protocol"}, {"base/"}), "");
}

TEST(Layering, NoTwoUnitsOfTheSimulatorOrTheDaemonDependOnEachOther) {
  const Graph graph = UnitGraph({"sim", "daemon"});
  // The scan sees the tree (a scan that read nothing would pass anything).
  ASSERT_TRUE(graph.contains("sim/instance") && graph.contains("daemon/runtime"));
  EXPECT_TRUE(graph.at("daemon/runtime").contains("sim/instance"));
  for (const std::vector<std::string>& knot : Knots(graph)) ADD_FAILURE() << "a knot: " << Describe(graph, knot);
}

// The detector itself, on a graph with one knot of three and a unit that only depends on it.
TEST(Layering, AKnotThroughOthersIsFound) {
  const Graph graph = {{"a", {"b"}}, {"b", {"c"}}, {"c", {"a"}}, {"d", {"a"}}};
  const std::vector<std::vector<std::string>> knots = Knots(graph);
  ASSERT_EQ(knots.size(), 1u);
  EXPECT_EQ(knots[0], (std::vector<std::string>{"a", "b", "c"}));
  EXPECT_EQ(Describe(graph, knots[0]), "a → b, b → c, c → a");
  EXPECT_TRUE(Knots({{"a", {"b"}}, {"b", {}}}).empty());
}

}  // namespace
}  // namespace lagrange
