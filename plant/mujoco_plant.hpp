#pragma once
// A MuJoCo model as a lagrange plant (plant/stepped_plant.hpp): library
// lagrange_mujoco, built when CMake finds Debian's libmujoco-dev (2.2.2).
//
// Loading. mj_loadXML reads MJCF, or a URDF as MuJoCo imports it (fusestatic,
// discardvisual, strippath forced; joints limited where lower < upper;
// damping and friction loss from <dynamics>; armature 0; geoms from
// <collision> only; no actuators). Then, before the model is shared:
//   - its joints must be hinge, slide or free (ball joints are refused);
//     its degrees of freedom are its hinge and slide joints but the mimics
//     of lagrange's model (`mimics`), so q = qpos, qd = qvel of those joints
//     in the model's joint order, or in `joint_order` (lagrange's model's
//     order, the same joints by name: a branching URDF may be ordered
//     differently by MuJoCo's importer and by lagrange's); MuJoCo's hinge
//     and slide joints must be exactly those and the mimics;
//   - a free joint is either lagrange's floating base (`floating_base`: the
//     model's first free joint) or a free body
//     lagrange does not model (every other free joint: a loose box), which
//     MuJoCo alone moves: no entry of q, its state MuJoCo's (MujocoFreeBody
//     reads it). With a floating base, q = (p, x, y, z, w, joints) (nq =
//     num_positions()) and qd = v = (v_b, ω_b, joint rates) (nv =
//     num_dofs()), lagrange's conventions (plant/rigid_tree.hpp), converted
//     from and to MuJoCo's by plant/mujoco_free_joint.hpp; qdd, tau and every
//     row of ComputeForces are nv, the base's a wrench in base axes (tau's
//     is turned into MuJoCo's world-frame force at the tick's start and held
//     over its substeps); no mimics yet;
//   - a mimic joint (q_mimic = multiplier · q_leader + offset) is coupled by
//     MuJoCo's joint equality constraint, <equality><joint joint1="MIMIC"
//     joint2="LEADER" polycoef="a0 multiplier 0 0 0"/>, a0 = offset when
//     both joints' reference positions (qpos0) are 0. An MJCF must hold it
//     (else it is refused, naming the element to add); a URDF cannot say it
//     (MuJoCo 2.2.2's importer ignores <mimic>), so lagrange adds it: MuJoCo
//     imports the URDF, writes it back as MJCF (mj_saveLastXML, at 17
//     digits), the equality is appended, and MuJoCo loads that. The added
//     constraint is as stiff as MuJoCo allows at the step h: solref (2 h, 1),
//     solimp (0.9999, 0.9999, 0.001) (kMimicTimeConstantSteps,
//     kMimicImpedance). MuJoCo's equality is
//     soft, so the mimic follows its leader to the constraint's violation,
//     not exactly (README, "MuJoCo plants": the figures). A URDF mimic's own
//     <dynamics> and <limit> are cleared in MuJoCo (damping, friction loss,
//     range), as lagrange reads them: unused, its leader's apply (an MJCF's
//     are its own, MuJoCo's world). A mimic's q, qd are
//     never in q: SetState places it on its leader; Step applies no force
//     to it (tau acts on the leader; the constraint carries its share);
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
// Errors. A file MuJoCo refuses, a refused joint, joints that are not
// lagrange's model's, a mimic the MJCF does not couple, throw
// std::invalid_argument with one line: "FILE: MuJoCo: <its message>",
// "FILE: joint 'j' is a ball joint: expected hinge, slide or free joints only ...".

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>

#include "plant/rigid_tree.hpp"
#include "plant/stepped_plant.hpp"

struct mjModel_;  // MuJoCo's (mujoco/mjmodel.h): only lagrange_mujoco includes MuJoCo's headers

namespace lagrange {

// A mimic joint of lagrange's model: q_joint = multiplier · q_leader + offset.
struct MujocoMimic {
  std::string joint, leader;
  double multiplier = 1.0;
  double offset = 0.0;  // rad or m
};
std::vector<MujocoMimic> MimicsOf(const RigidTree& tree);

struct MujocoOptions {
  double period = 1e-3;  // s, one Step
  int substeps = 1;      // MuJoCo steps per Step: timestep = period / substeps
  MujocoIntegrator integrator = MujocoIntegrator::kRk4;
  // The lagrange tree of the same URDF: its bodies' inertias replace MuJoCo's
  // (matched by the joint that carries each body, by name). Null: MuJoCo's own.
  const RigidTree* exact_inertia = nullptr;
  // q's order by joint name (lagrange's model's: JointNamesOf); empty:
  // MuJoCo's own joint order, mimics skipped. With the mimics, must name
  // MuJoCo's joints, each once.
  std::vector<std::string> joint_order;
  // m/s², world frame; unset: the file's (MuJoCo's default (0, 0, −9.81)).
  std::optional<Eigen::Vector3d> gravity;
  // Lagrange's model's mimic joints (MimicsOf its tree): no degrees of
  // freedom; each must be MuJoCo's joint, coupled to its leader as above.
  std::vector<MujocoMimic> mimics;
  // The model's first free joint is lagrange's floating base (above): q nq, qd nv.
  bool floating_base = false;
};

// The equality lagrange adds to a URDF with mimics: the stiffest MuJoCo
// allows, its time constant twice the step (MuJoCo's own floor unless
// mjDSBL_REFSAFE), critically damped; impedance 0.9999 at every violation.
inline constexpr double kMimicTimeConstantSteps = 2.0;
inline constexpr double kMimicImpedance = 0.9999;

// The loaded model's facts, for tests and the README.
struct MujocoModelInfo {
  double timestep = 0.0;  // s
  int num_geoms = 0;
  int num_actuators = 0;  // in the file; not used
  // per degree of freedom, in qd order (a floating base's six first, never limited): MuJoCo enforces its range
  std::vector<bool> limited;
  std::vector<double> lower, upper;      // its range, rad or m; ∓inf where not limited
};

class MujocoPlantModel final : public SteppedPlantModel, public std::enable_shared_from_this<MujocoPlantModel> {
 public:
  ~MujocoPlantModel() override;
  int num_dofs() const override { return num_dofs_; }  // nv: qd's size (q's too but with a floating base)
  int num_positions() const { return num_positions_; }  // nq: q's size, num_dofs() + 1 with a floating base
  bool floating_base() const { return base_qpos_ >= 0; }
  // The joints of q in order (a floating base's not among them).
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
  int num_dofs_ = 0, num_positions_ = 0;
  int substeps_ = 1;
  MujocoIntegrator integrator_ = MujocoIntegrator::kRk4;
  std::vector<std::string> joint_names_;
  int base_qpos_ = -1, base_qvel_ = -1;  // MuJoCo's qpos / qvel index of the floating base's free joint; −1: none
  int q0_ = 0, v0_ = 0;                  // where the joints start in q and in qd: 7 and 6 with a floating base
  std::vector<int> qpos_, qvel_;         // (joints) MuJoCo's qpos / qvel index of each joint of q
  struct Mimic {
    int qpos = 0, qvel = 0;  // MuJoCo's qpos / qvel index of the mimic
    int leader = 0;  // the index into q of the joint it follows
    double multiplier = 1.0, offset = 0.0;
  };
  std::vector<Mimic> mimics_;
  // Which terms of the equation of motion the model has (forces_t's flags), resolved at load.
  struct Terms {
    bool gravity = false;        // gravity on and not zero
    bool passive = false;        // damping, springs, fluid forces (qfrc_passive)
    bool friction_loss = false;  // dof or tendon friction loss
    bool limits = false;         // limited joints or tendons
    bool constraint = false;     // geoms that may touch, or equality constraints
  };
  Terms terms_;
  static Terms TermsOf(const ::mjModel_* m);
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

// A free body's state, MuJoCo's free joint `joint` (by name) at `data`'s
// current state, in lagrange's conventions (plant/mujoco_free_joint.hpp):
// q = (p, x, y, z, w), v = (v_b, ω_b) in body axes; nullopt when `data` is
// not a MuJoCo plant's or the model has no such free joint.
struct MujocoFreeBody {
  Eigen::Matrix<double, 7, 1> q;
  Eigen::Matrix<double, 6, 1> v;
};
std::optional<MujocoFreeBody> MujocoFreeJointState(const SteppedPlantData& data, const std::string& joint);

// MuJoCo's position of joint `joint` (by name, any joint, mimics too) at
// `data`'s current state, rad or m; nullopt when `data` is not a MuJoCo
// plant's or the model has no such joint. A mimic's is how far MuJoCo's soft
// equality lets it stray from multiplier · q_leader + offset.
std::optional<double> MujocoJointPosition(const SteppedPlantData& data, const std::string& joint);

// The version of the MuJoCo library linked, e.g. "2.2.2".
std::string MujocoVersion();

}  // namespace lagrange
