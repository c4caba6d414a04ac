// The words of `lagrangectl command` and lagrange.Client.command
// (protocol/command_words.hpp): every verb makes its command_t, and every
// word that is not one, or the wrong number of them, is refused in one line
// naming what was expected, before anything is sent.

#include "protocol/command_words.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace lagrange {
namespace {

std::string Refusal(const std::vector<std::string>& words) {
  try {
    CommandFromWords(words);
  } catch (const CommandWordsError& e) {
    return e.what();
  }
  return "";
}

TEST(CommandWords, EveryVerbMakesItsCommand) {
  EXPECT_EQ(CommandFromWords({"estop"}).command, command_t::ESTOP);
  EXPECT_EQ(CommandFromWords({"clear"}).command, command_t::CLEAR_ESTOP);
  EXPECT_EQ(CommandFromWords({"gains"}).command, command_t::SET_GAINS);
  const command_t c = CommandFromWords({"controller", "pd"});
  EXPECT_EQ(c.command, command_t::SWITCH_CONTROLLER);
  EXPECT_EQ(c.controller, "pd");
  const command_t e = CommandFromWords({"effect", "damping", "on"});
  EXPECT_EQ(e.command, command_t::SET_EFFECT);
  EXPECT_EQ(e.setting, "damping");
  EXPECT_TRUE(e.on);
  EXPECT_FALSE(CommandFromWords({"forces", "off"}).on);
  const command_t i = CommandFromWords({"integrator", "dopri5"});
  EXPECT_EQ(i.setting, "dopri5");
  EXPECT_EQ(i.substeps, 0);  // 0: the daemon's default
  EXPECT_EQ(CommandFromWords({"method", "lagrangian"}).command, command_t::SET_METHOD);
}

TEST(CommandWords, RefusesWhatIsNotACommandNamingWhatWasExpected) {
  EXPECT_EQ(Refusal({"explode"}), "unknown action 'explode' (expected " + CommandVerbs() + ")");
  EXPECT_EQ(Refusal({}), "no action (expected " + CommandVerbs() + ")");
  EXPECT_EQ(Refusal({"estop", "now"}), "estop: takes no arguments");
  EXPECT_EQ(Refusal({"controller"}), "controller: expected one controller name, got 0 words");
  EXPECT_EQ(Refusal({"effect", "damping"}), "effect: expected an effect NAME and on or off, got 1 word");
  EXPECT_EQ(Refusal({"effect", "damping", "maybe"}), "effect damping: expected on or off, got 'maybe'");
  EXPECT_NE(Refusal({"integrator", "rk5"}).find("unknown integrator 'rk5' (expected "), std::string::npos);
  EXPECT_NE(Refusal({"effect", "wind", "on"}).find("unknown effect 'wind' (expected "), std::string::npos);
  EXPECT_NE(Refusal({"method", "magic"}).find("unknown method 'magic' (expected "), std::string::npos);
  EXPECT_EQ(Refusal({"forces", "1"}), "forces: expected on or off, got '1'");
  // What a refusal prints of a word is escaped: it cannot break the line.
  EXPECT_EQ(Refusal({"x\ny"}).find('\n'), std::string::npos);
}

}  // namespace
}  // namespace lagrange
