// libFuzzer target: the URDF loader. Any text is either refused with a
// one-line UrdfError or becomes a robot that ValidateRigidTree accepts, with
// one set of joint properties per degree of freedom (mimics have none), and
// whose mass matrix at q = 0 is finite; nothing else may escape, crash,
// overflow the stack or trip a sanitizer. Seeded by scripts/fuzz with the
// shipped robots and every URDF fixture.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "plant/mimic_dynamics.hpp"
#include "plant/spatial_dynamics.hpp"
#include "plant/urdf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace lagrange;
  UrdfRobot robot;
  try {
    robot = ParseUrdf(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.urdf");
  } catch (const UrdfError& e) {
    if (std::string_view(e.what()).find('\n') != std::string_view::npos) __builtin_trap();  // one line
    return 0;
  }
  if (ValidateRigidTree(robot.tree)) __builtin_trap();  // the loader returns only valid trees
  if (robot.properties.size() != static_cast<std::size_t>(robot.tree.num_dofs())) __builtin_trap();  // one per dof
  // With mimic joints, the recursive path on the free tree, reduced (plant/mimic_dynamics.hpp).
  std::unique_ptr<Dynamics> made;
  if (robot.tree.has_mimics()) {
    made = std::make_unique<MimicDynamics>(robot.tree,
                                           std::make_shared<const SpatialDynamics>(robot.tree.WithEveryJointFree()));
  } else {
    made = std::make_unique<SpatialDynamics>(robot.tree);
  }
  const Dynamics& dynamics = *made;
  const std::unique_ptr<DynamicsData> dynamics_data = dynamics.MakeData();
  const int n = robot.tree.num_dofs();
  MatrixXd M(n, n);
  dynamics.ComputeMassMatrix(*dynamics_data, VectorXd::Zero(n), M);
  if (!M.allFinite()) __builtin_trap();
  return 0;
}
