#pragma once
// Shipped scenes with a mujoco plant need MuJoCo, which a build without it
// (no libmujoco-dev when CMake ran: LAGRANGE_HAVE_MUJOCO 0) refuses to load:
// the tests that go over every shipped scene skip those there, and only there.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace lagrange::testing {

inline bool NeedsMujocoThisBuildLacks(const std::filesystem::path& scene) {
#if LAGRANGE_HAVE_MUJOCO
  (void)scene;
  return false;
#else
  std::ifstream in(scene);
  std::stringstream text;
  text << in.rdbuf();
  return text.str().find("type: mujoco") != std::string::npos;
#endif
}

}  // namespace lagrange::testing
