#pragma once
// The plant factory and parameter table: plant types, their named
// parameters, validation, each plant's tree, and the factory that builds a
// plant's dynamics model by any of the three methods.
//
// Parameter names (SI units):
//   pendulum  m, L, g, body (point | rod)
//   arm2      m1, m2, L1, L2, g
//   cartpole  mc, mp, l, I, g
//   chain     links, m, L, com, I, joints (revolute | prismatic) (every link,
//             or one link), base_angle, g
//   urdf      gravity ("gx,gy,gz", m/s², world frame), mass_scale; the robot
//             itself is loaded from its file by the scene reader or
//             lagrangectl (plant/urdf.hpp, library lagrange_urdf), never here

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "plant/arm2.hpp"
#include "plant/cartpole.hpp"
#include "plant/chain.hpp"
#include "plant/dynamics.hpp"
#include "plant/pendulum.hpp"
#include "plant/rigid_tree.hpp"
#include "plant/urdf.hpp"  // the UrdfRobot data only: lagrange_plant never reads a file

namespace lagrange {

enum class PlantType : std::uint8_t { kPendulum, kArm2, kCartPole, kChain, kUrdf };

std::string_view ToString(PlantType type);
std::optional<PlantType> ParsePlantType(std::string_view name);
// "pendulum|arm2|cartpole|chain|urdf"
std::string PlantTypeNames();

// A robot read from a URDF file (plant/urdf.hpp), as a plant. The robot is
// loaded once, by whoever reads files (the scene reader, lagrangectl), and
// shared read-only by every spec made from it (a plant and its controllers'
// models). There is no default robot: DefaultPlantSpec(kUrdf) has none, and
// ValidatePlantSpec refuses it until one is set.
struct UrdfParams {
  std::string file;                        // where the robot was read from, for messages
  std::shared_ptr<const UrdfRobot> robot;  // null: none loaded
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -kStandardGravity);  // m/s², world (root link) frame
  double mass_scale = 1.0;  // > 0: every link's mass and inertia × this (a model error for controllers)
};

using PlantParams = std::variant<PendulumParams, Arm2Params, CartPoleParams, ChainParams, UrdfParams>;

struct PlantSpec {
  PlantParams params;

  PlantType type() const { return static_cast<PlantType>(params.index()); }
  int num_dofs() const;
};

// A problem with one named parameter: `message` reads "expected ..., got ...".
struct SpecError {
  std::string key;
  std::string message;
};

// The default parameters of a plant type. A urdf spec has no robot (its
// num_dofs() is 0, and ValidatePlantSpec says a robot must be loaded): use
// UrdfPlantSpec.
PlantSpec DefaultPlantSpec(PlantType type);

// A urdf plant of `robot` (non-null) with the default gravity and mass scale.
PlantSpec UrdfPlantSpec(std::shared_ptr<const UrdfRobot> robot);

// The parameter names a plant type accepts, in documentation order.
std::vector<std::string_view> PlantParamNames(PlantType type);

// Sets one parameter from its text. `link` selects one chain link (0-based);
// -1 sets it on every link. A urdf plant's gravity is "gx,gy,gz". Unknown
// names, malformed or non-finite numbers and out-of-range values are refused
// and leave the spec unchanged.
std::optional<SpecError> SetPlantParam(PlantSpec& spec, std::string_view name, std::string_view text, int link = -1);

// Sets the chain's number of links (1..kMaxDofs), keeping existing links.
std::optional<SpecError> SetChainLinks(PlantSpec& spec, int links);

// Checks that the parameters describe a physical plant. For the built-in
// plants (positive masses, lengths and inertias) that makes M(q) positive
// definite at every configuration. For a urdf plant it checks the tree the
// dynamics get (after mass_scale): finite, positive masses, physical
// inertias, and M positive definite at q = 0 only (ValidateRigidTree); other
// configurations are not checked.
std::optional<SpecError> ValidatePlantSpec(const PlantSpec& spec);

// Closed forms exist for pendulum, arm2 and cartpole; every plant has the
// lagrangian and recursive paths.
bool HasMethod(PlantType type, Method method);
// Why `type` cannot be derived by `method` (a static string: the scene reader
// and the run-time method command both say it), or null when it can.
const char* NoMethodReason(PlantType type, Method method);
// The fastest exact path: closed form where one exists, else recursive.
Method FastestMethod(PlantType type);

// Default bound on |T + V| for a plant instance: 1000 × (1 J + Σ m g ×
// reach), a few hundred times anything its gravity can supply. J. For a urdf
// plant the sum runs over its bodies, each with |gravity| and the farthest its
// centre of mass can be from the world origin (the lengths of the joint
// offsets from the root to it, plus its centre-of-mass offset, plus the
// largest |limit| of each prismatic joint on the way, 1 m when it has none).
double DefaultMaxEnergy(const PlantSpec& spec);

// The plant's tree (plant/rigid_tree.hpp), the one description of its
// bodies and joints: a built-in plant's planar tree (ToRigidTree of its
// parameters), or a urdf plant's as simulated: the robot's, with the spec's
// gravity and every mass and inertia × mass_scale. Throws
// std::invalid_argument for a urdf spec without a robot.
RigidTree MakeRigidTree(const PlantSpec& spec);
RigidTree MakeRigidTree(const UrdfParams& params);

// The joint types and names, in q order (the tree's); empty for a urdf spec
// without a robot. A urdf plant's names are its file's; the built-in plants
// name theirs: pendulum "theta", arm2 "q1", "q2", cartpole "x", "theta",
// chain "q1" .. "qn".
std::vector<JointType> JointTypesOf(const PlantSpec& spec);
std::vector<std::string> JointNamesOf(const PlantSpec& spec);

// Builds the plant's dynamics model by `method` (shareable: make data per
// user, plant/dynamics.hpp). From the plant's tree: a urdf plant's are
// SpatialDynamics (recursive) or LagrangianDynamics<RigidTree>; the built-in
// plants' planar chains run the planar recursive algorithms (and, for the
// chain, the planar Lagrangian energies); closed forms are hand-derived. Throws
// std::invalid_argument when the spec is invalid or the plant has no such method.
std::unique_ptr<Dynamics> MakeDynamics(const PlantSpec& spec, Method method);

// A plant's dynamics models by Method (indexed static_cast<std::size_t>(method)),
// null where not built: built once, then shared read-only by everyone who
// evaluates the plant (its instance, its controllers), each with data of
// their own.
inline constexpr std::size_t kNumMethods = 3;
using MethodModels = std::array<std::shared_ptr<const Dynamics>, kNumMethods>;
// Every method the plant has (HasMethod). Throws as MakeDynamics.
MethodModels MakeMethodModels(const PlantSpec& spec);

// Strict number parsing shared by every front end: the whole text must be a
// finite decimal number.
std::optional<double> ParseFiniteNumber(std::string_view text);

}  // namespace lagrange
