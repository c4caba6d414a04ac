#include "tests/daemon/external_support.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string_view>

#include "sim/scene_channels.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange::external_test {
namespace {

template <class T>
bool Decode(const std::uint8_t* data, std::size_t size, T& out) {
  return out.decode(data, 0, static_cast<int>(size)) >= 0;
}

}  // namespace

std::string Config(const std::string& name) { return std::string(LAGRANGE_SOURCE_DIR) + "/config/" + name; }

VectorXd Vec(const std::vector<double>& v) {
  return Eigen::Map<const VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

bool Finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}
bool Finite(const state_t& s) {
  return Finite(s.q) && Finite(s.qd) && Finite(s.qdd) && Finite(s.tau) && Finite(s.q_des) && Finite(s.qd_des) &&
         std::isfinite(s.t) && std::isfinite(s.kinetic_energy) && std::isfinite(s.potential_energy);
}

bool AllZero(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::abs(x) <= kExact; });
}

Scene ArmScene(const std::string& controller, const std::string& extra, const std::string& limits) {
  std::string text =
      "period: 0.001\n"
      "instances:\n"
      "  - name: arm\n"
      "    plant: {type: arm2, params: {m1: 1.0, m2: 0.8, L1: 0.6, L2: 0.5, g: 9.81}}\n"
      "    initial: {q: [0.7853981633974483, 0.0]}\n"
      "    integrator: {type: rk4}\n"
      "    controllers: [{type: gravity-compensation, kp: [60, 20], kd: [8, 3]}]\n";
  text += "    controller: " + controller + "\n";
  text += "    torque_limits: " + limits + "\n";
  return ParseScene(text + extra, "inline");
}

torque_t MakeTorque(std::vector<double> tau, std::int64_t sequence, std::int64_t utime, std::int64_t run_id) {
  torque_t t;
  t.utime = utime;
  t.run_id = run_id;
  t.sequence = sequence;
  t.state_tick = -1;
  t.num_dofs = static_cast<std::int32_t>(tau.size());
  t.tau = std::move(tau);
  return t;
}

state_t MakeState(std::vector<double> q, std::vector<double> qd, std::int64_t tick, std::int64_t utime,
                  std::int64_t run_id) {
  state_t s;
  s.utime = utime;
  s.run_id = run_id;
  s.tick = tick;
  s.t = 0.0;
  s.num_dofs = static_cast<std::int32_t>(q.size());
  const std::vector<double> zeros(q.size(), 0.0);
  s.qdd = s.tau = s.q_des = s.qd_des = zeros;
  s.q = std::move(q);
  s.qd = std::move(qd);
  s.kinetic_energy = s.potential_energy = 0.0;
  s.mode = state_t::MODE_RUNNING;
  return s;
}

void PostMeasured(Runtime& runtime, const VectorXd& q, const VectorXd& qd, std::int64_t tick, Nanoseconds arrived) {
  MeasuredMessage& m = runtime.channels(0).measured.back();
  m.q = q;
  m.qd = qd;
  m.tick = tick;
  m.run_id = kPlantRunId;
  m.sent = arrived;
  m.arrived = arrived;
  runtime.channels(0).measured.Publish();
}

Daemon::Daemon(Scene scene, const std::string& prefix, std::int64_t run_id)
    : run_id_(run_id),
      scene_(std::move(scene)),
      runtime_(scene_, BuildOptions::Prefixed(prefix)),
      channels_(runtime_.model().instances[0].channels),
      receiver_(input_, nullptr, output_, runtime_, clock_, stats_, SetpointAge::kWall, run_id),
      ring_(kRing, runtime_.MakeRecord()),
      loop_(runtime_, clock_, {kMs, OverrunPolicy::kSkip, 0}, ring_),
      publisher_(output_, runtime_, ring_, loop_, stats_, -1, run_id) {
  output_.Subscribe(channels_.state, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
    state_t s;
    if (!Decode(d, n, s) || s.run_id != run_id_) return;
    all_finite_ = all_finite_ && Finite(s);
    states_.push_back(std::move(s));
  });
  if (!channels_.torque_out.empty()) {
    output_.Subscribe(channels_.torque_out, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
      torque_t t;
      if (!Decode(d, n, t) || t.run_id != run_id_) return;
      all_finite_ = all_finite_ && Finite(t.tau);
      torques_.push_back(std::move(t));
    });
  }
  output_.Subscribe(channels_.reply, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
    reply_t r;
    if (Decode(d, n, r)) replies_.push_back(r);
  });
  output_.Subscribe(runtime_.model().status_channel, [this](std::string_view, const std::uint8_t* d, std::size_t n) {
    status_t s;
    if (Decode(d, n, s) && s.run_id == run_id_) last_status_ = s;
  });
}

void Daemon::Receive() {
  for (;;) {
    const std::int64_t before = input_.stats().received;
    receiver_.Poll(0);
    if (input_.stats().received == before) return;
  }
}

void Daemon::Ticks(int n) {
  Receive();
  while (n > 0) {
    const int chunk = std::min(n, kRing / 2);
    std::atomic<bool> stop{false};
    loop_.Run(stop, loop_.ticks() + chunk);
    publisher_.Drain();
    while (output_.Drain() > 0) {
    }
    n -= chunk;
  }
}

void Daemon::SendCommand(int8_t kind, std::int64_t request_id, const std::string& controller) {
  input_.PublishMessage(channels_.command, testing::MakeCommand(kind, request_id, 0, controller));
}

void Link(Daemon& from, const std::string& channel, Daemon& to) {
  from.output().Subscribe(channel, [&to, channel](std::string_view, const std::uint8_t* d, std::size_t n) {
    to.input().Publish(channel, d, n);
  });
}

VectorXd ExternalControllerLoop::Gravity(const VectorXd& q) {
  VectorXd g(q.size());
  PlantModel& model = arm_.runtime().instance(0).model();
  model.dynamics().ComputeGravityForce(model.data(), q, g);
  return g;
}

}  // namespace lagrange::external_test
