#pragma once
// Plants, states and models shared by the benchmark programs.
//
// Every state comes from a seeded generator (std::mt19937{42}), so two runs
// time the same arithmetic. Units as in plant/types.hpp: q in rad or m,
// qd in rad/s or m/s, tau in N·m or N.

#include <random>
#include <string>
#include <vector>

#include "plant/effects.hpp"
#include "plant/plant_spec.hpp"

namespace lagrange::bench {

// A plant to time, with the name the report uses ("arm2", "chain30").
struct NamedPlant {
  std::string name;
  PlantSpec spec;
};

// pendulum, arm2 and cartpole with their default parameters.
std::vector<NamedPlant> FixedPlants();
// Chains of the sizes: n = 2, 4, 7, 12, 20, 30, 50 default links.
std::vector<int> ChainSizes();
NamedPlant Chain(int links);

// The methods a plant type has, closed form first.
std::vector<Method> MethodsOf(PlantType type);

// One state and command for a plant of n dofs.
struct State {
  VectorXd q, qd, tau;
};

// `count` random states: q uniform in ±π (±1 m for a prismatic joint), qd in
// ±2 rad/s (m/s), tau in ±1 N·m (N).
std::vector<State> RandomStates(const std::vector<JointType>& joints, int count, std::mt19937& rng);

// Gravity and Coriolis terms on, every optional effect off.
EffectsConfig DefaultEffects();

}  // namespace lagrange::bench
