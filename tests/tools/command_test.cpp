// lagrangectl command's new forms refuse bad arguments before anything goes
// on the bus: names are checked against the plant's own tables, numbers as
// the daemon checks them. No daemon runs here: an argument that got past
// the checks would end in "no state from instance" (exit 1) instead.

#include <gtest/gtest.h>

#include "tests/support/process.hpp"
#include "tests/tools/run_ctl.hpp"

namespace lagrange {
namespace {

using testing::RunCtl;

struct Refusal {
  std::vector<std::string> action;  // after "command arm"
  std::string what;                 // in the one line on stderr
};

void ExpectRefused(const Refusal& c) {
  std::vector<std::string> args = {"command", "arm"};
  args.insert(args.end(), c.action.begin(), c.action.end());
  for (const char* bus : {"--lcm-url", "inprocess://", "--wait", "0.2"}) args.push_back(bus);
  const auto r = RunCtl(args);
  EXPECT_EQ(r.status, 2) << r.err;
  ASSERT_EQ(testing::Lines(r.err).size(), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("lagrangectl command: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(c.what), std::string::npos) << "got: " << r.err << "expected: " << c.what;
  EXPECT_EQ(r.out, "");
}

TEST(CommandArguments, UnknownIntegratorEffectOrMethodNamesListTheValidOnes) {
  for (const Refusal& c : std::vector<Refusal>{
           {{"integrator", "euler"},
            "unknown integrator 'euler' (expected explicit-euler|semi-implicit-euler|rk4|dopri5|variational)"},
           {{"effect", "wind", "on"},
            "unknown effect 'wind' (expected gravity|coriolis|damping|friction|limits|saturation|disturbance)"},
           {{"method", "fast"}, "unknown method 'fast' (expected closed-form, lagrangian or recursive)"},
           {{"integrator", "RK4"}, "unknown integrator 'RK4'"},  // names are exact
           {{"fly"},
            "unknown action 'fly' (expected controller, gains, reset, pause, resume, estop, clear, "
            "integrator, effect, method or forces)"},
       }) {
    ExpectRefused(c);
  }
}

TEST(CommandArguments, OnOffAndTheNumberOfWordsAreChecked) {
  for (const Refusal& c : std::vector<Refusal>{
           {{"effect", "friction", "maybe"}, "effect friction: expected on or off, got 'maybe'"},
           {{"forces", "yes"}, "forces: expected on or off, got 'yes'"},
           {{"forces"}, "forces: expected on or off, got 0 words"},
           {{"effect", "friction"}, "effect: expected an effect NAME and on or off, got 1 word"},
           {{"integrator"}, "integrator: expected one integrator TYPE, got 0 words"},
           {{"method", "recursive", "now"}, "method: expected one method NAME, got 2 words"},
       }) {
    ExpectRefused(c);
  }
}

// Sub-steps 1..1000 and tolerances finite and > 0, as the daemon's
// CheckIntegratorConfig has them; each refusal names the option and its value.
TEST(CommandArguments, IntegratorNumbersOutOfRangeAreRefusedNamingTheOption) {
  for (const Refusal& c : std::vector<Refusal>{
           {{"integrator", "rk4", "--substeps", "0"}, "--substeps 0: expected 1 to 1000"},
           {{"integrator", "rk4", "--substeps", "1001"}, "--substeps 1001: expected 1 to 1000"},
           {{"integrator", "dopri5", "--rtol", "-1"}, "--rtol -1: expected a finite number > 0"},
           {{"integrator", "dopri5", "--atol", "0"}, "--atol 0: expected a finite number > 0"},
           {{"integrator", "dopri5", "--rtol", "inf"}, "--rtol inf: expected a finite number > 0"},
           {{"integrator", "dopri5", "--max-steps", "0"}, "--max-steps 0: expected 1 to"},
           {{"integrator", "rk4", "--rtol", "1e-6"}, "--rtol, --atol, --max-steps: only for dopri5"},
           {{"reset", "--substeps", "2"}, "--substeps, --rtol, --atol, --max-steps: only for integrator"},
       }) {
    ExpectRefused(c);
  }
}

TEST(CommandArguments, WellFormedFormsGetPastTheChecksToTheBus) {
  for (const std::vector<std::string>& action : std::vector<std::vector<std::string>>{
           {"integrator", "rk4", "--substeps", "4"},
           {"integrator", "dopri5", "--rtol", "1e-6", "--atol", "1e-9", "--max-steps", "200"},
           {"integrator", "variational"},
           {"effect", "coriolis", "off"},
           {"method", "recursive"},
           {"forces", "on"},
       }) {
    std::vector<std::string> args = {"command", "arm"};
    args.insert(args.end(), action.begin(), action.end());
    for (const char* bus : {"--lcm-url", "inprocess://", "--wait", "0.2"}) args.push_back(bus);
    const auto r = RunCtl(args);
    EXPECT_EQ(r.status, 1) << action[0] << ": " << r.err;  // no daemon on this bus
    EXPECT_NE(r.err.find("no state from instance 'arm'"), std::string::npos) << r.err;
  }
}

// Issue 32: an empty --bus-key (an unset variable in a script) sent the
// command unsigned; an empty --bus-domain would fall back to the bus's own.
// Both are refused before anything goes on the bus.
TEST(CommandArguments, AnEmptyBusKeyPathOrBusDomainIsRefusedNotSentUnsigned) {
  ExpectRefused({{"estop", "--bus-key", ""}, "bus key '': an empty path (an unset variable in a unit or script?)"});
  ExpectRefused({{"estop", "--bus-domain", ""}, "--bus-domain: an empty bus domain"});
}

}  // namespace
}  // namespace lagrange
