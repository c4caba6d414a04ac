// The program that compiles the test programs' precompiled header (tests/CMakeLists.txt): a test program itself,
// so that the header is compiled with the flags of one (-fPIE); GCC refuses a header compiled for a library (-fPIC).
#include <gtest/gtest.h>

TEST(PrecompiledHeader, IsBuiltWithTheTestProgramsFlags) { EXPECT_EQ(sizeof(double), 8u); }
