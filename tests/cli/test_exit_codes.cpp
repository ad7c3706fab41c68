// Tests of the exit status of `pardel solve` per termination (cli/exit_codes.hpp).
#include <gtest/gtest.h>

#include "exit_codes.hpp"

namespace {

using namespace pardel;
using namespace pardel::cli;

TEST(ExitCodes, DistinctPerTermination) {
  EXPECT_EQ(exit_code(Termination::converged), 0);
  EXPECT_EQ(exit_code(Termination::invalid_input), 2);
  EXPECT_EQ(exit_code(Termination::max_iterations), 3);
  EXPECT_EQ(exit_code(Termination::diverged), 4);
  EXPECT_EQ(exit_code(Termination::non_finite), 5);
  EXPECT_EQ(exit_code(Termination::interrupted), 6);
  EXPECT_EQ(exit_code(Termination::stalled), 7);
}

}  // namespace
