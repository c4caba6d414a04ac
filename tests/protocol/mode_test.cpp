// Modes on the wire (protocol/mode.hpp): each state_t.MODE_* has its name,
// and a value no mode has, as a hostile packet may carry, is "?".

#include "protocol/mode.hpp"

#include <gtest/gtest.h>
#include <lagrange/state_t.hpp>

#include <string>

namespace lagrange {
namespace {

TEST(Mode, EveryWireModeHasTheNameOfItsMode) {
  EXPECT_EQ(std::string(ModeName(state_t::MODE_RUNNING)), "running");
  EXPECT_EQ(std::string(ModeName(state_t::MODE_HOLD)), "hold");
  EXPECT_EQ(std::string(ModeName(state_t::MODE_FAULT)), "fault");
  EXPECT_EQ(std::string(ModeName(state_t::MODE_PAUSED)), "paused");
  EXPECT_EQ(std::string(ModeName(state_t::MODE_ESTOP)), "estop");
  EXPECT_EQ(std::string(ModeName(state_t::MODE_STOPPED)), "stopped");
  EXPECT_EQ(std::string(ModeName(state_t::MODE_WAITING)), "waiting");
  for (std::int8_t m = state_t::MODE_RUNNING; m <= state_t::MODE_WAITING; ++m) {
    EXPECT_EQ(ToString(static_cast<Mode>(m)), ModeName(m));
  }
}

TEST(Mode, AValueNoModeHasIsAQuestionMark) {
  for (const std::int8_t m : {std::int8_t{-1}, std::int8_t{7}, std::int8_t{127}, std::int8_t{-128}}) {
    EXPECT_EQ(std::string(ModeName(m)), "?") << int{m};
  }
}

}  // namespace
}  // namespace lagrange
