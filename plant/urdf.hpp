#pragma once
// Loading a robot from URDF into a RigidTree (plant/rigid_tree.hpp). The
// text is parsed once, by TinyXML (Debian's libtinyxml), after a bounding scan
// (below), and the robot is read from that DOM. Library lagrange_urdf: it
// reads files, so it lives beside the math-only lagrange_plant, not in it.
//
// Not urdfdom (urdf::parseURDF), which read the file a second time: it parses
// only text, keeps a link's child joints sorted by name, reads an absent
// <limit lower/upper> or <dynamics> attribute as 0, and reports errors only
// through console_bridge's process-wide output handler. The checks it made on
// what we read are made here (see "Checks"); what we do not read is not
// checked: <collision>, <safety_controller>, <calibration>, <transmission>,
// <gazebo>. <visual> and <material> are read for viewers (UrdfLooks below),
// from the same DOM, leniently: the dynamics never use them, so a visual that
// does not read is noted and skipped, never a refusal of the robot.
//
// What is read:
//   joints     revolute, continuous (revolute without position limits),
//              prismatic, fixed; floating from the root link alone (below,
//              "Floating base"); planar joints are refused
//   mimics     <mimic joint multiplier offset> (defaults 1 and 0) on a moving
//              joint: it follows the joint named, q = multiplier · q_joint +
//              offset, and is no degree of freedom (RigidTree: the tree keeps
//              it as a joint with its body; q, the messages, scenes and
//              controllers have only the degrees of freedom). A mimic's own
//              <limit> and <dynamics> are read and checked but not used: its
//              followed joint's apply
//   origins    <origin xyz rpy> of joints and of each link's <inertial>; rpy is
//              URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)
//   axes       <axis xyz> in any direction, normalised (absent: URDF's x; zero refused)
//   inertias   full tensors (ixx ixy ixz iyy iyz izz) given in the <inertial>
//              <origin> frame, turned into link axes, about the centre of mass
//   properties <limit lower upper effort velocity>, <dynamics damping friction>
//
// The tree. Joint order is depth-first from the root link, a link's child
// joints in the order they appear in the file. Moving joints take indices 0..n−1,
// parents first. Body i is joint i's child link, plus every link hanging from
// it through fixed joints (chains of them too), merged by the parallel-axis
// theorem; a moving joint below such a link is re-based onto body i's frame
// (its origin composed with the fixed joints' origins). The base is fixed: the
// root link's inertia, and that of links fixed to it, is ignored, and joints
// below them start at the world (parent −1). Gravity is (0, 0, −9.81) (the
// URDF/ROS convention, z up); set `tree.gravity` to change it.
//
// Floating base (UrdfOptions::floating_base; Pinocchio's buildModel(urdf,
// JointModelFreeFlyer()) makes the same choice): the tree's root is a free body
// (RigidTree::floating_base, q and v in its conventions: nq = n + 7, nv = n + 6).
// The base is the root link, with its <inertial> and those of the links fixed
// to it merged (it must have mass > 0 and a positive definite inertia), and its
// child joints ride on it. Or, when the root link's joint is
// <joint type="floating">, that joint's child is the base and the root link is
// the world: it must be the root link's only joint, at the identity <origin>
// (q places the base in the world), and the root link is then no frame. A
// floating joint anywhere else is refused, and so is one in a file read
// without floating_base (it would make a fixed-base tree that is not the file's
// robot). A floating base's robot may have no moving joint (a free body).
//
// Frames. Every link is a frame of the tree (`tree.frames`, named as the
// link), in the same depth-first order, the root link first: the root link is
// the world frame; a moving joint's child link is its body's frame; a link
// merged by fixed joints keeps its own frame at its fixed placement in the body
// it was merged into (or in the world, below the root), so `panda_link8`,
// `panda_hand` and `tool0` survive the merge.
//
// Properties are what the file says: an attribute it does not give is
// nullopt, not 0 (a revolute joint whose <limit> gives only effort and
// velocity has no position limits). A continuous joint has no lower/upper even
// if its <limit> gives them. URDF requires effort and velocity in every
// <limit> (checked), so they are present exactly when <limit> is. Refused:
// effort, velocity, damping or friction < 0, lower > upper.
//
// Numbers are decimal (C locale, each read as the nearest double; a leading
// '+' allowed), a list of them separated by any white space.
//
// Checks, each a one-line UrdfError "FILE: ELEMENT: reason" (the caller picks
// the exit code), in this order:
//   the file      unreadable or not a regular file (a FIFO or device would block
//                 or never end), over 2 MiB, a NUL byte, not UTF-8, U+FEFF/U+FFFE/
//                 U+FFFF after the start; elements nested over 64 deep as tinyxml
//                 tokenises them (it would overflow the stack) or more than 65536
//                 elements; malformed XML (line, column); more than 4096 links or
//                 4096 joints
//   the XML       no <robot> or no name; a version other than 1.0 ("major.minor",
//                 decimal digits); an element without a name; a joint type that
//                 is not revolute/continuous/prismatic/fixed/floating; any number
//                 we read that is not finite (nan, inf, overflow) or not as many
//                 as expected; an <inertial> without <mass value> or <inertia>
//                 with all of ixx ixy ixz iyy iyz izz; a moving joint's <axis>
//                 without xyz; a revolute or prismatic joint without <limit>; a
//                 <limit> (on any joint) without effort or velocity; a <dynamics>
//                 with neither damping nor friction; a <mimic> on a fixed joint,
//                 twice in a joint or without a joint attribute; a link or joint defined
//                 twice; a joint naming an undefined link or the same link as
//                 parent and child; a link with two parents; no root, several
//                 roots, links not reachable from the root; a mimic following
//                 itself, a joint the robot does not have, a fixed joint, or
//                 another mimic (chains and cycles)
//   the physics   a negative mass; an inertia refused by CheckRotationalInertia
//                 (plant/rigid_tree.hpp: not positive semi-definite, or principal
//                 moments violating the triangle inequality); no moving joint (fixed base), or more than kMaxDofs; a
//                 joint that moves no inertia at q = 0 (a massless leaf, or a
//                 revolute joint whose subtree lies on its axis: its row of M is
//                 zero); last, ValidateRigidTree or, for a floating base, ValidateFloatingTree (which requires M(0)
//                 positive definite, catching e.g. two joints on one axis line
//                 with nothing between them), its message prefixed by the file.
// For example:
//   "arm.urdf: joint 'j3': a floating joint is read only from the root link (its parent here is link 'l2'): a tree
//   has one floating base, at its root" "arm.urdf: link 'l2' <inertial> <inertia>: inertia is not positive
//   semi-definite (eigenvalue -0.1 kg·m²)" "arm.urdf: link 'tool': massless leaf makes the mass matrix singular (joint
//   'j7' moves nothing)"
// Names and values from the file are quoted escaped as base/escape.hpp does
// (control characters and '\' as \n, \t, \\, \x1b, ...), and so is the file
// name: the message is one line, safe to print as it is; do not escape it again.

#include <array>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "plant/rigid_tree.hpp"

namespace lagrange {

// What a URDF says of one moving joint beyond its kinematics; absent entries
// are nullopt (see "Properties" above). SI units, revolute / prismatic.
struct UrdfJointProperties {
  std::optional<double> lower, upper;  // position limits, rad or m (never for continuous joints)
  std::optional<double> effort;        // |tau| limit, N·m or N
  std::optional<double> velocity;      // |qd| limit, rad/s or m/s
  std::optional<double> damping;       // viscous, N·m·s/rad or N·s/m
  std::optional<double> friction;      // Coulomb, N·m or N
};

// One <visual> of a link: how it looks, never how it moves. Its <origin> is
// read as a joint's (rpy: R = Rz(yaw) Ry(pitch) Rx(roll)), its numbers as
// every number of the file (finite, decimal).
struct UrdfVisual {
  enum class Geometry { kBox, kCylinder, kSphere, kMesh };
  std::string link;    // the link's name, as in the file
  int index = 1;       // its place among the link's <visual> elements, from 1
  Geometry geometry = Geometry::kBox;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // <origin rpy> in the link frame
  Eigen::Vector3d p = Eigen::Vector3d::Zero();      // <origin xyz> in the link frame, m
  Eigen::Vector3d size = Eigen::Vector3d::Zero();   // box: x y z; cylinder: radius, length; sphere: radius (m)
  std::string mesh;                                 // mesh: <mesh filename> as written (a viewer resolves it)
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // mesh: <mesh scale>
  std::array<double, 4> rgba{0.7, 0.7, 0.75, 1.0};  // <material><color rgba>, inline or named at the robot's level
};

// What a URDF says of how its links look: the <visual> elements that read,
// one line for each that did not ("link 'l2' <visual> 1: <box size> is not 3
// finite numbers"; names escaped), and which link hangs from which (a robot
// without any <visual> can be drawn as a skeleton of its link frames).
struct UrdfLooks {
  std::vector<UrdfVisual> visuals;                // file order
  std::vector<std::string> notes;                 // the visuals not read, one line each
  std::vector<std::array<std::string, 2>> links;  // (parent link, child link) of every joint, file order
};

struct UrdfRobot {
  std::string name;                             // <robot name="...">
  std::string file;                             // the path it was read from (ParseUrdf: its `file`)
  RigidTree tree;                               // moving joints in depth-first order, fixed joints merged
  std::vector<UrdfJointProperties> properties;  // one per degree of freedom (moving joints but mimics), q's order
  UrdfLooks looks;                              // <visual>s, for viewers
};

class UrdfError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How a URDF is read: as a fixed-base tree (the default), or with a floating base
// (above; a scene's `floating_base: true`, lagrangectl eval --floating-base).
struct UrdfOptions {
  bool floating_base = false;
};

// The most of a URDF file read (a real robot's is well under 1 MiB); a MuJoCo
// model's XML files are bounded alike (plant/mujoco_files.hpp).
inline constexpr std::size_t kMaxUrdfBytes = 2u << 20;

// Reads and checks a URDF file. Throws UrdfError with the one-line message above.
UrdfRobot LoadUrdf(const std::string& path, const UrdfOptions& options = {});
// The text of a URDF file as LoadUrdf reads it (a regular file, within the
// size bound; UrdfError "FILE: file: reason" otherwise), for a caller that
// keeps it: LoadUrdf(path, o) is ParseUrdf(ReadUrdfFile(path), path, o).
std::string ReadUrdfFile(const std::string& path);
// The same from text; `file` names it in messages.
UrdfRobot ParseUrdf(std::string_view xml, const std::string& file, const UrdfOptions& options = {});

}  // namespace lagrange
