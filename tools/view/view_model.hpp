#pragma once
// What lagrangectl view draws of one plant instance: its geometry, sent to
// the page once, and its frames' poses for a q, computed by the plant's own
// kinematics (plant/kinematics.hpp, from the same tree the daemon runs:
// MakeRigidTree of the scene's plant spec), sent per frame. The page places
// its objects at exactly these poses; it computes none.
//
// Geometry (JSON, "shapes"), each on a frame of the tree (index into
// "frames"; −1 the world):
//   built-in plants   from their parameters: the arm's and the chain's rods
//                     from joint to joint and to the tip, the pendulum's rod and
//                     bob, the cart (a box) on its rail and its pole
//   URDF robots       each link's <visual> (box, cylinder, sphere, STL or
//                     Collada mesh), as plant/urdf.hpp read them (UrdfLooks),
//                     meshes found and checked by tools/view/meshes.hpp; a
//                     robot without any is drawn as rods from each link frame
//                     to its children's. A visual that did not read and a mesh
//                     that is missing or refused are named ("missing"), and
//                     the link's frame drawn
// Planar plants live in the xy plane with gravity −y ("planar": the page turns
// them so that −y points down); a URDF robot's world is z up.
//
// A floating base (a scene's floating_base: true; "floating_base" in the
// geometry): the spec is the robot with its base bolted at the world origin
// (sim/scene.hpp's FixedBaseOf: the joints' model, as the instance's), whose
// kinematics place every frame in the base's frame; Poses with the base's
// pose (from <NAME>_BASE) puts them in the world: R_b R_k, R_b p_k + p_b, the
// placement FloatingDynamics makes at the full q (p, quaternion, joints).
//
// A pose is 12 numbers: R row by row (the frame's axes in world coordinates),
// then p (m), as KinematicsData::rotation and position give them.

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plant/kinematics.hpp"
#include "plant/plant_factory.hpp"
#include "tools/view/meshes.hpp"

namespace lagrange::cli::view {

struct ViewModelOptions {
  std::vector<std::string> package_path;  // for a URDF's package:// meshes
  VectorXd torque_limits;                 // (n) the scene's; empty: none
  bool floating_base = false;             // the spec is a floating base's joints (above)
};

// A floating base's pose in the world: its axes R (3 x 3) and origin p (m).
struct BasePose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
};

class ViewModel {
 public:
  // Throws std::invalid_argument for an invalid spec (a urdf spec without a robot).
  ViewModel(std::string name, const PlantSpec& spec, const ViewModelOptions& options);

  const std::string& name() const { return name_; }
  int num_dofs() const { return kinematics_->num_dofs(); }
  const Kinematics& kinematics() const { return *kinematics_; }
  bool floating_base() const { return floating_base_; }
  // {name, plant, planar, floating_base, dofs, joints [{name, lower, upper}], frames, shapes, missing, tau_limits,
  // meshes}.
  const nlohmann::json& geometry() const { return geometry_; }
  // The files a URDF's meshes resolved to (checked: meshes.hpp), served at /mesh/<model>/<k>.
  const std::vector<MeshFile>& mesh_files() const { return mesh_files_; }
  // q (num_dofs) => every frame's pose [R00 .. R22, px, py, pz], in the tree's frame order; with `base`, a
  // floating base's frames in the world (above), else in the tree's world (a floating base's own frame).
  // Thread-safe: one evaluation at a time (the model keeps one KinematicsData).
  nlohmann::json Poses(ConstVecRef q, const BasePose& base = {}) const;

 private:
  void BuiltInShapes(const PlantSpec& spec);
  void UrdfShapes(const UrdfRobot& robot, const std::vector<std::string>& package_path);
  void UrdfMesh(const UrdfVisual& v, const MeshRoots& roots, nlohmann::json& shape);
  void UrdfSkeleton(const UrdfLooks& looks);
  int Frame(const std::string& name) const;

  std::string name_;
  bool floating_base_ = false;
  std::unique_ptr<Kinematics> kinematics_;
  std::unique_ptr<KinematicsData> data_;
  mutable std::mutex data_mutex_;  // data_: one evaluation at a time
  nlohmann::json geometry_;
  std::vector<MeshFile> mesh_files_;
};

}  // namespace lagrange::cli::view
