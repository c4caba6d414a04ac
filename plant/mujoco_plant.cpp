#include "plant/mujoco_plant.hpp"

#include <mujoco/mujoco.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "plant/mujoco_files.hpp"
#include "plant/mujoco_free_joint.hpp"
#include "base/number_text.hpp"

// MuJoCo's own precision switch for the MJCF it writes (xml_numeric_format.h,
// exported by 2.2.2 but not in its public headers; MuJoCo's tests raise it to
// 17 digits the same way). At its default, 6 digits, a URDF written back as
// MJCF moves its joints by up to 5e-7 m and rad.
extern "C" {
int _mjPRIVATE__get_xml_precision();
void _mjPRIVATE__set_xml_precision(int precision);
}

namespace lagrange {
namespace {

// MuJoCo prints a warning's text (and appends it to MUJOCO_LOG.TXT) the first
// time mjData sees it; the tick does no I/O, and Step reads the counters.
void DiscardWarning(const char* /*message*/) {}

// A MuJoCo error (mju_error: "Stack overflow" when a step's contacts outgrow
// the file's nstack, "Could not allocate mjData stack", ...) is fatal by
// default: MuJoCo prints "Press Enter to exit ...", waits on stdin and calls
// exit(1), so one scene file could end or hang lagranged. Thrown instead
// (MuJoCo's Python bindings do the same): MujocoPlantData::Step catches it and
// faults the instance with MuJoCo's message; elsewhere it is a load error.
// MuJoCo 2.2.2's C frames unwind (x86-64 builds carry unwind tables); the
// mjData's arena mark is left raised, and Step resets it after the catch.
class MujocoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void ThrowError(const char* message) { throw MujocoError(std::string("MuJoCo: ") + message); }

void InstallHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_warning = &DiscardWarning;
    mju_user_error = &ThrowError;
  });
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
  if (name != nullptr) return name;
  std::string number = "#";  // appended, not "#" + ...: g++ 12 at -O3 warns (-Wrestrict) on that concatenation, wrongly
  number += std::to_string(j);
  return number;
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
  // MuJoCo's compiler marked what coincided with the file's inertial frame
  // (body_sameframe: it is the body frame, so kinematics skips ipos and iquat;
  // geom and site sameframe 2: placed at it) and bodies whose mass matrix is
  // diagonal (body_simple, dof_simplenum). The new frame need not keep any
  // of it (a finger whose inertia sits at its origin had its iquat ignored),
  // and each is a shortcut only: cleared. Geoms and sites are then placed by
  // their own pos and quat, which are relative to the body frame.
  m->body_sameframe[body] = 0;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] == body && m->geom_sameframe[g] == 2) m->geom_sameframe[g] = 0;
  }
  for (int k = 0; k < m->nsite; ++k) {
    if (m->site_bodyid[k] == body && m->site_sameframe[k] == 2) m->site_sameframe[k] = 0;
  }
  if (m->body_simple[body] != 0) {
    m->body_simple[body] = 0;
    for (int i = 0; i < m->nv; ++i) m->dof_simplenum[i] = 0;
  }
}

// `base_joint`: MuJoCo's free joint of a floating tree's base (−1: none); its body takes tree.base's.
void SetExactInertias(mjModel* m, const RigidTree& tree, int base_joint, const std::string& file) {
  if (tree.floating_base != (base_joint >= 0)) {
    Refuse(file, std::string("lagrange's model ") + (tree.floating_base ? "has" : "has no") +
                     " floating base and the MuJoCo plant " + (base_joint >= 0 ? "has one" : "none"));
  }
  if (base_joint >= 0) SetBodyInertia(m, m->jnt_bodyid[base_joint], tree.base);
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

// MuJoCo keeps the last XML it loaded process-wide (for mj_saveLastXML):
// every load of ours holds this, and CoupleMimics across its load and save.
std::recursive_mutex& LastXmlMutex() {
  static std::recursive_mutex mutex;
  return mutex;
}

// mj_loadXML of `files` (files[0] the model, under `file`'s name, so that MuJoCo's messages name it) from
// memory: MuJoCo reads no file itself (plant/mujoco_files.hpp).
mjModel* LoadFiles(const std::string& file, const std::vector<MujocoFile>& files, char* error, int error_size) {
  const MujocoVfs vfs = MakeMujocoVfs(file, files);
  const std::lock_guard<std::recursive_mutex> lock(LastXmlMutex());
  return mj_loadXML(file.c_str(), vfs.get(), error, error_size);
}

// Whether the XML's root element is a URDF's <robot> (MuJoCo's own test:
// the root's name), skipping the declaration and comments before it.
bool IsUrdfText(const std::string& text) {
  std::size_t at = 0;
  while ((at = text.find('<', at)) != std::string::npos) {
    if (text.compare(at, 4, "<!--") == 0) {
      at = text.find("-->", at);
    } else if (text.compare(at, 2, "<?") == 0 || text.compare(at, 2, "<!") == 0) {
      at = text.find('>', at);
    } else {
      return text.compare(at, 6, "<robot") == 0 && (at + 6 == text.size() || !std::isalnum(text[at + 6]));
    }
    if (at == std::string::npos) return false;
  }
  return false;
}

// MuJoCo's joint equality of a mimic: joint1 = the mimic (y), joint2 = its
// leader (x), y − y0 = a0 + a1 (x − x0) + ... with y0, x0 their qpos0, so
// that y = multiplier x + offset: a0 = multiplier x0 + offset − y0, a1 = multiplier.
struct Coupling {
  int mimic = -1, leader = -1;  // MuJoCo's joint ids
  double a0 = 0.0, a1 = 1.0;
};

Coupling CouplingOf(const mjModel* m, const MujocoMimic& mimic) {
  Coupling c;
  c.mimic = mj_name2id(m, mjOBJ_JOINT, mimic.joint.c_str());
  c.leader = mj_name2id(m, mjOBJ_JOINT, mimic.leader.c_str());
  const double y0 = m->qpos0[m->jnt_qposadr[c.mimic]], x0 = m->qpos0[m->jnt_qposadr[c.leader]];
  c.a0 = mimic.multiplier * x0 + mimic.offset - y0;
  c.a1 = mimic.multiplier;
  return c;
}

// <equality><joint joint1="MIMIC" joint2="LEADER" polycoef="a0 a1 0 0 0" ATTRIBUTES/></equality>
std::string EqualityElement(const MujocoMimic& mimic, const Coupling& c, const std::string& attributes = "") {
  return "<equality><joint joint1=\"" + mimic.joint + "\" joint2=\"" + mimic.leader + "\" polycoef=\"" +
         FormatDouble(c.a0) + " " + FormatDouble(c.a1) + " 0 0 0\"" + attributes + "/></equality>";
}

// The equality coupling `mimic` in `m`, or why there is none as expected.
std::optional<std::string> CheckCoupled(const mjModel* m, const MujocoMimic& mimic) {
  const Coupling c = CouplingOf(m, mimic);
  const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 * (1.0 + std::abs(b)); };
  std::string found;
  for (int e = 0; e < m->neq; ++e) {
    if (m->eq_type[e] != mjEQ_JOINT || m->eq_obj1id[e] != c.mimic || m->eq_obj2id[e] != c.leader) continue;
    const double* a = m->eq_data + static_cast<std::ptrdiff_t>(e) * mjNEQDATA;
    if (m->eq_active[e] != 0 && near(a[0], c.a0) && near(a[1], c.a1) && a[2] == 0.0 && a[3] == 0.0 && a[4] == 0.0) {
      return std::nullopt;
    }
    found = std::string(m->eq_active[e] != 0 ? "" : "an inactive one, ") + "polycoef " + FormatDouble(a[0]) + " " +
            FormatDouble(a[1]) + " " + FormatDouble(a[2]) + " " + FormatDouble(a[3]) + " " + FormatDouble(a[4]);
  }
  return "joint '" + mimic.joint + "' mimics '" + mimic.leader +
         "' in lagrange's model (q = " + FormatDouble(mimic.multiplier) + " q_leader + " + FormatDouble(mimic.offset) +
         "): expected " + EqualityElement(mimic, c) + " in the MJCF, got " + (found.empty() ? "none" : found);
}

// A URDF's model with every mimic coupled: MuJoCo loads the URDF's text (as
// LoadMujocoPlant prepared it) and writes it back as MJCF (mj_saveLastXML:
// MuJoCo's only URDF-to-MJCF path in 2.2.2, at 17 digits); the equalities, as
// stiff as MuJoCo allows at `timestep`, go before its end, and MuJoCo loads
// that. Null (and MuJoCo's message in `error`) if MuJoCo refuses either.
mjModel* CoupleMimics(const std::string& file, std::vector<MujocoFile> files, const std::vector<MujocoMimic>& mimics,
                      double timestep, char* error, int error_size) {
  std::string path = (std::filesystem::temp_directory_path() / "lagrange_mujoco_XXXXXX").string();
  const int fd = mkstemp(path.data());
  if (fd < 0) Refuse(file, "could not make a temporary file for MuJoCo's MJCF of it");
  ::close(fd);
  std::string equalities;
  int saved = 0;
  {
    const std::lock_guard<std::recursive_mutex> lock(LastXmlMutex());  // no other load between the two calls
    mjModel* m = LoadFiles(file, files, error, error_size);
    if (m == nullptr) {
      std::remove(path.c_str());
      return nullptr;
    }
    const std::string attributes = " solref=\"" + FormatDouble(kMimicTimeConstantSteps * timestep) + " 1\" solimp=\"" +
                                   FormatDouble(kMimicImpedance) + " " + FormatDouble(kMimicImpedance) +
                                   " 0.001 0.5 2\"";
    for (const MujocoMimic& mimic : mimics)
      equalities += EqualityElement(mimic, CouplingOf(m, mimic), attributes) + "\n";
    const int precision = _mjPRIVATE__get_xml_precision();
    _mjPRIVATE__set_xml_precision(17);
    saved = mj_saveLastXML(path.c_str(), m, error, error_size);
    _mjPRIVATE__set_xml_precision(precision);
    mj_deleteModel(m);
  }
  std::ifstream in(path);
  std::stringstream all;
  all << in.rdbuf();
  std::string text = all.str();
  std::remove(path.c_str());
  const std::size_t end = text.rfind("</mujoco>");
  if (saved == 0 || end == std::string::npos) {
    Refuse(file, "MuJoCo could not write it as MJCF to couple its mimic joints: " + OneLine(error));
  }
  text.insert(end, equalities);
  files[0].data = std::move(text);  // the MJCF in the URDF's place; the files it names stay
  return LoadFiles(file, files, error, error_size);
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
        qpos_start_(model_.model_->nq),
        qvel_start_(model_.model_->nv),
        jacp_(3 * static_cast<std::size_t>(model_.model_->nv)),
        full_(VectorXd::Zero(model_.model_->nv)),
        turn_(VectorXd::Zero(model_.model_->nv)) {
    if (d_ == nullptr) throw std::runtime_error(model_.file_ + ": MuJoCo could not make its data");
    mj_forward(m_, d_);
  }
  ~MujocoPlantData() override { mj_deleteData(d_); }
  MujocoPlantData(const MujocoPlantData&) = delete;
  MujocoPlantData& operator=(const MujocoPlantData&) = delete;

  // A mimic is placed on its leader: q_mimic = multiplier q_leader + offset, qd likewise.
  void SetState(ConstVecRef q, ConstVecRef qd) override {
    if (model_.floating_base()) {
      FreeJointToMujoco(q.data(), qd.data(), d_->qpos + model_.base_qpos_, d_->qvel + model_.base_qvel_);
    }
    for (std::size_t i = 0; i < model_.qpos_.size(); ++i) {
      d_->qpos[model_.qpos_[i]] = q[model_.q0_ + static_cast<int>(i)];
      d_->qvel[model_.qvel_[i]] = qd[model_.v0_ + static_cast<int>(i)];
    }
    for (const MujocoPlantModel::Mimic& mimic : model_.mimics_) {
      d_->qpos[mimic.qpos] = mimic.multiplier * q[mimic.leader] + mimic.offset;
      d_->qvel[mimic.qvel] = mimic.multiplier * qd[mimic.leader];
    }
    mju_zero(d_->qfrc_applied, m_->nv);
    mju_zero(d_->qacc_warmstart, m_->nv);
    for (mjWarningStat& w : d_->warning) w.number = 0;
    mj_forward(m_, d_);
  }

  const char* Step(ConstVecRef tau, VecRef q, VecRef qd, VecRef qdd) override {
    try {
      return StepOnce(tau, q, qd, qdd);
    } catch (const MujocoError& error) {
      // The fault path only (the throw allocated): the instance stops here with
      // MuJoCo's words, and its arena is free again for a later SetState.
      d_->pstack = 0;
      std::snprintf(error_.data(), error_.size(), "%s", error.what());
      return error_.data();
    }
  }

 private:
  const char* StepOnce(ConstVecRef tau, VecRef q, VecRef qd, VecRef qdd) {
    if (model_.floating_base()) {  // the base's wrench, held in the world over the substeps
      BaseQ();
      FreeJointForceToMujoco(base_q_.data(), tau.data(), d_->qfrc_applied + model_.base_qvel_);
    }
    for (std::size_t i = 0; i < model_.qvel_.size(); ++i)  // a mimic's: 0
      d_->qfrc_applied[model_.qvel_[i]] = tau[model_.v0_ + static_cast<int>(i)];
    for (mjWarningStat& w : d_->warning) w.number = 0;
    const double h = m_->opt.timestep;
    other_work_ = 0.0;
    double power_before = 0.0;
    for (int k = 0; k < model_.substeps_; ++k) {
      SaveStart();
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
    SaveStart();
    mj_forward(m_, d_);  // q̈ and the energies at the end state, under tau
    other_work_ += 0.5 * h * (power_before + OtherPower());
    for (int w = 0; w < mjNWARNING; ++w) {
      if (d_->warning[w].number > 0) return WarningReason(w);
    }
    if (model_.floating_base()) {
      const int b = model_.base_qvel_;
      FreeJointFromMujoco(d_->qpos + model_.base_qpos_, d_->qvel + b, q.data(), qd.data());
      FreeJointAccelerationFromMujoco(q.data(), qd.data(), d_->qacc + b, qdd.data());
    }
    for (std::size_t i = 0; i < model_.qpos_.size(); ++i) {
      const int iq = model_.q0_ + static_cast<int>(i), iv = model_.v0_ + static_cast<int>(i);
      q[iq] = d_->qpos[model_.qpos_[i]];
      qd[iv] = d_->qvel[model_.qvel_[i]];
      qdd[iv] = d_->qacc[model_.qvel_[i]];
    }
    return nullptr;
  }

  void SaveStart() {
    for (int i = 0; i < m_->nq; ++i) qpos_start_[i] = d_->qpos[i];
    for (int i = 0; i < m_->nv; ++i) qvel_start_[i] = d_->qvel[i];
  }

  // The floating base's q (lagrange's 7) at the current state, into base_q_.
  void BaseQ() const {
    std::array<double, 6> unused{};
    FreeJointFromMujoco(d_->qpos + model_.base_qpos_, d_->qvel + model_.base_qvel_, base_q_.data(), unused.data());
  }

 public:
  double kinetic_energy() const override { return d_->energy[1]; }
  const mjModel* m() const { return m_; }
  const mjData* d() const { return d_; }
  double potential_energy() const override { return d_->energy[0]; }
  double other_work() const override { return other_work_; }

  // MuJoCo's M qacc = qfrc_applied + qfrc_passive + qfrc_constraint − qfrc_bias, each term
  // as mj_forward left it at the current state, reduced to the degrees of freedom (Sᵀ).
  void ComputeForces(EffectForces& out) override {
    if (model_.floating_base()) BaseQ();
    const MujocoPlantModel::Terms& has = model_.terms_;
    out.active.gravity = has.gravity;
    out.active.coriolis = true;
    out.active.damping = has.passive;
    out.active.friction = has.friction_loss;
    out.active.limits = has.limits;
    out.constraint_on = has.constraint;
    out.limit_springs.setZero();  // MuJoCo's limits are constraints, with no spring energy in V
    ComputeGravity(full_);
    Reduce(full_, out.gravity);
    for (int i = 0; i < m_->nv; ++i) full_[i] = d_->qfrc_bias[i] - full_[i];
    if (model_.floating_base()) {  // lagrange's a is v̇: its Coriolis row holds Tᵀ M Ṫ v too (plant/mujoco_free_joint.hpp)
      BaseQ();
      const int b = model_.base_qvel_;
      turn_.setZero();
      const Eigen::Map<const Eigen::Vector3d> pdot(d_->qvel + b), w(d_->qvel + b + 3);
      const Eigen::Matrix3d R = FreeJointRotation(base_q_.data());
      turn_.segment<3>(b) = R * w.cross(R.transpose() * pdot);  // Ṫ v = R (ω_b × v_b)
      mj_mulM(m_, d_, scratch_.data(), turn_.data());
      full_ += scratch_;
    }
    Reduce(full_, out.coriolis);
    Reduce(Eigen::Map<const VectorXd>(d_->qfrc_passive, m_->nv), out.damping);
    ConstraintShare(ConstraintKind::kFrictionLoss, out.friction);
    ConstraintShare(ConstraintKind::kLimit, out.limits);
    ConstraintShare(ConstraintKind::kContactOrEquality, out.constraint);
    ListContacts(out);
  }

 private:
  enum class ConstraintKind : std::uint8_t { kFrictionLoss, kLimit, kContactOrEquality };
  static ConstraintKind KindOf(int efc_type) {
    switch (efc_type) {
      case mjCNSTR_FRICTION_DOF:
      case mjCNSTR_FRICTION_TENDON: return ConstraintKind::kFrictionLoss;
      case mjCNSTR_LIMIT_JOINT:
      case mjCNSTR_LIMIT_TENDON: return ConstraintKind::kLimit;
      default: return ConstraintKind::kContactOrEquality;  // equality, and contacts of every cone
    }
  }

  // (nv) => (n): Sᵀ f, S the coupling q_full = S q + offset: a mimic's force acts on its leader times its multiplier.
  // With a floating base, Tᵀ f on its six (plant/mujoco_free_joint.hpp; BaseQ() current).
  void Reduce(const Eigen::Ref<const VectorXd>& full, VecRef out) const {
    if (model_.floating_base()) FreeJointForceFromMujoco(base_q_.data(), full.data() + model_.base_qvel_, out.data());
    for (std::size_t i = 0; i < model_.qvel_.size(); ++i) out[model_.v0_ + static_cast<int>(i)] = full[model_.qvel_[i]];
    for (const MujocoPlantModel::Mimic& mimic : model_.mimics_)
      out[mimic.leader] += mimic.multiplier * full[mimic.qvel];
  }

  // (q) => G (nv) = −Σ_bodies m J_comᵀ g: the gravity part of qfrc_bias.
  void ComputeGravity(VectorXd& g_force) {
    g_force.setZero();
    if (!model_.terms_.gravity) return;
    const int nv = m_->nv;
    for (int b = 1; b < m_->nbody; ++b) {
      const double mass = m_->body_mass[b];
      if (mass == 0.0) continue;
      mj_jacBodyCom(m_, d_, jacp_.data(), nullptr, b);
      for (int k = 0; k < 3; ++k) {
        const double weight = mass * m_->opt.gravity[k];
        for (int i = 0; i < nv; ++i) g_force[i] -= weight * jacp_[static_cast<std::size_t>(k * nv + i)];
      }
    }
  }

  // (efc rows of `kind`) => Sᵀ Jᵀ efc_force over them: the kinds add up to qfrc_constraint.
  void ConstraintShare(ConstraintKind kind, VecRef out) {
    full_.setZero();
    const int nv = m_->nv;
    const bool sparse = mj_isSparse(m_) != 0;
    for (int r = 0; r < d_->nefc; ++r) {
      if (KindOf(d_->efc_type[r]) != kind) continue;
      const double f = d_->efc_force[r];
      if (sparse) {
        const int start = d_->efc_J_rowadr[r];
        for (int k = 0; k < d_->efc_J_rownnz[r]; ++k) full_[d_->efc_J_colind[start + k]] += d_->efc_J[start + k] * f;
      } else {
        const mjtNum* row = d_->efc_J + static_cast<std::ptrdiff_t>(r) * nv;
        for (int i = 0; i < nv; ++i) full_[i] += row[i] * f;
      }
    }
    Reduce(full_, out);
  }

  // MuJoCo's active contacts (those in the constraint), the first kMaxContacts in its order, world frame.
  void ListContacts(EffectForces& out) const {
    out.contacts_total = 0;
    out.num_contacts = 0;
    for (int i = 0; i < d_->ncon; ++i) {
      const mjContact& c = d_->contact[i];
      if (c.efc_address < 0) continue;  // excluded, or not in the constraint
      ++out.contacts_total;
      if (out.num_contacts == kMaxContacts) continue;
      ContactWrench& w = out.contacts[static_cast<std::size_t>(out.num_contacts++)];
      mjtNum f[6];
      mj_contactForce(m_, d_, i, f);  // contact frame: normal, tangent 1, tangent 2; on geom2 from geom1
      // frame: its axes (normal, tangent 1, tangent 2) in world coordinates, one per row.
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> frame(c.frame);
      w.geom1 = c.geom1;
      w.geom2 = c.geom2;
      w.distance = c.dist;
      w.position = Eigen::Map<const Eigen::Vector3d>(c.pos);
      w.normal = frame.row(0).transpose();
      w.force = frame.transpose() * Eigen::Vector3d(f[0], f[1], f[2]);
      w.torque = frame.transpose() * Eigen::Vector3d(f[3], f[4], f[5]);
    }
  }

  // W: qvelᵀ (passive + constraint forces) at (qpos_start_, qvel_start_),
  // with the joint springs taken out (their energy is in V): damping, fluid,
  // friction loss, limits, contacts, equality constraints (a mimic's
  // coupling). The forces are those mj_forward left in the data for that
  // state. Over every MuJoCo degree of freedom, mimics and free bodies too
  // (qvel and qfrc are dual: their product is power; the springs of hinge and
  // slide joints only are taken out: a free joint's stiffness is not expected).
  double OtherPower() const {
    double p = 0.0;
    for (int i = 0; i < m_->nv; ++i) {
      const int j = m_->dof_jntid[i];
      const int k = m_->jnt_qposadr[j];
      const bool simple = m_->jnt_type[j] == mjJNT_HINGE || m_->jnt_type[j] == mjJNT_SLIDE;
      const double spring = simple ? -m_->jnt_stiffness[j] * (qpos_start_[k] - m_->qpos_spring[k]) : 0.0;
      p += qvel_start_[i] * (d_->qfrc_passive[i] - spring + d_->qfrc_constraint[i]);
    }
    return p;
  }

  std::shared_ptr<const MujocoPlantModel> shared_;  // the model outlives its data
  const MujocoPlantModel& model_;
  const mjModel* m_;
  mjData* d_;
  VectorXd qpos_start_, qvel_start_;  // (nq, nv) the state a MuJoCo step started from, mimics too
  double other_work_ = 0.0;
  std::vector<mjtNum> jacp_;  // (3 x nv) scratch: a body's centre-of-mass Jacobian
  VectorXd full_;             // (nv) scratch: one term over every MuJoCo joint, mimics too
  VectorXd turn_;             // (nv) scratch: Ṫ v of a floating base
  VectorXd scratch_ = VectorXd::Zero(model_.model_->nv);  // (nv) M Ṫ v
  mutable std::array<double, 7> base_q_{};  // the floating base's q, lagrange's (BaseQ)
  std::array<char, 256> error_{};  // the reason of a Step that MuJoCo ended with an error
};

MujocoPlantModel::~MujocoPlantModel() {
  if (model_ != nullptr) mj_deleteModel(model_);
}

std::unique_ptr<SteppedPlantData> MujocoPlantModel::MakeData() const {
  return std::make_unique<MujocoPlantData>(shared_from_this());
}

std::vector<MujocoMimic> MimicsOf(const RigidTree& tree) {
  std::vector<MujocoMimic> mimics;
  for (const TreeJoint& j : tree.joints) {
    if (j.mimic < 0) continue;
    mimics.push_back({j.name, tree.joints[static_cast<std::size_t>(j.mimic)].name, j.multiplier, j.offset});
  }
  return mimics;
}

namespace {

std::string List(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& n : names) text += (text.empty() ? "" : ", ") + n;
  return text;
}

// MuJoCo's first free joint when `floating` (lagrange's floating base), else
// −1; refused when there is none.
int BaseJoint(const std::string& file, const mjModel* m, bool floating) {
  if (!floating) return -1;
  for (int j = 0; j < m->njnt; ++j) {
    if (m->jnt_type[j] == mjJNT_FREE) return j;
  }
  Refuse(file, "expected a free joint for lagrange's floating base, got none");
}

// MuJoCo's hinge and slide joints must be lagrange's degrees of freedom
// (`dofs`; empty: MuJoCo's joints but the mimics, which it then lists) and
// its mimics, each once; free joints are the floating base or free bodies
// (mujoco_plant.hpp), ball joints refused; MuJoCo's joint id of each degree of freedom.
std::vector<int> MatchJoints(const std::string& file, const mjModel* m, std::vector<std::string>& dofs,
                             const std::vector<MujocoMimic>& mimics, bool floating) {
  std::vector<std::string> names;
  std::vector<int> ids;
  for (int j = 0; j < m->njnt; ++j) {
    const int type = m->jnt_type[j];
    if (type == mjJNT_BALL) {
      Refuse(file, "joint '" + JointName(m, j) +
                       "' is a ball joint: expected hinge, slide or free joints only (lagrange's messages are "
                       "joint-space)");
    }
    if (type == mjJNT_FREE) continue;
    names.push_back(JointName(m, j));
    ids.push_back(j);
  }
  if (names.empty() && !floating) Refuse(file, "expected at least one hinge or slide joint, got none");
  if (dofs.empty()) {
    for (const std::string& name : names) {
      const bool mimic =
          std::any_of(mimics.begin(), mimics.end(), [&](const MujocoMimic& x) { return x.joint == name; });
      if (!mimic) dofs.push_back(name);
    }
  }
  std::vector<std::string> ours = dofs;
  for (const MujocoMimic& mimic : mimics) ours.push_back(mimic.joint);
  std::vector<bool> used(names.size(), false);
  std::vector<int> index;
  bool same = ours.size() == names.size();
  for (const std::string& name : ours) {
    const auto j = static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
    same = same && j < names.size() && !used[j];
    if (!same) break;
    used[j] = true;
    index.push_back(ids[j]);
  }
  if (!same) {
    std::vector<std::string> mimic_names;
    for (const MujocoMimic& mimic : mimics) mimic_names.push_back(mimic.joint);
    Refuse(file, "MuJoCo's joints (" + List(names) + ") are not those of lagrange's model (" + List(dofs) +
                     (mimics.empty() ? "" : "; mimics " + List(mimic_names)) + "): expected the same joints");
  }
  index.resize(dofs.size());
  return index;
}

template <class T>
bool AnyNonZero(const T* v, int n) {
  return std::any_of(v, v + n, [](T x) { return x != 0; });
}

}  // namespace

// The terms of the equation of motion `m` has, as its options and elements say.
MujocoPlantModel::Terms MujocoPlantModel::TermsOf(const mjModel* m) {
  const auto disabled = [&](int flag) { return (m->opt.disableflags & flag) != 0; };
  const bool constraints = !disabled(mjDSBL_CONSTRAINT);
  Terms t;
  t.gravity = !disabled(mjDSBL_GRAVITY) && AnyNonZero(m->opt.gravity, 3);
  t.passive = !disabled(mjDSBL_PASSIVE) &&
              (AnyNonZero(m->dof_damping, m->nv) || AnyNonZero(m->jnt_stiffness, m->njnt) ||
               AnyNonZero(m->tendon_damping, m->ntendon) || AnyNonZero(m->tendon_stiffness, m->ntendon) ||
               m->opt.density > 0.0 || m->opt.viscosity > 0.0);
  t.friction_loss = constraints && !disabled(mjDSBL_FRICTIONLOSS) &&
                    (AnyNonZero(m->dof_frictionloss, m->nv) || AnyNonZero(m->tendon_frictionloss, m->ntendon));
  t.limits = constraints && !disabled(mjDSBL_LIMIT) &&
             (AnyNonZero(m->jnt_limited, m->njnt) || AnyNonZero(m->tendon_limited, m->ntendon));
  t.constraint =
      constraints && ((!disabled(mjDSBL_CONTACT) && m->ngeom > 0) || (!disabled(mjDSBL_EQUALITY) && m->neq > 0));
  return t;
}

std::shared_ptr<const MujocoPlantModel> LoadMujocoPlant(const std::string& file, const MujocoOptions& options) {
  InstallHandlers();
  if (!(options.period > 0.0) || options.substeps < 1) Refuse(file, "expected a positive period and substeps >= 1");
  char error[1000] = "";
  // The model's text as MuJoCo reads it (exact_inertia: a URDF whose inertias lagrange sets, with the edits
  // above), and every file it names, read bounded before MuJoCo sees them.
  std::string text = ReadMujocoModelText(file);
  if (options.exact_inertia != nullptr) text = PrepareUrdf(std::move(text));
  const bool urdf = IsUrdfText(text);
  std::vector<MujocoFile> files = ReadMujocoFiles(file, std::move(text));
  mjModel* m = LoadFiles(file, files, error, sizeof error);
  if (m == nullptr) Refuse(file, "MuJoCo: " + OneLine(error[0] != '\0' ? error : "could not load the model"));
  std::shared_ptr<MujocoPlantModel> model(new MujocoPlantModel);
  model->model_ = m;  // deleted with the model, whatever is refused below
  model->file_ = file;
  std::vector<std::string> dofs = options.joint_order;
  if (options.floating_base && !options.mimics.empty()) Refuse(file, "mimic joints with a floating base: not yet");
  BaseJoint(file, m, options.floating_base);  // a missing free joint named before the joints are matched
  std::vector<int> joints = MatchJoints(file, m, dofs, options.mimics, options.floating_base);
  const double timestep = options.period / options.substeps;
  const bool couple = !options.mimics.empty() && urdf;
  if (couple) {  // a URDF cannot say it: lagrange adds it
    mj_deleteModel(m);
    model->model_ = nullptr;
    m = CoupleMimics(file, std::move(files), options.mimics, timestep, error, sizeof error);
    if (m == nullptr) Refuse(file, "MuJoCo: " + OneLine(error[0] != '\0' ? error : "could not load the model"));
    model->model_ = m;
    joints = MatchJoints(file, m, dofs, options.mimics, false);  // the same joints, in MuJoCo's MJCF of the URDF
  }
  model->joint_names_ = dofs;
  for (const MujocoMimic& mimic : options.mimics) {
    if (auto why = CheckCoupled(m, mimic)) Refuse(file, *why);
    const auto leader = std::find(dofs.begin(), dofs.end(), mimic.leader);
    if (leader == dofs.end()) {
      Refuse(file, "joint '" + mimic.joint + "' mimics '" + mimic.leader + "': expected a degree of freedom");
    }
    const int j = mj_name2id(m, mjOBJ_JOINT, mimic.joint.c_str());
    model->mimics_.push_back(
        {m->jnt_qposadr[j], m->jnt_dofadr[j], static_cast<int>(leader - dofs.begin()), mimic.multiplier, mimic.offset});
    if (couple) {  // as lagrange reads a URDF mimic (plant/urdf.hpp): its own <dynamics> and <limit> unused
      m->dof_damping[m->jnt_dofadr[j]] = 0.0;
      m->dof_frictionloss[m->jnt_dofadr[j]] = 0.0;
      m->jnt_limited[j] = 0;
    }
  }
  const int base = BaseJoint(file, m, options.floating_base);
  const double inf = std::numeric_limits<double>::infinity();
  if (base >= 0) {
    model->base_qpos_ = m->jnt_qposadr[base];
    model->base_qvel_ = m->jnt_dofadr[base];
    model->q0_ = kFreeFlyerNq;
    model->v0_ = kFreeFlyerNv;
    model->info_.limited.assign(kFreeFlyerNv, false);
    model->info_.lower.assign(kFreeFlyerNv, -inf);
    model->info_.upper.assign(kFreeFlyerNv, inf);
  }
  for (const int j : joints) {
    model->qpos_.push_back(m->jnt_qposadr[j]);
    model->qvel_.push_back(m->jnt_dofadr[j]);
    const bool limited = m->jnt_limited[j] != 0;
    model->info_.limited.push_back(limited);
    model->info_.lower.push_back(limited ? m->jnt_range[2 * j] : -inf);
    model->info_.upper.push_back(limited ? m->jnt_range[2 * j + 1] : inf);
  }
  model->num_dofs_ = static_cast<int>(dofs.size()) + model->v0_;  // MuJoCo's nv less the mimics and free bodies
  model->num_positions_ = static_cast<int>(dofs.size()) + model->q0_;
  model->substeps_ = options.substeps;
  model->integrator_ = options.integrator;
  m->opt.timestep = timestep;
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
  if (options.exact_inertia != nullptr) SetExactInertias(m, *options.exact_inertia, base, file);
  model->terms_ = MujocoPlantModel::TermsOf(m);
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

std::optional<MujocoFreeBody> MujocoFreeJointState(const SteppedPlantData& data, const std::string& joint) {
  const auto* mujoco = dynamic_cast<const MujocoPlantData*>(&data);
  if (mujoco == nullptr) return std::nullopt;
  const mjModel* m = mujoco->m();
  const int id = mj_name2id(m, mjOBJ_JOINT, joint.c_str());
  if (id < 0 || m->jnt_type[id] != mjJNT_FREE) return std::nullopt;
  MujocoFreeBody body;
  FreeJointFromMujoco(mujoco->d()->qpos + m->jnt_qposadr[id], mujoco->d()->qvel + m->jnt_dofadr[id], body.q.data(),
                      body.v.data());
  return body;
}

std::optional<double> MujocoJointPosition(const SteppedPlantData& data, const std::string& joint) {
  const auto* mujoco = dynamic_cast<const MujocoPlantData*>(&data);
  if (mujoco == nullptr) return std::nullopt;
  const int id = mj_name2id(mujoco->m(), mjOBJ_JOINT, joint.c_str());
  if (id < 0) return std::nullopt;
  return mujoco->d()->qpos[mujoco->m()->jnt_qposadr[id]];
}

std::string MujocoVersion() {
  const int v = mj_version();  // 222 for 2.2.2
  return std::to_string(v / 100) + "." + std::to_string(v / 10 % 10) + "." + std::to_string(v % 10);
}

}  // namespace lagrange
