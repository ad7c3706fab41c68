/**
 * @file test_invariant.cpp
 * The internal invariant macro (runtime/src/invariant.hpp): checked where PARDEL_CHECK_INVARIANTS
 * is defined, a failure names the file, the line, the condition and what it means, and aborts; a
 * holding invariant does nothing. Also the invariants of the refinement levels on a problem
 * whose knots move the levels.
 */
#define PARDEL_CHECK_INVARIANTS 1
#include "invariant.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "levels.hpp"
#include "hand_models.hpp"

namespace {

TEST(Invariant, AHoldingInvariantDoesNothing) {
  int evaluated = 0;
  PARDEL_INVARIANT(++evaluated == 1, "evaluated once");
  EXPECT_EQ(evaluated, 1);
}

TEST(InvariantDeathTest, AFailureNamesTheLineTheConditionAndWhatItMeans) {
  EXPECT_DEATH(PARDEL_INVARIANT(1 + 1 == 3, "arithmetic holds"),
               "pardel: internal error at .*test_invariant.cpp:[0-9]+: arithmetic holds \\(1 \\+ 1 == 3 does not hold\\)");
}

TEST(Invariant, RefinementLevelsGrowToTheGridThroughKnots) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.params = {1.0};
  p.T = 3;
  p.N = 3003;  // the automatic method's next grid, 751, moves to 753 to hold the knot
  p.q0 = {0};
  p.qN = {1};
  p.knots = {{1.0, {0.5}}};  // on a node only where 3 divides N
  pardel::Options automatic;
  const std::vector<int> levels = pardel::detail::refinement_levels(p, automatic, true);
  EXPECT_EQ(levels, (std::vector<int>{753, 3003}));  // 3003 / 4 rounded up is 751: not a multiple of 3
  EXPECT_EQ(levels.back(), p.N);
  for (std::size_t l = 0; l < levels.size(); ++l) {
    EXPECT_EQ(levels[l] % 3, 0) << "level " << levels[l] << " holds the knot on a node";
    if (l > 0) EXPECT_LT(levels[l - 1], levels[l]);
  }
}

}  // namespace
