#include "plant/stepped_plant.hpp"

namespace lagrange {

std::optional<MujocoIntegrator> ParseMujocoIntegrator(std::string_view name) {
  if (name == "euler" || name == "semi-implicit-euler") return MujocoIntegrator::kEuler;
  if (name == "rk4") return MujocoIntegrator::kRk4;
  if (name == "implicit") return MujocoIntegrator::kImplicit;
  return std::nullopt;
}

std::string_view ToString(MujocoIntegrator integrator) {
  switch (integrator) {
    case MujocoIntegrator::kEuler: return "euler";
    case MujocoIntegrator::kRk4: return "rk4";
    case MujocoIntegrator::kImplicit: return "implicit";
  }
  return "?";
}

}  // namespace lagrange
