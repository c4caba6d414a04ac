#include "controllers/ddp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace lagrange {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

[[noreturn]] void Refuse(std::string_view field, std::string_view expected) {
  std::string message = "ddp: ";
  message.append(field).append(": expected ").append(expected);
  throw std::invalid_argument(message);
}

void CheckWeights(const VectorXd& w, int size, bool positive, const char* field) {
  const bool ok = w.size() == size && w.allFinite() && (positive ? (w.array() > 0.0).all() : (w.array() >= 0.0).all());
  if (ok) return;
  std::string expected = "(";
  expected.append(std::to_string(size)).append(") finite values ").append(positive ? "> 0" : ">= 0");
  Refuse(field, expected);
}

// Cholesky factorisation L Lᵀ of the leading f x f block of L, in place
// (lower triangle). Written out rather than Eigen's LLT because the free
// block's size changes from knot to knot: an LLT<MatrixXd> would reallocate,
// and this one works inside the buffer sized once for m.
bool CholeskyInPlace(MatrixXd& L, int f) {
  for (int j = 0; j < f; ++j) {
    double s = L(j, j);
    for (int p = 0; p < j; ++p) s -= L(j, p) * L(j, p);
    if (!(s > 0.0) || !std::isfinite(s)) return false;
    L(j, j) = std::sqrt(s);
    for (int i = j + 1; i < f; ++i) {
      double v = L(i, j);
      for (int p = 0; p < j; ++p) v -= L(i, p) * L(j, p);
      L(i, j) = v / L(j, j);
    }
  }
  return true;
}

// b ← (L Lᵀ)⁻¹ b over the leading f entries.
void CholeskySolveInPlace(const MatrixXd& L, int f, double* b) {
  for (int i = 0; i < f; ++i) {
    double v = b[i];
    for (int p = 0; p < i; ++p) v -= L(i, p) * b[p];
    b[i] = v / L(i, i);
  }
  for (int i = f - 1; i >= 0; --i) {
    double v = b[i];
    for (int p = i + 1; p < f; ++p) v -= L(p, i) * b[p];
    b[i] = v / L(i, i);
  }
}

}  // namespace

std::string_view ToString(DdpStatus status) {
  switch (status) {
    case DdpStatus::kConverged: return "converged";
    case DdpStatus::kMaxIterations: return "max-iterations";
    case DdpStatus::kLineSearchFailed: return "line-search-failed";
    case DdpStatus::kNotPositiveDefinite: return "not-positive-definite";
    case DdpStatus::kDiverged: return "diverged";
    case DdpStatus::kStopped: return "stopped";
  }
  return "unknown";
}

DdpModel::DdpModel(std::shared_ptr<const Dynamics> dynamics, DdpConfig config)
    : dynamics_(std::move(dynamics)), config_(std::move(config)), n_(0) {
  if (dynamics_ == nullptr) Refuse("model", "a dynamics model, got null");
  n_ = dynamics_->num_dofs();
  if (const char* reason = NoStepDerivativesReason(config_.integrator)) Refuse("integrator", reason);
  if (config_.substeps < 1 || config_.substeps > 1000) Refuse("substeps", "1..1000");
  if (!std::isfinite(config_.dt) || !(config_.dt > 0.0)) Refuse("dt", "a finite number > 0 (s)");
  if (config_.horizon < 1 || config_.horizon > 100000) Refuse("horizon", "1..100000 knots");
  actuated_ = config_.actuated;
  if (actuated_.empty()) {
    for (int i = 0; i < n_; ++i) actuated_.push_back(i);
  }
  for (std::size_t j = 0; j < actuated_.size(); ++j) {
    if (actuated_[j] < 0 || actuated_[j] >= n_ || (j > 0 && actuated_[j] <= actuated_[j - 1])) {
      Refuse("actuated", std::string("ascending joint indices in 0..").append(std::to_string(n_ - 1)));
    }
  }
  const int m = num_controls();
  lower_ = config_.tau_lower.size() == 0 ? VectorXd::Constant(m, -kInf) : config_.tau_lower;
  upper_ = config_.tau_upper.size() == 0 ? VectorXd::Constant(m, kInf) : config_.tau_upper;
  if (lower_.size() != m || upper_.size() != m || lower_.hasNaN() || upper_.hasNaN() ||
      !(lower_.array() <= upper_.array()).all() || (lower_.array() == kInf).any() || (upper_.array() == -kInf).any()) {
    Refuse("tau_lower, tau_upper", std::to_string(m).append(" each, lower <= upper, no NaN"));
  }
  const DdpWeights& w = config_.weights;
  CheckWeights(w.q, n_, false, "weights.q");
  CheckWeights(w.qd, n_, false, "weights.qd");
  CheckWeights(w.tau, m, true, "weights.tau");
  CheckWeights(w.q_terminal, n_, false, "weights.q_terminal");
  CheckWeights(w.qd_terminal, n_, false, "weights.qd_terminal");
  const DdpOptions& o = config_.options;
  if (o.max_iterations < 1 || o.max_iterations > 10000) Refuse("options.max_iterations", "1..10000");
  if (!(o.tolerance >= 0.0) || !std::isfinite(o.tolerance)) Refuse("options.tolerance", "a finite number >= 0");
  if (!(o.regularization_min > 0.0) || !(o.regularization_max >= o.regularization_min) ||
      !std::isfinite(o.regularization_max)) {
    Refuse("options.regularization_min, regularization_max", "0 < min <= max, finite");
  }
  if (!(o.regularization_factor > 1.0) || !std::isfinite(o.regularization_factor)) {
    Refuse("options.regularization_factor", "a finite number > 1");
  }
  if (o.line_search_steps < 1 || o.line_search_steps > 60) Refuse("options.line_search_steps", "1..60");
  if (!(o.line_search_acceptance >= 0.0 && o.line_search_acceptance < 1.0)) {
    Refuse("options.line_search_acceptance", "a number in [0, 1)");
  }
  if (o.box_qp_max_iterations < 1 || o.box_qp_max_iterations > 1000) Refuse("options.box_qp_max_iterations", "1..1000");
  const DdpFrameCost& f = config_.frame_cost;
  if (f.kinematics != nullptr) {
    if (f.kinematics->num_dofs() != n_) Refuse("frame_cost.kinematics", "the plant's joints");
    if (f.frame < 0 || f.frame >= f.kinematics->num_frames()) Refuse("frame_cost.frame", "one of the model's frames");
    for (double weight : {f.position, f.rotation, f.position_terminal, f.rotation_terminal}) {
      if (!(std::isfinite(weight) && weight >= 0.0)) Refuse("frame_cost weights", "finite values >= 0");
    }
  }
  if (auto err = ValidateEffects(config_.effects, n_)) Refuse(std::string("effects.").append(err->key), err->message);
  if (!config_.effects.disturbance.empty())
    Refuse("effects.disturbance", "none (the optimiser's model takes no pushes)");
}

DdpData::DdpData(const DdpModel& model) : model_(&model) {
  const int n = model.num_dofs(), m = model.num_controls(), N = model.horizon(), nx = 2 * n;
  q_ref = MatrixXd::Zero(n, N + 1);
  qd_ref = MatrixXd::Zero(n, N + 1);
  u_ref = MatrixXd::Zero(m, N);
  pose_ref.assign(static_cast<std::size_t>(N + 1), Pose{});
  if (model.has_frame_cost()) kinematics_ = model.config().frame_cost.kinematics->MakeData();
  plant_ = std::make_unique<PlantModel>(model.dynamics(), model.config().effects);
  IntegratorConfig ic;
  ic.type = model.config().integrator;
  ic.substeps = model.config().substeps;
  integrator_ = MakeIntegrator(ic, n);
  step_ = std::make_unique<StepDerivatives>(ic.type, n);
  x_ = x_try_ = MatrixXd::Zero(nx, N + 1);
  u_ = u_try_ = MatrixXd::Zero(m, N);
  A_.assign(static_cast<std::size_t>(N), MatrixXd::Zero(nx, nx));
  B_.assign(static_cast<std::size_t>(N), MatrixXd::Zero(nx, m));
  K_.assign(static_cast<std::size_t>(N), MatrixXd::Zero(m, nx));
  kff_ = Qu_ = MatrixXd::Zero(m, N);
  B_full_.resize(nx, n);
  tau_ = q_ = qd_ = VectorXd::Zero(n);
  dx_.resize(nx);
  x0_.resize(nx);
  Vx_.resize(nx);
  Qx_.resize(nx);
  Qu_k_.resize(m);
  Quu_k_vec_.resize(m);
  lo_.resize(m);
  hi_.resize(m);
  du_.resize(m);
  Vxx_.resize(nx, nx);
  VA_.resize(nx, nx);
  VB_.resize(nx, m);
  Qxx_.resize(nx, nx);
  Quu_.resize(m, m);
  Qreg_.resize(m, m);
  Qux_.resize(m, nx);
  QuuK_.resize(m, nx);
  XX_.resize(nx, nx);
  qp_grad_.resize(m);
  qp_x_trial_.resize(m);
  qp_search_.resize(m);
  qp_Hx_.resize(m);
  qp_rhs_.resize(m);
  qp_L_.resize(m, m);
  qp_free_.reserve(static_cast<std::size_t>(m));
  qp_is_free_.assign(static_cast<std::size_t>(m), 1);
  qp_factored_.reserve(static_cast<std::size_t>(m));
  result_.cost_history = VectorXd::Zero(model.config().options.max_iterations + 1);
}

Effects& DdpData::effects() { return plant_->effects(); }
const Effects& DdpData::effects() const { return plant_->effects(); }

double FramePoseCost(const Kinematics& kinematics, KinematicsData& data, int frame, const Pose& target, double w_pos,
                     double w_rot, ConstVecRef q, bool derivatives, VecRef gradient, Eigen::Ref<MatrixXd> hessian) {
  if (derivatives) {
    kinematics.ComputeFrameJacobian(data, q, frame, FrameAxes::kWorldAligned);
  } else {
    kinematics.ComputeFramePlacement(data, q, frame);
  }
  const Pose measured{data.position(frame), Eigen::Quaterniond(data.rotation(frame))};
  const Vector6d e = PoseError(target, measured);
  const double cost = 0.5 * (w_pos * e.head<3>().squaredNorm() + w_rot * e.tail<3>().squaredNorm());
  if (!derivatives) return cost;
  const Matrix6Xd& J = data.jacobian(frame, FrameAxes::kWorldAligned);
  Vector6d we;
  we << w_pos * e.head<3>(), w_rot * e.tail<3>();
  gradient.noalias() -= J.transpose() * we;
  hessian.noalias() += w_pos * (J.topRows<3>().transpose() * J.topRows<3>());
  hessian.noalias() += w_rot * (J.bottomRows<3>().transpose() * J.bottomRows<3>());
  return cost;
}

void EvaluateAffinePolicy(ConstVecRef u_bar, const Eigen::Ref<const MatrixXd>& K, ConstVecRef x_bar, ConstVecRef q,
                          ConstVecRef qd, const VectorXd& lower, const VectorXd& upper, VecRef u) {
  EvaluateAffinePolicy(u_bar, u_bar, K, x_bar, x_bar, 0.0, q, qd, lower, upper, u);
}

void EvaluateAffinePolicy(ConstVecRef u_bar, ConstVecRef u_bar_next, const Eigen::Ref<const MatrixXd>& K,
                          ConstVecRef x_bar, ConstVecRef x_bar_next, double s, ConstVecRef q, ConstVecRef qd,
                          const VectorXd& lower, const VectorXd& upper, VecRef u) {
  // Written out: a product with (x − x̄) would evaluate it into a temporary.
  const auto n = q.size();
  const auto planned = [&](Eigen::Index i) { return x_bar[i] + s * (x_bar_next[i] - x_bar[i]); };
  for (Eigen::Index j = 0; j < u.size(); ++j) {
    double v = u_bar[j] + s * (u_bar_next[j] - u_bar[j]);
    for (Eigen::Index i = 0; i < n; ++i) v += K(j, i) * (q[i] - planned(i)) + K(j, n + i) * (qd[i] - planned(n + i));
    u[j] = std::clamp(v, lower[j], upper[j]);
  }
}

void DdpData::EvaluatePolicy(int k, ConstVecRef q, ConstVecRef qd, VecRef u) const {
  eigen_assert(k >= 0 && k < model_->horizon() && q.size() == model_->num_dofs() && u.size() == model_->num_controls());
  EvaluateAffinePolicy(u_.col(k), K_[static_cast<std::size_t>(k)], x_.col(k), q, qd, model_->tau_lower(),
                       model_->tau_upper(), u);
}

void DdpData::ShiftSolution(int knots) {
  const int N = model_->horizon();
  const int s = std::clamp(knots, 0, N);
  if (s == 0) return;
  // Increasing k reads only columns >= k, still unshifted.
  for (int k = 0; k < N; ++k) u_.col(k) = u_.col(std::min(k + s, N - 1));
  for (int k = 0; k <= N; ++k) x_.col(k) = x_.col(std::min(k + s, N));
  // The gains by rotation (swaps, no copies); then the last one repeated.
  if (s < N) std::rotate(K_.begin(), K_.begin() + s, K_.end());
  const int last = s < N ? N - 1 - s : N - 1;
  for (int k = N - s; k < N; ++k) {
    if (k != last) K_[static_cast<std::size_t>(k)] = K_[static_cast<std::size_t>(last)];
  }
}

void DdpData::ShiftSolution(double knots) {
  const int N = model_->horizon();
  const double whole = std::floor(std::clamp(knots, 0.0, static_cast<double>(N)));
  ShiftSolution(static_cast<int>(whole));
  const double f = std::clamp(knots, 0.0, static_cast<double>(N)) - whole;
  if (!(f > 0.0)) return;
  // Increasing k reads only knot k + 1, still unshifted; coefficient-wise, so no temporaries.
  for (int k = 0; k + 1 < N; ++k) {
    u_.col(k) += f * (u_.col(k + 1) - u_.col(k));
    K_[static_cast<std::size_t>(k)] += f * (K_[static_cast<std::size_t>(k + 1)] - K_[static_cast<std::size_t>(k)]);
  }
  for (int k = 0; k < N; ++k) x_.col(k) += f * (x_.col(k + 1) - x_.col(k));
}

void DdpData::Reset() {
  u_.setZero();
  kff_.setZero();
  x_.setZero();
  for (MatrixXd& K : K_) K.setZero();
}

void DdpData::HoldControls(ConstVecRef u) {
  Reset();
  u_.colwise() = u;
}

// The passes of one solve, each a named stage over the data's buffers.
struct DdpPasses {
  // DdpData::stop, polled at every knot of every pass (the first rollout, the
  // linearisation, the backward pass, the line search's rollouts), so that a
  // thread that plans stops within one knot's work whatever the horizon.
  static bool StopRequested(const DdpData& d) {
    return d.stop != nullptr && d.stop->load(std::memory_order_relaxed);
  }
  // ½ Σ w e² of the running cost at knot k of (x, u), or the terminal one (k = N).
  static double Cost(const DdpModel& model, DdpData& d, int k, const Eigen::Ref<const VectorXd>& x,
                     const double* u) {
    const int n = model.num_dofs(), N = model.horizon();
    const DdpWeights& w = model.config().weights;
    const bool terminal = k == N;
    const VectorXd& wq = terminal ? w.q_terminal : w.q;
    const VectorXd& wqd = terminal ? w.qd_terminal : w.qd;
    double J = 0.0;
    for (int i = 0; i < n; ++i) {
      const double eq = x[i] - d.q_ref(i, k), ev = x[n + i] - d.qd_ref(i, k);
      J += wq[i] * eq * eq + wqd[i] * ev * ev;
    }
    if (!terminal) {
      for (int j = 0; j < model.num_controls(); ++j) {
        const double eu = u[j] - d.u_ref(j, k);
        J += w.tau[j] * eu * eu;
      }
    }
    return 0.5 * J + FrameTerm(model, d, k, x.head(n), false, d.Vx_, d.Vxx_);
  }

  // The frame's pose-error term at knot k (k = N: the terminal weights) of q
  // (n); with `derivatives`, its gradient added to g.head(n) and its
  // Gauss–Newton Hessian to H's top-left (n x n). 0 without a frame cost.
  static double FrameTerm(const DdpModel& model, DdpData& d, int k, ConstVecRef q, bool derivatives, VectorXd& g,
                          MatrixXd& H) {
    if (!model.has_frame_cost()) return 0.0;
    const DdpFrameCost& f = model.config().frame_cost;
    const bool terminal = k == model.horizon();
    const int n = model.num_dofs();
    return FramePoseCost(*f.kinematics, *d.kinematics_, f.frame, d.pose_ref[static_cast<std::size_t>(k)],
                         terminal ? f.position_terminal : f.position, terminal ? f.rotation_terminal : f.rotation, q,
                         derivatives, g.head(n), H.topLeftCorner(n, n));
  }

  // tau_ ← S u: the controls u (m) on the actuated joints, 0 on the others.
  static void SetTau(const DdpModel& model, DdpData& d, const double* u) {
    const std::vector<int>& act = model.actuated();
    d.tau_.setZero();
    for (int j = 0; j < model.num_controls(); ++j) d.tau_[act[static_cast<std::size_t>(j)]] = u[j];
  }

  // Forward pass with step α: (x̂, û) from x̂_0 = x_0 under
  // û_k = clamp(ū_k + α k_k + K_k (x̂_k − x̄_k)); returns J(α), +inf when the
  // rollout leaves the finite numbers. `linearize`: each step by the step
  // derivatives, which leave A_k, B_k of the candidate as well (the first
  // rollout of a solve: one pass instead of two). Returns NaN when the stop
  // is set (the candidate then part-way).
  static double Rollout(const DdpModel& model, DdpData& d, double alpha, bool linearize) {
    const int n = model.num_dofs(), N = model.horizon();
    double J = 0.0;
    d.x_try_.col(0) = d.x0_;
    for (int k = 0; k < N; ++k) {
      if (StopRequested(d)) return std::numeric_limits<double>::quiet_NaN();
      d.dx_ = d.x_try_.col(k) - d.x_.col(k);
      auto u = d.u_try_.col(k);
      u = d.u_.col(k) + alpha * d.kff_.col(k);
      u.noalias() += d.K_[static_cast<std::size_t>(k)] * d.dx_;
      u = u.cwiseMax(model.tau_lower()).cwiseMin(model.tau_upper());
      J += Cost(model, d, k, d.x_try_.col(k), u.data());
      SetTau(model, d, u.data());
      d.q_ = d.x_try_.col(k).head(n);
      d.qd_ = d.x_try_.col(k).tail(n);
      if (linearize) {
        StepAt(model, d, k);
      } else {
        d.integrator_->Advance(*d.plant_, k * model.dt(), model.dt(), d.tau_, d.q_, d.qd_);
      }
      d.x_try_.col(k + 1).head(n) = d.q_;
      d.x_try_.col(k + 1).tail(n) = d.qd_;
      if (!d.q_.allFinite() || !d.qd_.allFinite() || !std::isfinite(J)) return kInf;
    }
    J += Cost(model, d, N, d.x_try_.col(N), nullptr);
    return std::isfinite(J) ? J : kInf;
  }

  // (q_, qd_, tau_) at knot k => A_k, B_k and the step's end in (q_, qd_).
  static void StepAt(const DdpModel& model, DdpData& d, int k) {
    const std::vector<int>& act = model.actuated();
    d.step_->Advance(*d.plant_, k * model.dt(), model.dt(), model.config().substeps, d.q_, d.qd_, d.tau_,
                     d.A_[static_cast<std::size_t>(k)], d.B_full_);
    for (int j = 0; j < model.num_controls(); ++j) {
      d.B_[static_cast<std::size_t>(k)].col(j) = d.B_full_.col(act[static_cast<std::size_t>(j)]);
    }
    d.q_ = d.step_->q_next();
    d.qd_ = d.step_->qd_next();
  }

  // A_k, B_k along the nominal; false when the stop is set (A_k, B_k then part-way).
  static bool Linearize(const DdpModel& model, DdpData& d) {
    const int n = model.num_dofs(), N = model.horizon();
    for (int k = 0; k < N; ++k) {
      if (StopRequested(d)) return false;
      SetTau(model, d, d.u_.col(k).data());
      d.q_ = d.x_.col(k).head(n);
      d.qd_ = d.x_.col(k).tail(n);
      StepAt(model, d, k);
    }
    return true;
  }

  // ½ xᵀ H x + gᵀ x, with H x left in d.qp_Hx_.
  static double QpValue(DdpData& d, const MatrixXd& H, const VectorXd& g, ConstVecRef x) {
    d.qp_Hx_.noalias() = H * x;
    return g.dot(x) + 0.5 * x.dot(d.qp_Hx_);
  }

  // The free set at x: a component is clamped when it sits on a bound and
  // the gradient g + H x pushes it outward. Leaves the gradient in qp_grad_.
  static void FreeSet(DdpData& d, const MatrixXd& H, const VectorXd& g, const VectorXd& lo, const VectorXd& hi,
                      ConstVecRef x) {
    d.qp_grad_ = g;
    d.qp_grad_.noalias() += H * x;
    d.qp_free_.clear();
    for (int i = 0; i < static_cast<int>(x.size()); ++i) {
      const bool clamped = (x[i] <= lo[i] && d.qp_grad_[i] > 0.0) || (x[i] >= hi[i] && d.qp_grad_[i] < 0.0);
      d.qp_is_free_[static_cast<std::size_t>(i)] = !clamped;
      if (!clamped) d.qp_free_.push_back(i);
    }
  }

  // qp_L_ ← chol(H_FF) for the current free set, unless it is the one factored.
  static bool FactorFree(DdpData& d, const MatrixXd& H) {
    if (d.qp_factored_ == d.qp_free_) return true;
    const int f = static_cast<int>(d.qp_free_.size());
    for (int a = 0; a < f; ++a) {
      for (int b = 0; b <= a; ++b)
        d.qp_L_(a, b) = H(d.qp_free_[static_cast<std::size_t>(a)], d.qp_free_[static_cast<std::size_t>(b)]);
    }
    d.qp_factored_ = d.qp_free_;  // same capacity (m): no allocation
    if (CholeskyInPlace(d.qp_L_, f)) return true;
    d.qp_factored_.clear();
    return false;
  }

  // The projected-Newton box QP of Tassa, Mansard & Todorov (ICRA 2014),
  // written here by hand (no Debian package offers it):
  //   minimise ½ xᵀ H x + gᵀ x  subject to  lo <= x <= hi,  H (m x m) symmetric,
  // from x (clamped first). Each iteration takes the Newton step on the free
  // set (the components not held at a bound by the gradient), projected onto
  // the box, backtracked until the decrease is at least 0.1 of the linear
  // prediction. It ends with the free set and chol(H_FF) of the final x (so
  // the gains use the active set the solution has). False when an H_FF is not
  // positive definite.
  static bool SolveBoxQp(const DdpModel& model, DdpData& d, const MatrixXd& H, const VectorXd& g, const VectorXd& lo,
                         const VectorXd& hi, VecRef x) {
    constexpr double kArmijo = 0.1, kBacktrack = 0.6, kMinStep = 1e-12, kMinGradient = 1e-12, kMinRelative = 1e-14;
    const int m = static_cast<int>(x.size());
    x = x.cwiseMax(lo).cwiseMin(hi);
    d.qp_factored_.clear();
    double value = QpValue(d, H, g, x);
    for (int it = 0; it < model.config().options.box_qp_max_iterations; ++it) {
      FreeSet(d, H, g, lo, hi, x);
      const int f = static_cast<int>(d.qp_free_.size());
      if (f == 0) break;
      double free_gradient = 0.0;
      for (int i : d.qp_free_) free_gradient = std::max(free_gradient, std::abs(d.qp_grad_[i]));
      if (free_gradient <= kMinGradient * (1.0 + g.lpNorm<Eigen::Infinity>())) break;
      if (!FactorFree(d, H)) return false;
      // Newton target on F with the clamped components fixed: H_FF x_F = −(g_F + H_FC x_C).
      for (int a = 0; a < f; ++a) {
        const int i = d.qp_free_[static_cast<std::size_t>(a)];
        double r = -g[i];
        for (int j = 0; j < m; ++j) {
          if (!d.qp_is_free_[static_cast<std::size_t>(j)]) r -= H(i, j) * x[j];
        }
        d.qp_rhs_[a] = r;
      }
      CholeskySolveInPlace(d.qp_L_, f, d.qp_rhs_.data());
      d.qp_search_.setZero();
      for (int a = 0; a < f; ++a) {
        const int i = d.qp_free_[static_cast<std::size_t>(a)];
        d.qp_search_[i] = d.qp_rhs_[a] - x[i];
      }
      const double slope = d.qp_search_.dot(d.qp_grad_);
      if (!(slope < 0.0)) break;  // no descent left: at the minimum to round-off
      double step = 1.0, trial = kInf;
      for (;;) {
        d.qp_x_trial_ = (x + step * d.qp_search_).cwiseMax(lo).cwiseMin(hi);
        trial = QpValue(d, H, g, d.qp_x_trial_);
        if (trial - value <= kArmijo * step * slope) break;
        step *= kBacktrack;
        if (step < kMinStep) break;
      }
      if (step < kMinStep) break;
      x = d.qp_x_trial_;
      const double improvement = value - trial;
      value = trial;
      if (improvement <= kMinRelative * std::abs(value)) break;
    }
    FreeSet(d, H, g, lo, hi, x);
    return FactorFree(d, H);
  }

  // The backward pass with regularisation μ; false when a Q_uu + μI is not
  // positive definite, or with `stopped` set when the stop is (the gains then
  // part-way). Sums k·Q_u and ½ k·Q_uu k into dV1, dV2.
  static bool BackwardPass(const DdpModel& model, DdpData& d, double mu, double& dV1, double& dV2, bool& stopped) {
    const int n = model.num_dofs(), N = model.horizon(), nx = 2 * n;
    const DdpWeights& w = model.config().weights;
    dV1 = dV2 = 0.0;
    // V_N = ℓ_N.
    for (int i = 0; i < n; ++i) {
      d.Vx_[i] = w.q_terminal[i] * (d.x_(i, N) - d.q_ref(i, N));
      d.Vx_[n + i] = w.qd_terminal[i] * (d.x_(n + i, N) - d.qd_ref(i, N));
    }
    d.Vxx_.setZero();
    d.Vxx_.diagonal().head(n) = w.q_terminal;
    d.Vxx_.diagonal().tail(n) = w.qd_terminal;
    FrameTerm(model, d, N, d.x_.col(N).head(n), true, d.Vx_, d.Vxx_);
    for (int k = N - 1; k >= 0; --k) {
      if (StopRequested(d)) {
        stopped = true;
        return false;
      }
      const MatrixXd& A = d.A_[static_cast<std::size_t>(k)];
      const MatrixXd& B = d.B_[static_cast<std::size_t>(k)];
      MatrixXd& K = d.K_[static_cast<std::size_t>(k)];
      // ℓ_x, ℓ_u, then the Q-function's derivatives.
      for (int i = 0; i < n; ++i) {
        d.Qx_[i] = w.q[i] * (d.x_(i, k) - d.q_ref(i, k));
        d.Qx_[n + i] = w.qd[i] * (d.x_(n + i, k) - d.qd_ref(i, k));
      }
      d.Qu_k_ = w.tau.cwiseProduct(d.u_.col(k) - d.u_ref.col(k));
      d.Qx_.noalias() += A.transpose() * d.Vx_;
      d.Qu_k_.noalias() += B.transpose() * d.Vx_;
      d.VA_.noalias() = d.Vxx_ * A;
      d.VB_.noalias() = d.Vxx_ * B;
      d.Qxx_.noalias() = A.transpose() * d.VA_;
      d.Qxx_.diagonal().head(n) += w.q;
      d.Qxx_.diagonal().tail(n) += w.qd;
      FrameTerm(model, d, k, d.x_.col(k).head(n), true, d.Qx_, d.Qxx_);
      d.Quu_.noalias() = B.transpose() * d.VB_;
      d.Quu_.diagonal() += w.tau;
      d.Qux_.noalias() = B.transpose() * d.VA_;
      d.Qreg_ = d.Quu_;
      d.Qreg_.diagonal().array() += mu;
      // k_k by the box QP on δu, started from the last pass's k_k.
      d.lo_ = model.tau_lower() - d.u_.col(k);
      d.hi_ = model.tau_upper() - d.u_.col(k);
      d.du_ = d.kff_.col(k);
      if (!SolveBoxQp(model, d, d.Qreg_, d.Qu_k_, d.lo_, d.hi_, d.du_)) return false;
      d.kff_.col(k) = d.du_;
      d.Qu_.col(k) = d.Qu_k_;
      // K_k = −(Q_uu + μI)_FF⁻¹ Q_ux,F on the free rows, 0 on the clamped ones.
      K.setZero();
      const int f = static_cast<int>(d.qp_free_.size());
      for (int c = 0; c < nx; ++c) {
        for (int a = 0; a < f; ++a) d.qp_rhs_[a] = -d.Qux_(d.qp_free_[static_cast<std::size_t>(a)], c);
        CholeskySolveInPlace(d.qp_L_, f, d.qp_rhs_.data());
        for (int a = 0; a < f; ++a) K(d.qp_free_[static_cast<std::size_t>(a)], c) = d.qp_rhs_[a];
      }
      // V_x = Q_x + Kᵀ (Q_uu k + Q_u) + Q_uxᵀ k;  V_xx = Q_xx + Kᵀ Q_uu K + Kᵀ Q_ux + Q_uxᵀ K.
      d.Quu_k_vec_.noalias() = d.Quu_ * d.du_;
      dV1 += d.du_.dot(d.Qu_k_);
      dV2 += 0.5 * d.du_.dot(d.Quu_k_vec_);
      d.Quu_k_vec_ += d.Qu_k_;
      d.Vx_ = d.Qx_;
      d.Vx_.noalias() += K.transpose() * d.Quu_k_vec_;
      d.Vx_.noalias() += d.Qux_.transpose() * d.du_;
      d.QuuK_.noalias() = d.Quu_ * K;
      d.Vxx_ = d.Qxx_;
      d.Vxx_.noalias() += K.transpose() * d.QuuK_;
      d.XX_.noalias() = d.Qux_.transpose() * K;
      d.Vxx_ += d.XX_;
      d.Vxx_ += d.XX_.transpose();
      d.XX_ = d.Vxx_.transpose();  // symmetric to round-off; keep it exactly so
      d.Vxx_ += d.XX_;
      d.Vxx_ *= 0.5;
    }
    return true;
  }
};

const DdpResult& SolveDdp(const DdpModel& model, DdpData& d, ConstVecRef q0, ConstVecRef qd0) {
  if (d.model_ != &model) throw std::invalid_argument("ddp: data made for another model");
  const int n = model.num_dofs();
  if (q0.size() != n || qd0.size() != n) throw std::invalid_argument("ddp: expected q0, qd0 of the plant's size");
  const DdpOptions& o = model.config().options;
  DdpResult& r = d.result_;
  r.status = DdpStatus::kMaxIterations;
  r.iterations = 0;
  r.expected_decrease = 0.0;
  r.cost_history.setZero();
  // The first rollout: the policy held by the data (open loop after Reset).
  d.x0_.head(n) = q0;
  d.x0_.tail(n) = qd0;
  double J = DdpPasses::Rollout(model, d, 0.0, true);
  r.cost = J;
  r.cost_history[0] = J;
  if (std::isnan(J)) {  // stopped in the first rollout: the data's nominal stays what it was
    r.status = DdpStatus::kStopped;
    return r;
  }
  if (!std::isfinite(J)) {
    d.Reset();  // a policy that diverged is no warm start
    r.status = DdpStatus::kDiverged;
    return r;
  }
  std::swap(d.x_, d.x_try_);
  std::swap(d.u_, d.u_try_);
  d.kff_.setZero();
  double mu = 0.0;
  // μ after a failure; false past regularization_max.
  const auto increase = [&] {
    mu = std::max(o.regularization_min, mu * o.regularization_factor);
    return mu <= o.regularization_max;
  };
  bool linearized = true;  // by the first rollout
  while (r.iterations < o.max_iterations) {
    if (DdpPasses::StopRequested(d) || (!linearized && !DdpPasses::Linearize(model, d))) {
      r.status = DdpStatus::kStopped;
      break;
    }
    linearized = true;
    double dV1 = 0.0, dV2 = 0.0;
    bool stopped = false;
    if (!DdpPasses::BackwardPass(model, d, mu, dV1, dV2, stopped)) {
      if (stopped) {
        r.status = DdpStatus::kStopped;
        break;
      }
      if (!increase()) {
        r.status = DdpStatus::kNotPositiveDefinite;
        break;
      }
      continue;
    }
    r.expected_decrease = -(dV1 + dV2);
    if (r.expected_decrease <= o.tolerance * J) {
      r.status = DdpStatus::kConverged;
      break;
    }
    bool accepted = false;
    double alpha = 1.0;
    for (int s = 0; s < o.line_search_steps && !accepted; ++s, alpha *= 0.5) {
      const double expected = -(alpha * dV1 + alpha * alpha * dV2);
      const double trial = DdpPasses::Rollout(model, d, alpha, false);
      if (std::isnan(trial)) {  // stopped: the nominal stays the last accepted one
        stopped = true;
        break;
      }
      if (trial < J && J - trial > o.line_search_acceptance * expected) {
        accepted = true;
        J = trial;
      }
    }
    if (stopped) {
      r.status = DdpStatus::kStopped;
      break;
    }
    ++r.iterations;
    r.cost_history[r.iterations] = J;
    if (accepted) {
      std::swap(d.x_, d.x_try_);
      std::swap(d.u_, d.u_try_);
      linearized = false;
      mu /= o.regularization_factor;
      if (mu < o.regularization_min) mu = 0.0;
    } else if (!increase()) {
      r.status = DdpStatus::kLineSearchFailed;
      break;
    }
  }
  r.cost = J;
  r.regularization = mu;
  return r;
}

}  // namespace lagrange
