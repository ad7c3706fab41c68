// Tests of the progress line's estimates (cli/progress.hpp): contraction rate and time left.
#include <gtest/gtest.h>

#include <cmath>

#include "progress.hpp"

namespace {

using namespace pardel;
using namespace pardel::cli;

IterationRecord record(long iteration, double residual, double seconds, int N = 100) {
  IterationRecord r;
  r.iteration = iteration;
  r.residual = residual;
  r.seconds = seconds;
  r.N = N;
  return r;
}

TEST(Progress, RateIsTheGeometricMeanContraction) {
  EXPECT_NEAR(contraction_rate(record(10, 1e-2, 1), record(20, 1e-3, 2)), std::pow(0.1, 0.1), 1e-15);
  EXPECT_TRUE(std::isnan(contraction_rate(record(10, 1e-2, 1), record(10, 1e-3, 2))));
  EXPECT_TRUE(std::isnan(contraction_rate(record(10, 1e-2, 1), record(20, 1e-3, 2, 120))));  // N changed
}

TEST(Progress, TimeLeftFollowsTheRate) {
  // A factor 10 per 10 iterations and 0.1 s per iteration: from 1e-3 to 1e-10 takes 70 more iterations.
  EXPECT_NEAR(eta_seconds(record(10, 1e-2, 1), record(20, 1e-3, 2), 1e-10), 7.0, 1e-9);
  EXPECT_TRUE(std::isnan(eta_seconds(record(10, 1e-3, 1), record(20, 1e-2, 2), 1e-10)));  // growing
  EXPECT_EQ(eta_seconds(record(10, 1e-2, 1), record(20, 1e-11, 2), 1e-10), 0.0);
}

}  // namespace
