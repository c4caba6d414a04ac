#include "plant/mujoco_plant.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace lagrange {
namespace {

// MuJoCo prints a warning's text (and appends it to MUJOCO_LOG.TXT) the first
// time mjData sees it; the tick does no I/O, and Step reads the counters.
void DiscardWarning(const char* /*message*/) {}

void InstallHandlers() {
  static std::once_flag once;
  std::call_once(once, [] { mju_user_warning = &DiscardWarning; });
}

// MuJoCo's messages run over several lines ("Error: ...\nElement 'x', line 3"): one line.
std::string OneLine(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  std::string out;
  for (char c : text) {
    if (c == '\n') {
      out += !out.empty() && out.back() == ':' ? " " : "; ";
    } else if (c == '\r' || c == '\t') {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out;
}

[[noreturn]] void Refuse(const std::string& file, const std::string& why) {
  throw std::invalid_argument(file + ": " + why);
}

std::string JointName(const mjModel* m, int j) {
  const char* name = mj_id2name(m, mjOBJ_JOINT, j);
  return name != nullptr ? std::string(name) : "#" + std::to_string(j);
}

// Body `body`'s mass, centre of mass and inertia from lagrange's `b`, the
// tensor diagonalised to round-off: I = R diag(d) Rᵀ, R a proper rotation
// (MuJoCo's body_iquat), d its principal moments (body_inertia).
void SetBodyInertia(mjModel* m, int body, const RigidBody& b) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(b.inertia);
  Eigen::Matrix3d R = eig.eigenvectors();
  if (R.determinant() < 0.0) R.col(2) = -R.col(2);
  const Eigen::Quaterniond quat(R);
  m->body_mass[body] = b.mass;
  for (int k = 0; k < 3; ++k) {
    m->body_ipos[3 * body + k] = b.com[k];
    m->body_inertia[3 * body + k] = std::max(0.0, eig.eigenvalues()[k]);  // PSD to the file's rounding
  }
  m->body_iquat[4 * body + 0] = quat.w();
  m->body_iquat[4 * body + 1] = quat.x();
  m->body_iquat[4 * body + 2] = quat.y();
  m->body_iquat[4 * body + 3] = quat.z();
}

void SetExactInertias(mjModel* m, const RigidTree& tree, const std::string& file) {
  for (const TreeJoint& joint : tree.joints) {
    const int j = mj_name2id(m, mjOBJ_JOINT, joint.name.c_str());
    if (j < 0) Refuse(file, "joint '" + joint.name + "' of lagrange's model is not MuJoCo's");
  }
  for (std::size_t i = 0; i < tree.joints.size(); ++i) {
    const int j = mj_name2id(m, mjOBJ_JOINT, tree.joints[i].name.c_str());
    SetBodyInertia(m, m->jnt_bodyid[j], tree.bodies[i]);
  }
  mjData* d = mj_makeData(m);
  mj_setConst(m, d);  // the derived constants (subtree masses, dof_M0, ...) from the new inertias
  mj_deleteData(d);
}

// A URDF as lagrange has MuJoCo read it (the reasons in mujoco_plant.hpp):
// every <collision> whose geometry is a <mesh> removed, and a <mujoco>
// compiler element bounding mass and inertia from below inserted as the
// robot's first child. Plain text edits: MuJoCo parses the result.
std::string PrepareUrdf(std::string text) {
  for (std::size_t at = text.find("<collision"); at != std::string::npos; at = text.find("<collision", at)) {
    const std::size_t end = text.find("</collision>", at);
    if (end == std::string::npos) break;
    const std::size_t after = end + std::string("</collision>").size();
    if (text.substr(at, after - at).find("<mesh") != std::string::npos) {
      text.erase(at, after - at);
    } else {
      at = after;
    }
  }
  const std::size_t robot = text.find("<robot");
  const std::size_t open_end = robot == std::string::npos ? robot : text.find('>', robot);
  if (open_end != std::string::npos && text[open_end - 1] != '/') {
    text.insert(open_end + 1, R"(<mujoco><compiler boundmass="1e-9" boundinertia="1e-12"/></mujoco>)");
  }
  return text;
}

// mj_loadXML of `text` under `file`'s name (so that MuJoCo's messages name it), through a virtual file system.
mjModel* LoadXmlText(const std::string& file, const std::string& text, char* error, int error_size) {
  const auto vfs = std::make_unique<mjVFS>();  // 2 MB of names: not on the stack
  mj_defaultVFS(vfs.get());
  const std::string name = file.substr(file.find_last_of('/') + 1);
  if (mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(text.size())) != 0) {
    std::snprintf(error, static_cast<std::size_t>(error_size), "could not hold the file in memory");
    return nullptr;
  }
  const int i = mj_findFileVFS(vfs.get(), name.c_str());
  std::memcpy(vfs->filedata[i], text.data(), text.size());
  mjModel* m = mj_loadXML(file.c_str(), vfs.get(), error, error_size);
  mj_deleteVFS(vfs.get());
  return m;
}

const char* WarningReason(int warning) {
  switch (warning) {
    case mjWARN_INERTIA: return "MuJoCo warned: singular inertia matrix (mjWARN_INERTIA)";
    case mjWARN_CONTACTFULL: return "MuJoCo warned: too many contacts (mjWARN_CONTACTFULL)";
    case mjWARN_CNSTRFULL: return "MuJoCo warned: too many constraints (mjWARN_CNSTRFULL)";
    case mjWARN_VGEOMFULL: return "MuJoCo warned: too many visual geoms (mjWARN_VGEOMFULL)";
    case mjWARN_BADQPOS: return "MuJoCo warned: qpos not finite or too large, the simulation diverged (mjWARN_BADQPOS)";
    case mjWARN_BADQVEL: return "MuJoCo warned: qvel not finite or too large, the simulation diverged (mjWARN_BADQVEL)";
    case mjWARN_BADQACC: return "MuJoCo warned: qacc not finite or too large, the simulation diverged (mjWARN_BADQACC)";
    case mjWARN_BADCTRL: return "MuJoCo warned: bad control (mjWARN_BADCTRL)";
    default: return "MuJoCo warned";
  }
}

}  // namespace

// One user's mjData, made once; Step runs MuJoCo's pipeline in its arena.
class MujocoPlantData final : public SteppedPlantData {
 public:
  explicit MujocoPlantData(std::shared_ptr<const MujocoPlantModel> shared)
      : shared_(std::move(shared)),
        model_(*shared_),
        m_(model_.model_),
        d_(mj_makeData(model_.model_)),
        qpos_start_(model_.num_dofs_),
        qvel_start_(model_.num_dofs_) {
    if (d_ == nullptr) throw std::runtime_error(model_.file_ + ": MuJoCo could not make its data");
    mj_forward(m_, d_);
  }
  ~MujocoPlantData() override { mj_deleteData(d_); }
  MujocoPlantData(const MujocoPlantData&) = delete;
  MujocoPlantData& operator=(const MujocoPlantData&) = delete;

  void SetState(ConstVecRef q, ConstVecRef qd) override {
    for (int i = 0; i < model_.num_dofs_; ++i) {
      const int k = model_.dof_[static_cast<std::size_t>(i)];
      d_->qpos[k] = q[i];
      d_->qvel[k] = qd[i];
      d_->qfrc_applied[k] = 0.0;
    }
    mju_zero(d_->qacc_warmstart, m_->nv);
    for (mjWarningStat& w : d_->warning) w.number = 0;
    mj_forward(m_, d_);
  }

  const char* Step(ConstVecRef tau, VecRef q, VecRef qd, VecRef qdd) override {
    const int n = model_.num_dofs_;
    for (int i = 0; i < n; ++i) d_->qfrc_applied[model_.dof_[static_cast<std::size_t>(i)]] = tau[i];
    for (mjWarningStat& w : d_->warning) w.number = 0;
    const double h = m_->opt.timestep;
    other_work_ = 0.0;
    double power_before = 0.0;
    for (int k = 0; k < model_.substeps_; ++k) {
      for (int i = 0; i < n; ++i) {
        qpos_start_[i] = d_->qpos[i];
        qvel_start_[i] = d_->qvel[i];
      }
      if (model_.integrator_ == MujocoIntegrator::kRk4) {
        // mj_step's own sequence, so the forces of the step's start can be
        // read before mj_RungeKutta's later stages overwrite them.
        mj_checkPos(m_, d_);
        mj_checkVel(m_, d_);
        mj_forward(m_, d_);
        mj_checkAcc(m_, d_);
        const double power = OtherPower();
        mj_RungeKutta(m_, d_, 4);
        if (k > 0) other_work_ += 0.5 * h * (power_before + power);
        power_before = power;
      } else {
        mj_step(m_, d_);  // Euler and implicit evaluate the forces once, at the step's start, and keep them
        const double power = OtherPower();
        if (k > 0) other_work_ += 0.5 * h * (power_before + power);
        power_before = power;
      }
    }
    for (int i = 0; i < n; ++i) {
      qpos_start_[i] = d_->qpos[i];
      qvel_start_[i] = d_->qvel[i];
    }
    mj_forward(m_, d_);  // q̈ and the energies at the end state, under tau
    other_work_ += 0.5 * h * (power_before + OtherPower());
    for (int w = 0; w < mjNWARNING; ++w) {
      if (d_->warning[w].number > 0) return WarningReason(w);
    }
    for (int i = 0; i < n; ++i) {
      const int k = model_.dof_[static_cast<std::size_t>(i)];
      q[i] = d_->qpos[k];
      qd[i] = d_->qvel[k];
      qdd[i] = d_->qacc[k];
    }
    return nullptr;
  }

  double kinetic_energy() const override { return d_->energy[1]; }
  const mjModel* m() const { return m_; }
  const mjData* d() const { return d_; }
  double potential_energy() const override { return d_->energy[0]; }
  double other_work() const override { return other_work_; }

 private:
  // W: qvelᵀ (passive + constraint forces) at (qpos_start_, qvel_start_),
  // with the joint springs taken out (their energy is in V): damping, fluid,
  // friction loss, limits, contacts, equality constraints. The forces are
  // those mj_forward left in the data for that state.
  double OtherPower() const {
    double p = 0.0;
    for (int i = 0; i < model_.num_dofs_; ++i) {
      const double spring = -m_->jnt_stiffness[i] * (qpos_start_[i] - m_->qpos_spring[i]);
      p += qvel_start_[i] * (d_->qfrc_passive[i] - spring + d_->qfrc_constraint[i]);
    }
    return p;
  }

  std::shared_ptr<const MujocoPlantModel> shared_;  // the model outlives its data
  const MujocoPlantModel& model_;
  const mjModel* m_;
  mjData* d_;
  VectorXd qpos_start_, qvel_start_;  // (n) the state a MuJoCo step started from
  double other_work_ = 0.0;
};

MujocoPlantModel::~MujocoPlantModel() { mj_deleteModel(model_); }

std::unique_ptr<SteppedPlantData> MujocoPlantModel::MakeData() const {
  return std::make_unique<MujocoPlantData>(shared_from_this());
}

std::shared_ptr<const MujocoPlantModel> LoadMujocoPlant(const std::string& file, const MujocoOptions& options) {
  InstallHandlers();
  if (!(options.period > 0.0) || options.substeps < 1) Refuse(file, "expected a positive period and substeps >= 1");
  char error[1000] = "";
  mjModel* m = nullptr;
  if (options.exact_inertia != nullptr) {  // a URDF whose inertias lagrange sets
    std::ifstream in(file);
    if (!in) Refuse(file, "MuJoCo: could not open the file");
    std::stringstream text;
    text << in.rdbuf();
    m = LoadXmlText(file, PrepareUrdf(text.str()), error, sizeof error);
  } else {
    m = mj_loadXML(file.c_str(), nullptr, error, sizeof error);
  }
  if (m == nullptr) Refuse(file, "MuJoCo: " + OneLine(error[0] != '\0' ? error : "could not load the model"));
  std::shared_ptr<MujocoPlantModel> model(new MujocoPlantModel);
  model->model_ = m;
  model->file_ = file;
  std::vector<std::string> names;
  for (int j = 0; j < m->njnt; ++j) {
    const int type = m->jnt_type[j];
    if (type == mjJNT_FREE || type == mjJNT_BALL) {
      Refuse(file, "joint '" + JointName(m, j) + "' is a " + (type == mjJNT_FREE ? "free" : "ball") +
                       " joint: expected hinge or slide joints only (lagrange's messages are joint-space)");
    }
    names.push_back(JointName(m, j));
  }
  if (m->njnt == 0) Refuse(file, "expected at least one hinge or slide joint, got none");
  model->joint_names_ = options.joint_order.empty() ? names : options.joint_order;
  std::vector<bool> used(names.size(), false);
  for (const std::string& name : model->joint_names_) {
    const auto it = std::find(names.begin(), names.end(), name);
    const auto j = static_cast<std::size_t>(it - names.begin());
    if (it == names.end() || used[j] || model->joint_names_.size() != names.size()) {
      std::string theirs, ours;
      for (const std::string& n : names) theirs += (theirs.empty() ? "" : ", ") + n;
      for (const std::string& n : model->joint_names_) ours += (ours.empty() ? "" : ", ") + n;
      Refuse(file, "MuJoCo's joints (" + theirs + ") are not those of lagrange's model (" + ours +
                       "): expected the same joints");
    }
    used[j] = true;
    model->dof_.push_back(static_cast<int>(j));  // hinge and slide only: joint j is qpos[j] and qvel[j]
    const bool limited = m->jnt_limited[j] != 0;
    const double inf = std::numeric_limits<double>::infinity();
    model->info_.limited.push_back(limited);
    model->info_.lower.push_back(limited ? m->jnt_range[2 * j] : -inf);
    model->info_.upper.push_back(limited ? m->jnt_range[2 * j + 1] : inf);
  }
  model->num_dofs_ = m->nv;  // hinge and slide joints only: nq = nv = njnt, in joint order
  model->substeps_ = options.substeps;
  model->integrator_ = options.integrator;
  m->opt.timestep = options.period / options.substeps;
  switch (options.integrator) {
    case MujocoIntegrator::kEuler: m->opt.integrator = mjINT_EULER; break;
    case MujocoIntegrator::kRk4: m->opt.integrator = mjINT_RK4; break;
    case MujocoIntegrator::kImplicit: m->opt.integrator = mjINT_IMPLICIT; break;
  }
  m->opt.enableflags |= mjENBL_ENERGY;
  m->opt.disableflags |= mjDSBL_ACTUATION;
  if (options.gravity) {
    for (int k = 0; k < 3; ++k) m->opt.gravity[k] = (*options.gravity)[k];
  }
  if (options.exact_inertia != nullptr) SetExactInertias(m, *options.exact_inertia, file);
  model->info_.timestep = m->opt.timestep;
  model->info_.num_geoms = m->ngeom;
  model->info_.num_actuators = m->nu;
  return model;
}

std::optional<Eigen::Vector3d> MujocoContactForce(const SteppedPlantData& data, const std::string& geom) {
  const auto* mujoco = dynamic_cast<const MujocoPlantData*>(&data);
  if (mujoco == nullptr) return std::nullopt;
  const mjModel* m = mujoco->m();
  const mjData* d = mujoco->d();
  const int id = mj_name2id(m, mjOBJ_GEOM, geom.c_str());
  if (id < 0) return std::nullopt;
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    if (c.geom1 != id && c.geom2 != id) continue;
    mjtNum f[6];
    mj_contactForce(m, d, i, f);  // in the contact frame: normal, then the tangents; on geom2, from geom1
    // frame: its axes (normal, tangent 1, tangent 2) in world coordinates, one per row.
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> frame(c.frame);
    const Eigen::Vector3d on_geom2 = frame.transpose() * Eigen::Vector3d(f[0], f[1], f[2]);
    total += c.geom2 == id ? on_geom2 : Eigen::Vector3d(-on_geom2);
  }
  return total;
}

std::string MujocoVersion() {
  const int v = mj_version();  // 222 for 2.2.2
  return std::to_string(v / 100) + "." + std::to_string(v / 10 % 10) + "." + std::to_string(v % 10);
}

}  // namespace lagrange
