// A robot driver for lagranged's `external` plant, with MuJoCo standing in for the robot: what you copy to
// connect a real one. Every period it publishes the measured state (state_t) on --state-channel and applies the
// latest torque (torque_t) lagranged sent on --torque-channel; swap the MuJoCo calls marked ROBOT for your robot's
// I/O. lagranged runs the controller (config/panda_external_mujoco.yaml: plant: {type: external, ...}).
//
// Watchdog, the rules lagranged applies to an external controller's torques: a torque is taken only when its
// num_dofs is the robot's, every value is finite and |tau| <= 1e6, its run_id is non-zero and is the sender's it
// locked onto (a second sender is refused while the first streams), its sequence grows, and it is at most
// --torque-timeout old (utime against this clock). With no torque taken for --torque-timeout (and before the
// first) the robot holds: tau = C q̇ + G (MuJoCo's bias force) − B q̇, B = 20/s × diag M(q0), and the state says
// MODE_HOLD. Only the generated types, lcm::LCM, libsodium (bus_signing.hpp) and MuJoCo (libmujoco-dev).
#include <lagrange/state_t.hpp>
#include <lagrange/torque_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mujoco/mujoco.h>
#include <time.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <random>
#include <sstream>
#include "bus_signing.hpp"  // also <chrono>, <cstdlib>, <map>, <string>, <vector>

const char* const kUsage =
    "usage: mujoco_driver --model FILE (MJCF or URDF) [--state-channel PANDA_ROBOT_STATE] [--torque-channel PANDA_ROBOT_TORQUE]\n"
    "                     [--initial Q1,Q2,..] [--period 0.001] [--substeps 1] [--torque-timeout 0.02] [--lcm-url URL]\n"
    "                     [--duration S (0: until SIGINT/SIGTERM)] [--bus-key FILE (else $LAGRANGE_BUS_KEY_FILE)]\n"
    "                     [--bus-domain D (else $LAGRANGE_BUS_DOMAIN, else udpm://GROUP:PORT of the URL)]\n";

volatile std::sig_atomic_t g_stop = 0;

struct Watchdog {
  int n = 0;
  double timeout_s = 0.02;
  BusSigning* bus = nullptr;
  std::int64_t locked_run = 0, last_sequence = 0, last_taken_us = -1;
  std::vector<double> tau;  // the latest torque taken
  long refused = 0;

  void OnTorque(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    lagrange::torque_t t;
    if (!bus->Decode(channel, *rbuf, t)) return void(++refused);
    const std::int64_t now = WallMicros();
    const bool streaming = last_taken_us >= 0 && now - last_taken_us <= timeout_s * 1e6;
    bool ok = t.num_dofs == n && t.run_id != 0 && now - t.utime <= timeout_s * 1e6;
    for (int i = 0; ok && i < n; ++i) ok = std::isfinite(t.tau[i]) && std::abs(t.tau[i]) <= 1e6;
    if (ok && t.run_id != locked_run) {
      ok = !streaming;  // a second sender, while the first streams: refused; otherwise lock onto the new one
      if (ok) locked_run = t.run_id, last_sequence = 0;
    }
    if (!ok || t.sequence <= last_sequence) return void(++refused);
    last_sequence = t.sequence;
    last_taken_us = now;
    tau = t.tau;
  }
  bool Fresh() const { return last_taken_us >= 0 && WallMicros() - last_taken_us <= timeout_s * 1e6; }
};

double Number(const std::string& text) {  // a finite number, or an exception naming the text
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(x)) throw std::invalid_argument("not a number: '" + text + "'");
  return x;
}

int main(int argc, char** argv) try {
  std::map<std::string, std::string> opt = {
      {"--model", ""},   {"--state-channel", "PANDA_ROBOT_STATE"}, {"--torque-channel", "PANDA_ROBOT_TORQUE"},
      {"--initial", ""}, {"--period", "0.001"},                 {"--substeps", "1"},
      {"--lcm-url", ""}, {"--torque-timeout", "0.02"},          {"--duration", "0"},
      {"--bus-key", ""}, {"--bus-domain", ""}};
  for (int i = 1; i < argc; i += 2) {
    if (argv[i] == std::string("--help") || argv[i] == std::string("-h")) return std::fputs(kUsage, stdout), 0;
    if (!opt.count(argv[i]) || i + 1 == argc) throw std::invalid_argument(std::string("bad option ") + argv[i]);
    opt[argv[i]] = argv[i + 1];
  }
  char error[1000] = "";
  mjModel* m = mj_loadXML(opt["--model"].c_str(), nullptr, error, sizeof error);  // ROBOT: your robot's connection
  if (m == nullptr) throw std::runtime_error(opt["--model"] + ": " + error);
  for (int j = 0; j < m->njnt; ++j)
    if (m->jnt_type[j] == mjJNT_FREE || m->jnt_type[j] == mjJNT_BALL)
      throw std::runtime_error(opt["--model"] + ": expected hinge and slide joints only (state_t is joint-space)");
  const int n = m->nv;
  const double period = Number(opt["--period"]);
  const int substeps = static_cast<int>(Number(opt["--substeps"]));
  if (!(period > 0.0) || substeps < 1) throw std::invalid_argument("--period > 0 and --substeps >= 1");
  m->opt.timestep = period / substeps;
  m->opt.enableflags |= mjENBL_ENERGY;
  m->opt.disableflags |= mjDSBL_ACTUATION;  // the torque comes from lagranged, as qfrc_applied
  mjData* d = mj_makeData(m);
  std::stringstream list(opt["--initial"]);
  int k = 0;
  for (std::string item; std::getline(list, item, ',') && k < n;) d->qpos[k++] = Number(item);
  mj_forward(m, d);
  std::vector<double> M(static_cast<std::size_t>(n * n)), brake(static_cast<std::size_t>(n));
  mj_fullM(m, M.data(), d->qM);
  for (int i = 0; i < n; ++i) brake[i] = 20.0 * M[static_cast<std::size_t>(i * n + i)];

  lcm::LCM lcm(opt["--lcm-url"]);  // "" → $LCM_DEFAULT_URL or LCM's default
  if (!lcm.good()) throw std::runtime_error("cannot open LCM '" + opt["--lcm-url"] + "'");
  BusSigning bus(GivenOption(argc, argv, "--bus-key"), GivenOption(argc, argv, "--bus-domain"), opt["--lcm-url"]);
  Watchdog watchdog;
  watchdog.n = n;
  watchdog.timeout_s = Number(opt["--torque-timeout"]);
  watchdog.bus = &bus;
  lcm.subscribe(opt["--torque-channel"], &Watchdog::OnTorque, &watchdog);
  std::signal(SIGINT, [](int) { g_stop = 1; });
  std::signal(SIGTERM, [](int) { g_stop = 1; });

  lagrange::state_t s;
  s.run_id = static_cast<std::int64_t>(std::mt19937_64{std::random_device{}()}() | 1);  // random, never 0
  s.num_dofs = n;
  for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(static_cast<std::size_t>(n), 0.0);
  const double duration = Number(opt["--duration"]);
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  for (s.tick = 0; !g_stop && (duration <= 0.0 || s.tick * period < duration); ++s.tick) {
    while (lcm.handleTimeout(0) > 0) continue;  // every torque that came in since the last tick
    const bool commanded = watchdog.Fresh();
    for (int i = 0; i < n; ++i)  // ROBOT: send the torque to your robot
      d->qfrc_applied[i] = commanded ? watchdog.tau[i] : d->qfrc_bias[i] - brake[i] * d->qvel[i];
    for (int j = 0; j < substeps; ++j) mj_step(m, d);
    mj_forward(m, d);  // ROBOT: read the measured state instead; here q̈ and the energies at the new state
    bool finite = true;
    for (int i = 0; i < n; ++i) finite = finite && std::isfinite(d->qpos[i]) && std::isfinite(d->qvel[i]);
    if (!finite || d->warning[mjWARN_BADQACC].number > 0)
      throw std::runtime_error("MuJoCo's simulation diverged (bad q, q̇ or q̈); stopped");
    s.utime = WallMicros();
    s.t = static_cast<double>(s.tick + 1) * period;
    for (int i = 0; i < n; ++i) {
      s.q[i] = s.q_des[i] = d->qpos[i];
      s.qd[i] = d->qvel[i];
      s.qdd[i] = d->qacc[i];
      s.tau[i] = d->qfrc_applied[i];
    }
    s.kinetic_energy = d->energy[1];
    s.potential_energy = d->energy[0];
    s.controller = commanded ? "external" : "hold";
    s.mode = commanded ? lagrange::state_t::MODE_RUNNING : lagrange::state_t::MODE_HOLD;
    bus.Publish(lcm, opt["--state-channel"], s);
    next.tv_nsec += static_cast<long>(period * 1e9);
    while (next.tv_nsec >= 1'000'000'000) next.tv_nsec -= 1'000'000'000, ++next.tv_sec;
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
  }
  std::fprintf(stderr, "mujoco_driver: stopped after %lld ticks, %ld torques refused\n",
               static_cast<long long>(s.tick), watchdog.refused);
  mj_deleteData(d);
  mj_deleteModel(m);
  return 0;
} catch (const std::exception& e) {  // a bad option or model, no LCM, a bus key that cannot be used
  return std::fprintf(stderr, "mujoco_driver: %s\n%s", e.what(), kUsage), 2;
}
