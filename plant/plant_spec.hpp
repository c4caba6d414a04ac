#pragma once
// Plant types, their named parameters, validation, and the factory that
// builds a plant's dynamics by any of the three methods.
//
// Parameter names (SI units):
//   pendulum  m, L, g, body (point | rod)
//   arm2      m1, m2, L1, L2, g
//   cartpole  mc, mp, l, I, g
//   chain     links, m, L, com, I, joints (revolute | prismatic) (every link,
//             or one link), base_angle, g

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

namespace lagrange {

enum class PlantType : std::uint8_t { kPendulum, kArm2, kCartPole, kChain };

std::string_view ToString(PlantType type);
std::optional<PlantType> ParsePlantType(std::string_view name);
// "pendulum|arm2|cartpole|chain"
std::string PlantTypeNames();

using PlantParams = std::variant<PendulumParams, Arm2Params, CartPoleParams, ChainParams>;

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

PlantSpec DefaultPlantSpec(PlantType type);

// The parameter names a plant type accepts, in documentation order.
std::vector<std::string_view> PlantParamNames(PlantType type);

// Sets one parameter from its text. `link` selects one chain link (0-based);
// -1 sets it on every link. Unknown names, malformed or non-finite numbers and
// out-of-range values are refused and leave the spec unchanged.
std::optional<SpecError> SetPlantParam(PlantSpec& spec, std::string_view name, std::string_view text, int link = -1);

// Sets the chain's number of links (1..kMaxDofs), keeping existing links.
std::optional<SpecError> SetChainLinks(PlantSpec& spec, int links);

// Checks that the parameters describe a physical plant with a positive
// definite mass matrix at every configuration.
std::optional<SpecError> ValidatePlantSpec(const PlantSpec& spec);

bool HasMethod(PlantType type, Method method);
// The fastest exact path: closed form where one exists, else recursive.
Method FastestMethod(PlantType type);

// Default bound on |T + V| for a plant instance: 1000 × (1 J + Σ m g ×
// reach), a few hundred times anything its gravity can supply. J.
double DefaultMaxEnergy(const PlantSpec& spec);

// The joint types, base first.
std::vector<JointType> JointTypesOf(const PlantSpec& spec);

// The plant as a planar chain (the recursive path's model).
PlanarChain ToPlanarChain(const PlantSpec& spec);

// Builds the plant's dynamics by `method`. Throws std::invalid_argument when
// the spec is invalid or the plant has no such method.
std::unique_ptr<Dynamics> MakeDynamics(const PlantSpec& spec, Method method);

// Strict number parsing shared by every front end: the whole text must be a
// finite decimal number.
std::optional<double> ParseFiniteNumber(std::string_view text);

}  // namespace lagrange
