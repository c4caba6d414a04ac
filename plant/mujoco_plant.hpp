#pragma once
// A MuJoCo model as a lagrange plant (plant/stepped_plant.hpp): library
// lagrange_mujoco, built when CMake finds Debian's libmujoco-dev (2.2.2).
//
// Loading. mj_loadXML reads MJCF, or a URDF as MuJoCo imports it (fusestatic,
// discardvisual, strippath forced; joints limited where lower < upper;
// damping and friction loss from <dynamics>; armature 0; geoms from
// <collision> only; no actuators). Then, before the model is shared:
//   - its degrees of freedom are its joints, which must all be hinge or slide
//     (free and ball joints are refused: lagrange's messages are joint-space),
//     so q = qpos, qd = qvel in the model's joint order, or in `joint_order`
//     (lagrange's model's order, the same joints by name: a branching URDF
//     may be ordered differently by MuJoCo's importer and by lagrange's);
//   - timestep = period / substeps, the integrator as asked, energy on;
//     actuators off (mjDSBL_ACTUATION: lagrange's controller applies the
//     joint force, qfrc_applied);
//   - given `exact_inertia` (the file is a URDF lagrange read too), MuJoCo
//     reads it with two edits: every <collision> whose geometry is a <mesh> is
//     dropped (MuJoCo 2.2.2 cannot resolve package:// meshes, and lagrange
//     reads no geometry: a URDF robot's contacts are the primitive shapes
//     only), and <mujoco><compiler boundmass boundinertia/> is added, so that
//     MuJoCo's compiler takes the massless or point-mass links lagrange takes
//     (their exact values replace the bounds below);
//   - given `exact_inertia` (lagrange's tree of the same URDF), every moving
//     body's mass, centre of mass and inertia are replaced by the tree's, the
//     inertia diagonalised by Eigen's self-adjoint eigensolver (to round-off)
//     instead of MuJoCo's mju_eig3, which stops early (stored tensors off by
//     up to 6.5e-7 relative on the Panda); then mj_setConst. MuJoCo's M, bias
//     forces, T, V and dynamics then agree with lagrange's to round-off
//     (tests/plant/mujoco_plant_test.cpp).
//
// Stepping (MujocoPlantData::Step): qfrc_applied = tau, `substeps` MuJoCo
// steps, then mj_forward at the end state (q̈, energies). A warning MuJoCo
// raises in the tick (mjWARN_BADQACC: a diverging simulation, which MuJoCo
// answers by resetting its data; a full contact or constraint buffer; a
// singular inertia) fails the step with its reason. MuJoCo's printed warning
// text is discarded (mju_user_warning, set once per process): the tick does no
// I/O, and the counters in mjData say everything.
//
// Errors. A file MuJoCo refuses, or a refused joint, throws
// std::invalid_argument with one line: "FILE: MuJoCo: <its message>" or
// "FILE: joint 'j' is a ball joint: expected hinge or slide joints only ...".

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>

#include "plant/rigid_tree.hpp"
#include "plant/stepped_plant.hpp"

struct mjModel_;  // MuJoCo's (mujoco/mjmodel.h): only lagrange_mujoco includes MuJoCo's headers

namespace lagrange {

struct MujocoOptions {
  double period = 1e-3;  // s, one Step
  int substeps = 1;      // MuJoCo steps per Step: timestep = period / substeps
  MujocoIntegrator integrator = MujocoIntegrator::kRk4;
  // The lagrange tree of the same URDF: its bodies' inertias replace MuJoCo's
  // (matched by the joint that carries each body, by name). Null: MuJoCo's own.
  const RigidTree* exact_inertia = nullptr;
  // q's order by joint name (lagrange's model's: JointNamesOf); empty:
  // MuJoCo's own joint order. Must name MuJoCo's joints, each once.
  std::vector<std::string> joint_order;
  // m/s², world frame; unset: the file's (MuJoCo's default (0, 0, −9.81)).
  std::optional<Eigen::Vector3d> gravity;
};

// The loaded model's facts, for tests and the README.
struct MujocoModelInfo {
  double timestep = 0.0;  // s
  int num_geoms = 0;
  int num_actuators = 0;  // in the file; not used
  std::vector<bool> limited;             // per degree of freedom, in q order: MuJoCo enforces its range
  std::vector<double> lower, upper;      // its range, rad or m; ∓inf where not limited
};

class MujocoPlantModel final : public SteppedPlantModel, public std::enable_shared_from_this<MujocoPlantModel> {
 public:
  ~MujocoPlantModel() override;
  int num_dofs() const override { return num_dofs_; }
  const std::vector<std::string>& joint_names() const override { return joint_names_; }
  // Data that keeps this model alive (it must be held by a shared_ptr: LoadMujocoPlant's is).
  std::unique_ptr<SteppedPlantData> MakeData() const override;
  const MujocoModelInfo& info() const { return info_; }
  const std::string& file() const { return file_; }
  const ::mjModel_* mj_model() const { return model_; }  // MuJoCo's own model, read-only

 private:
  friend std::shared_ptr<const MujocoPlantModel> LoadMujocoPlant(const std::string&, const MujocoOptions&);
  MujocoPlantModel() = default;
  ::mjModel_* model_ = nullptr;
  std::string file_;
  int num_dofs_ = 0;
  int substeps_ = 1;
  MujocoIntegrator integrator_ = MujocoIntegrator::kRk4;
  std::vector<std::string> joint_names_;
  std::vector<int> dof_;  // (n) MuJoCo's qpos / qvel index of q[i]
  MujocoModelInfo info_;
  friend class MujocoPlantData;
};

// Loads `file` as above. Throws std::invalid_argument (one line, naming the file).
std::shared_ptr<const MujocoPlantModel> LoadMujocoPlant(const std::string& file, const MujocoOptions& options);

// The total contact force on geom `geom` (by name) at `data`'s current state
// (after a Step or SetState), N, world frame: Σ over MuJoCo's active contacts
// that involve it of the force the other geom exerts on it (mj_contactForce,
// normal and friction). Zero when it touches nothing; nullopt when `data` is
// not a MuJoCo plant's or the model has no such geom.
std::optional<Eigen::Vector3d> MujocoContactForce(const SteppedPlantData& data, const std::string& geom);

// The version of the MuJoCo library linked, e.g. "2.2.2".
std::string MujocoVersion();

}  // namespace lagrange
