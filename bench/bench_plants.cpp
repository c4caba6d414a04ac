#include "bench/bench_plants.hpp"

#include <memory>
#include <numbers>

#include "plant/random_tree.hpp"
#include "plant/urdf.hpp"

namespace lagrange::bench {

std::vector<NamedPlant> FixedPlants() {
  return {{"pendulum", DefaultPlantSpec(PlantType::kPendulum)},
          {"arm2", DefaultPlantSpec(PlantType::kArm2)},
          {"cartpole", DefaultPlantSpec(PlantType::kCartPole)}};
}

std::vector<int> ChainSizes() { return {2, 4, 7, 12, 20, 30, 50, 64}; }

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

std::vector<std::string> ShippedRobotNames() { return {"panda", "ur5"}; }

NamedTree LoadShippedRobot(const std::string& name) {
  return {name, LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + name + ".urdf").tree};
}

NamedPlant ShippedRobotPlant(const std::string& name) {
  return {name, UrdfPlantSpec(std::make_shared<const UrdfRobot>(
                    LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + name + ".urdf")))};
}

std::vector<int> SpatialChainSizes() { return ChainSizes(); }

NamedTree RandomSpatialChain(int links, std::uint32_t seed, double prismatic_fraction) {
  std::mt19937 rng{seed};
  RandomTreeOptions options;
  options.bodies = links;
  options.chain = true;
  options.prismatic_fraction = prismatic_fraction;
  return {"spatial" + std::to_string(links), RandomRigidTree(options, rng)};
}

std::vector<State> RandomStates(const std::vector<JointType>& joints, int count, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto n = static_cast<int>(joints.size());
  std::vector<State> states;
  for (int k = 0; k < count; ++k) {
    State s{VectorXd(n), VectorXd(n), VectorXd(n), VectorXd(n)};
    for (int i = 0; i < n; ++i) {
      s.q[i] = unit(rng) * (joints[i] == JointType::kRevolute ? std::numbers::pi : 1.0);
      s.qd[i] = 2.0 * unit(rng);
      s.tau[i] = unit(rng);
    }
    states.push_back(std::move(s));
  }
  for (State& s : states) {
    for (int i = 0; i < n; ++i) s.qdd[i] = unit(rng);
  }
  return states;
}

EffectsConfig DefaultEffects() { return EffectsConfig{}; }

std::string_view TermName(DynamicsTerm term) {
  switch (term) {
    case DynamicsTerm::kM: return "M";
    case DynamicsTerm::kC: return "C";
    case DynamicsTerm::kCqd: return "Cqd";
    case DynamicsTerm::kG: return "G";
    case DynamicsTerm::kdTdq: return "dTdq";
    case DynamicsTerm::kID: return "ID";
    case DynamicsTerm::kFD: return "FD";
  }
  return "?";
}

void EvaluateTerm(const Dynamics& d, DynamicsData& data, DynamicsTerm term, const State& s, MatrixXd& M,
                  VectorXd& v) {
  DynamicsData* const d_data = &data;
  switch (term) {
    case DynamicsTerm::kM: d.ComputeMassMatrix(*d_data, s.q, M); break;
    case DynamicsTerm::kC: d.ComputeCoriolisMatrix(*d_data, s.q, s.qd, M); break;
    case DynamicsTerm::kCqd: d.ComputeCoriolisForce(*d_data, s.q, s.qd, v); break;
    case DynamicsTerm::kG: d.ComputeGravityForce(*d_data, s.q, v); break;
    case DynamicsTerm::kdTdq: d.ComputeKineticEnergyGradient(*d_data, s.q, s.qd, v); break;
    case DynamicsTerm::kID: d.ComputeInverseDynamics(*d_data, s.q, s.qd, s.qdd, DynamicsTerms{}, v); break;
    case DynamicsTerm::kFD: d.ComputeForwardDynamics(*d_data, s.q, s.qd, s.tau, DynamicsTerms{}, v); break;
  }
}

void TimeTerm(benchmark::State& bm, const Dynamics& d, DynamicsTerm term) {
  TimeCall(bm, d, [&d, term](DynamicsData& data, const State& s, MatrixXd& M, VectorXd& v) {
    EvaluateTerm(d, data, term, s, M, v);
  });
}

}  // namespace lagrange::bench
