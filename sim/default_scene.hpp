#pragma once
// The scene lagranged runs without --config. An installed lagranged (any
// prefix, `cmake --install build --prefix P` included) runs the default scene
// installed with it, P/share/lagrange/config/default.yaml; a lagranged in a
// build tree runs this checkout's config/default.yaml.
//
// Compiled into lagrange_sim and what links it (lagrangectl view shows that
// scene by default): sim/CMakeLists.txt defines
//   LAGRANGE_DEFAULT_SCENE    this checkout's config/default.yaml (absolute)
//   LAGRANGE_INSTALLED_SCENE  the installed default.yaml relative to the
//                             installed lagranged's directory
//                             (../share/lagrange/config/default.yaml)

#include <filesystem>
#include <string>
#include <system_error>

namespace lagrange {

inline std::string DefaultScenePath() {
  std::error_code error;
  const std::filesystem::path program = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const std::filesystem::path installed = (program.parent_path() / LAGRANGE_INSTALLED_SCENE).lexically_normal();
    if (std::filesystem::is_regular_file(installed, error)) return installed.string();
  }
  return LAGRANGE_DEFAULT_SCENE;
}

}  // namespace lagrange
