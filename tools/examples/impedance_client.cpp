// A joint-space impedance controller for lagranged's `external` controller:
//   tau = K (q* − q) − D q̇   (N·m; lagranged adds G(q) with compensate_gravity: true)
// answering every <NAME>_STATE with one torque_t on <NAME>_TORQUE, so it runs at the daemon's rate.
// Only the generated types, lcm::LCM and libsodium (bus_signing.hpp, signed traffic): copy it, change the law.
// LCM 1.3.1 crashes on forged fragments (docs/lcm-fragment-bug.md): use a bus only you reach (ttl=0), and a key.
#include <lagrange/state_t.hpp>
#include <lagrange/torque_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include "bus_signing.hpp"  // also <chrono>, <cstdlib>, <map>, <string>, <vector>

const char* const kUsage =
    "usage: impedance_client --target Q1,Q2,.. [--stiffness 40] [--damping 8] [--instance arm] [--url URL]\n"
    "                        [--duration S (0: until killed)] [--bus-key FILE (else $LAGRANGE_BUS_KEY_FILE)]\n"
    "                        [--bus-domain D (else $LAGRANGE_BUS_DOMAIN, else udpm://GROUP:PORT of the URL)]\n";

struct Impedance {
  lcm::LCM* lcm;
  std::string torque_channel;
  std::vector<double> target;                   // q*, rad or m
  double K, D;                                  // N·m/rad, N·m·s/rad
  BusSigning* bus;                              // unsigned without a key
  lagrange::torque_t out;                       // run_id: this stream's; sequence: +1 per torque, from 1
  std::int64_t locked_run = 0, last_heard = 0;  // the lagranged run followed, and when (µs) it was last heard
  std::string error;                            // set: main stops and reports it

  void OnState(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    lagrange::state_t s;
    if (!bus->Decode(channel, *rbuf, s)) return;  // with a key: only a key holder's, and each once
    if (locked_run != 0 && s.run_id != locked_run && WallMicros() - last_heard > 500'000)  // silent 0.5 s: restarted?
      std::fputs("impedance_client: following a new lagranged run\n", stderr), locked_run = 0;
    if (locked_run == 0) locked_run = s.run_id;
    if (s.run_id != locked_run) return;
    last_heard = WallMicros();
    if (s.num_dofs != static_cast<int>(target.size()))
      return void(error = channel + " has " + std::to_string(s.num_dofs));
    out.num_dofs = s.num_dofs;
    out.tau.resize(target.size());
    for (std::size_t i = 0; i < target.size(); ++i) {
      if (!std::isfinite(s.q[i]) || !std::isfinite(s.qd[i])) return;
      out.tau[i] = K * (target[i] - s.q[i]) - D * s.qd[i];
    }
    ++out.sequence;
    out.state_tick = s.tick;
    out.utime = WallMicros();
    bus->Publish(*lcm, torque_channel, out);
  }
};

double Number(const std::string& text) {  // a finite number, or an exception naming the text
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(x)) throw std::invalid_argument("not a number: '" + text + "'");
  return x;
}

int main(int argc, char** argv) try {
  std::map<std::string, std::string> opt = {{"--url", ""},         {"--instance", "arm"}, {"--target", ""},
                                            {"--stiffness", "40"}, {"--damping", "8"},    {"--duration", "0"},
                                            {"--bus-key", ""},     {"--bus-domain", ""}};
  for (int i = 1; i < argc; i += 2) {
    if (argv[i] == std::string("--help") || argv[i] == std::string("-h")) return std::fputs(kUsage, stdout), 0;
    if (!opt.count(argv[i]) || i + 1 == argc) throw std::invalid_argument(std::string("bad option ") + argv[i]);
    opt[argv[i]] = argv[i + 1];
  }
  std::vector<double> q_target;
  std::stringstream list(opt["--target"]);
  for (std::string item; std::getline(list, item, ',');) q_target.push_back(Number(item));
  if (q_target.empty()) throw std::invalid_argument("--target a,b,.. is required");
  lcm::LCM lcm(opt["--url"]);  // "" → $LCM_DEFAULT_URL or LCM's default
  if (!lcm.good()) throw std::runtime_error("cannot open LCM '" + opt["--url"] + "'");
  std::string name = opt["--instance"];
  for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  BusSigning bus(GivenOption(argc, argv, "--bus-key"), GivenOption(argc, argv, "--bus-domain"), opt["--url"]);
  Impedance law{&lcm, name + "_TORQUE", q_target, Number(opt["--stiffness"]), Number(opt["--damping"]), &bus, {}, 0, 0,
                {}};
  law.out.run_id = static_cast<std::int64_t>(std::mt19937_64{std::random_device{}()}() | 1);  // random, never 0
  lcm.subscribe(name + "_STATE", &Impedance::OnState, &law);
  const double duration = Number(opt["--duration"]);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(duration);
  while (law.error.empty() && (duration <= 0.0 || std::chrono::steady_clock::now() < end) &&
         lcm.handleTimeout(100) >= 0)
    continue;
  if (!law.error.empty())
    throw std::runtime_error(law.error + " joints; --target gives " + std::to_string(q_target.size()));
  return 0;
} catch (const std::exception& e) {  // a bad option or number, no LCM, a bus key that cannot be used, wrong targets
  return std::fprintf(stderr, "impedance_client: %s\n%s", e.what(), kUsage), 2;
}
