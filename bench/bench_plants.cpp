#include "bench/bench_plants.hpp"

#include <numbers>

namespace lagrange::bench {

std::vector<NamedPlant> FixedPlants() {
  return {{"pendulum", DefaultPlantSpec(PlantType::kPendulum)},
          {"arm2", DefaultPlantSpec(PlantType::kArm2)},
          {"cartpole", DefaultPlantSpec(PlantType::kCartPole)}};
}

std::vector<int> ChainSizes() { return {2, 4, 7, 12, 20, 30, 50}; }

NamedPlant Chain(int links) {
  PlantSpec spec = DefaultPlantSpec(PlantType::kChain);
  SetChainLinks(spec, links);
  return {"chain" + std::to_string(links), spec};
}

std::vector<Method> MethodsOf(PlantType type) {
  std::vector<Method> methods;
  for (Method m : {Method::kClosedForm, Method::kLagrangian, Method::kRecursive}) {
    if (HasMethod(type, m)) methods.push_back(m);
  }
  return methods;
}

std::vector<State> RandomStates(const std::vector<JointType>& joints, int count, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto n = static_cast<int>(joints.size());
  std::vector<State> states;
  for (int k = 0; k < count; ++k) {
    State s{VectorXd(n), VectorXd(n), VectorXd(n)};
    for (int i = 0; i < n; ++i) {
      s.q[i] = unit(rng) * (joints[i] == JointType::kRevolute ? std::numbers::pi : 1.0);
      s.qd[i] = 2.0 * unit(rng);
      s.tau[i] = unit(rng);
    }
    states.push_back(std::move(s));
  }
  return states;
}

EffectsConfig DefaultEffects() { return EffectsConfig{}; }

}  // namespace lagrange::bench
