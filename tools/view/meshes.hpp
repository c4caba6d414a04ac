#pragma once
// The mesh files a URDF's <visual>s name, as lagrangectl view finds, checks
// and serves them. A robot package is foreign input: a <mesh filename> may say
// "../../x.stl", the package may hold a symlink to /etc/shadow, and the view
// may run as root and be reached from the network (--bind). A mesh is served
// only when
//   - it is found as ROS finds it: "package://PKG/PATH" as DIR/PKG/PATH for
//     each --package-path DIR in order, "file:///ABS" and an absolute path as
//     they are, anything else relative to the URDF's folder;
//   - its canonical path (every symlink and ".." resolved) lies under the
//     URDF's folder or under a --package-path DIR (canonical too): a symlink
//     that leads out of them is refused, wherever it points;
//   - it is a regular file of at most kMaxMeshBytes whose bytes are what its
//     extension says (CheckMeshBytes): .stl a binary STL (an 80-byte header
//     and a triangle count that accounts for the file's size exactly) or an
//     ASCII one (starting "solid"), .dae Collada (XML whose root element is
//     <COLLADA>).
// At each request it is opened again without following a symlink, must be
// the very file checked (device and inode) and is checked again, so a path
// changed since cannot lead the server elsewhere.

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace lagrange::cli::view {

inline constexpr std::uintmax_t kMaxMeshBytes = 64u << 20;

enum class MeshFormat { kStl, kCollada };

// A mesh file as checked when the view started.
struct MeshFile {
  std::string path;  // canonical
  MeshFormat format = MeshFormat::kStl;
  dev_t device = 0;
  ino_t inode = 0;
};

// "" when `head` (a file's first bytes, at most all of them) and its `size` are a `format` file; else why
// not ("is not an STL file (...)").
std::string CheckMeshBytes(std::string_view head, std::uintmax_t size, MeshFormat format);

// Where a URDF's meshes may come from: its folder and the --package-path directories.
class MeshRoots {
 public:
  MeshRoots(const std::string& urdf_file, const std::vector<std::string>& package_path);
  // The file a <mesh filename> names, checked; or why it is not served (one line, names escaped, to follow
  // "mesh 'NAME' ").
  std::variant<MeshFile, std::string> Find(const std::string& filename) const;

 private:
  std::vector<std::filesystem::path> Candidates(const std::string& filename, std::string& why) const;
  bool Confined(const std::filesystem::path& canonical) const;

  std::filesystem::path urdf_dir_;
  std::vector<std::string> package_path_;
  std::vector<std::filesystem::path> roots_;  // canonical: the URDF's folder, then each --package-path
};

// The bytes of `mesh` when it is still the file that was checked and still passes the checks; nullopt otherwise.
std::optional<std::string> ReadMesh(const MeshFile& mesh);

}  // namespace lagrange::cli::view
