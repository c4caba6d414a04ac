#pragma once
// What a URDF says about how its links look, for lagrangectl view: each
// link's <visual> elements (box, cylinder, sphere, mesh), their <origin> and
// colour, and which link hangs from which (to draw a robot that gives no
// <visual> as a skeleton of its link frames). plant/urdf.hpp reads the
// kinematics and ignores all of this; the file has passed LoadUrdf's checks
// (size, depth, well-formed XML) before it comes here.
//
// Meshes are resolved to files as ROS does: "package://PKG/PATH" as
// DIR/PKG/PATH for each DIR of the search path in order, "file:///ABS" and
// an absolute path as they are, anything else relative to the URDF's
// directory. STL (binary or ASCII) and Collada (.dae) are drawn; a mesh that
// cannot be found, or in another format, is reported (`missing`) and the
// link is drawn as its frame.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace lagrange::cli {

struct UrdfVisual {
  enum class Kind { kBox, kCylinder, kSphere, kMesh };
  std::string link;
  Kind kind = Kind::kBox;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // <origin rpy> in the link frame
  Eigen::Vector3d p = Eigen::Vector3d::Zero();      // <origin xyz> in the link frame, m
  Eigen::Vector3d size = Eigen::Vector3d::Zero();   // box: x y z, m; cylinder: radius, length; sphere: radius
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // mesh <scale>
  std::string mesh_file;                            // mesh: the resolved file (exists)
  std::string mesh_format;                          // mesh: "stl" | "dae"
  std::array<double, 4> rgba{0.7, 0.7, 0.75, 1.0};  // <material><color rgba> (inline or named at the robot)
};

struct UrdfLooks {
  std::vector<UrdfVisual> visuals;
  std::vector<std::array<std::string, 2>> links;  // (parent link, child link) of every joint, the file's order
  std::vector<std::string> missing;  // one line each: "link 'l3' <visual> mesh 'package://x/y.stl': not found (...)"
};

// Reads the <visual> elements of the URDF at `path` (already read by
// LoadUrdf). A malformed visual (numbers that do not parse, no geometry) is
// reported in `missing`, never thrown; only an unreadable file throws
// std::runtime_error.
UrdfLooks ReadUrdfLooks(const std::string& path, const std::vector<std::string>& package_path);

}  // namespace lagrange::cli
