// A joint-space impedance controller for lagranged's `external` controller:
//   tau = K (q* − q) − D q̇   (N·m; lagranged adds G(q) with compensate_gravity: true)
// answering every <NAME>_STATE with one torque_t on <NAME>_TORQUE, so it runs at the daemon's rate.
// Only the generated types, lcm::LCM and libsodium (bus_signing.hpp, signed traffic): copy it, change the law.
// LCM 1.3.1 crashes on forged fragments (docs/lcm-fragment-bug.md): use a bus only you reach (ttl=0), and a key.
// It names the run it follows and, at the end, what it sent (exit 0); no state within --wait or none applied: exit 1.
#include <lagrange/state_t.hpp>
#include <lagrange/torque_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include <cctype>
#include <cinttypes>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <random>
#include <set>
#include <sstream>
#include "bus_signing.hpp"  // also <chrono>, <cstdlib>, <map>, <string>, <vector>

const char* const kUsage =
    "usage: impedance_client --target Q1,Q2,.. [--stiffness 40] [--damping 8] [--instance arm] [--lcm-url URL]\n"
    "         [--duration S (0: until SIGINT or SIGTERM)] [--wait 3] [--bus-key FILE (else $LAGRANGE_BUS_KEY_FILE)]\n"
    "         [--bus-domain D (else $LAGRANGE_BUS_DOMAIN, else udpm://GROUP:PORT of the URL)]\n";
volatile std::sig_atomic_t stop = 0;

struct Impedance {
  lcm::LCM* lcm;
  std::string state_channel, torque_channel;
  std::vector<double> target;                   // q*, rad or m
  double K, D;                                  // N·m/rad, N·m·s/rad
  BusSigning* bus;                              // unsigned without a key
  lagrange::torque_t out{};                     // run_id: this stream's; sequence: +1 per torque, from 1
  std::int64_t locked_run = 0, last_heard = 0;  // the lagranged run followed, and when (µs) it was last heard
  std::int64_t unverified = 0, applied = 0;     // states BusSigning refused; states with our torque applied
  std::set<std::string> heard{};                // state channels heard (for a mistyped --instance)
  std::string error{};                          // set: main stops and reports it

  void OnState(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if (channel != state_channel) return void(heard.size() < 8 && heard.insert(channel).second);
    lagrange::state_t s;
    if (!bus->Decode(channel, *rbuf, s)) return void(++unverified);  // with a key: only a key holder's, each once
    const bool restarted = locked_run != 0 && s.run_id != locked_run && WallMicros() - last_heard > 500'000;
    if (locked_run == 0 || restarted)  // first, or a new run after 0.5 s of silence (a restarted lagranged)
      std::fprintf(stderr, "impedance_client: following %slagranged run %016" PRIx64 " on %s\n",
                   restarted ? "a new " : "", static_cast<std::uint64_t>(locked_run = s.run_id), channel.c_str());
    if (s.run_id != locked_run) return;
    last_heard = WallMicros();
    if (s.num_dofs != static_cast<int>(target.size()))
      return void(error = channel + " has " + std::to_string(s.num_dofs) + " joints; --target gives " +
                          std::to_string(target.size()));
    applied += out.sequence > 0 && s.mode == lagrange::state_t::MODE_RUNNING && s.controller == "external";
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
  std::map<std::string, std::string> opt = {{"--lcm-url", ""},     {"--instance", "arm"}, {"--target", ""},
                                            {"--stiffness", "40"}, {"--damping", "8"},    {"--duration", "0"},
                                            {"--wait", "3"},       {"--bus-key", ""},     {"--bus-domain", ""}};
  for (int i = 1; i < argc; i += 2) {
    if (argv[i] == std::string("--help") || argv[i] == std::string("-h")) return std::fputs(kUsage, stdout), 0;
    if (argv[i] == std::string("--url")) throw std::invalid_argument("--url is now --lcm-url, as in lagrangectl");
    if (!opt.count(argv[i]) || i + 1 == argc) throw std::invalid_argument(std::string("bad option ") + argv[i]);
    opt[argv[i]] = argv[i + 1];
  }
  std::vector<double> q_target;
  std::stringstream list(opt["--target"]);
  for (std::string item; std::getline(list, item, ',');) q_target.push_back(Number(item));
  if (q_target.empty()) throw std::invalid_argument("--target a,b,.. is required");
  lcm::LCM lcm(opt["--lcm-url"]);  // "" → $LCM_DEFAULT_URL or LCM's default
  if (!lcm.good()) throw std::invalid_argument("cannot open LCM '" + opt["--lcm-url"] + "'");
  std::string name = opt["--instance"];
  for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  BusSigning bus(GivenOption(argc, argv, "--bus-key"), GivenOption(argc, argv, "--bus-domain"), opt["--lcm-url"]);
  Impedance law{&lcm, name + "_STATE", name + "_TORQUE", q_target, Number(opt["--stiffness"]), Number(opt["--damping"]),
                &bus};
  law.out.run_id = static_cast<std::int64_t>(std::mt19937_64{std::random_device{}()}() | 1);  // random, never 0
  lcm.subscribe(".*_STATE", &Impedance::OnState, &law);
  for (const int s : {SIGINT, SIGTERM}) std::signal(s, [](int) { stop = 1; });
  const double duration = Number(opt["--duration"]), wait = Number(opt["--wait"]);
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  while (!stop && law.error.empty() && (duration <= 0.0 || elapsed() < duration) &&
         (law.locked_run || elapsed() < wait))
    if (lcm.handleTimeout(100) < 0 && !stop) throw std::runtime_error("LCM stopped receiving");
  if (!law.error.empty()) return std::fprintf(stderr, "impedance_client: %s\n", law.error.c_str()), 2;
  std::string heard;  // no daemon there, or not this instance, or not this key
  for (const std::string& c : law.heard) heard += (heard.empty() ? "; heard only " : ", ") + c;
  if (law.unverified) heard = "; its states do not verify with this key and bus domain (--bus-key, --bus-domain)";
  const std::string url = opt["--lcm-url"].empty() ? "LCM's default URL ($LCM_DEFAULT_URL)" : opt["--lcm-url"];
  if (!law.locked_run)
    throw std::runtime_error("no " + law.state_channel + " within " + opt["--wait"] + " s on " + url + heard);
  std::printf("impedance_client: sent %" PRId64 " torques to %s answering lagranged run %016" PRIx64 "\n",
              law.out.sequence, law.torque_channel.c_str(), static_cast<std::uint64_t>(law.locked_run));
  if (!law.applied)
    throw std::runtime_error("no state showed them applied: is " + opt["--instance"] + "'s controller external? " +
                             "(lagrangectl command " + opt["--instance"] + " controller external)");
  return 0;
} catch (const std::invalid_argument& e) {  // a bad option, number or key file, no LCM
  return std::fprintf(stderr, "impedance_client: %s\n%s", e.what(), kUsage), 2;
} catch (const std::exception& e) {  // no state heard, none applied
  return std::fprintf(stderr, "impedance_client: %s\n", e.what()), 1;
}
