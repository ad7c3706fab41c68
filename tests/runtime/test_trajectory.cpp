/**
 * @file test_trajectory.cpp
 * Initial guesses and resampling: the straight line and the polyline hit the boundary values;
 * resampling reproduces linear data exactly (order 1) and cubic polynomials exactly when
 * derivatives are stored (order 2, cubic Hermite), keeps the end times and boundary nodes.
 */
#include <gtest/gtest.h>

#include <cmath>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

TEST(Trajectory, LinearGuessInterpolatesBoundaries) {
  pardel::Problem p;
  p.model = &hand::spline;
  p.t0 = 1;
  p.T = 2;
  p.N = 8;
  p.q0 = {1.0, 2.0};
  p.qN = {3.0, -2.0};
  const auto tr = pardel::linear_guess(p);
  ASSERT_EQ(tr.N, 8);
  ASSERT_EQ(tr.dim, 2);
  EXPECT_EQ(tr.t.front(), 1.0);
  EXPECT_EQ(tr.t.back(), 3.0);
  EXPECT_EQ(tr.node(0)[0], 1.0);
  EXPECT_EQ(tr.node(8)[1], -2.0);
  EXPECT_NEAR(tr.node(4)[0], 2.0, 1e-15);
  EXPECT_NEAR(tr.node(2)[1], 1.0, 1e-15);
}

TEST(Trajectory, PolylineGuessVisitsThePoints) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.N = 10;
  p.q0 = {0.0};
  p.qN = {0.0};
  const auto tr = pardel::polyline_guess(p, {{5.0}, {1.0}, {7.0}});
  EXPECT_EQ(tr.node(0)[0], 0.0);  // first point replaced by the boundary
  EXPECT_NEAR(tr.node(5)[0], 1.0, 1e-15);
  EXPECT_EQ(tr.node(10)[0], 0.0);
  EXPECT_NEAR(tr.node(3)[0], 0.6, 1e-15);  // 3/5 of the way from the boundary to the point 1
}

TEST(Trajectory, ResampleIsExactForLinearDataOfOrderOne) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.T = 3;
  p.N = 7;
  p.q0 = {1.0};
  p.qN = {-2.0};
  const auto coarse = pardel::linear_guess(p);
  const auto fine = pardel::resample(p, coarse, 19);
  ASSERT_EQ(fine.N, 19);
  for (int k = 0; k <= 19; ++k) EXPECT_NEAR(fine.node(k)[0], 1.0 - 3.0 * k / 19, 1e-14);
  EXPECT_NEAR(fine.t.back(), 3.0, 1e-15);
}

TEST(Trajectory, ResampleIsExactForCubicsWithStoredDerivatives) {
  pardel::Problem p;
  p.model = &hand::spline;
  p.T = 2;
  p.N = 5;
  auto f = [](double t) { return 1 - t + 0.5 * t * t * t; };
  auto df = [](double t) { return -1 + 1.5 * t * t; };
  pardel::Trajectory coarse;
  coarse.N = 5;
  coarse.dim = 2;
  for (int k = 0; k <= 5; ++k) {
    const double t = 2.0 * k / 5;
    coarse.t.push_back(t);
    coarse.q.push_back(f(t));
    coarse.q.push_back(df(t));
  }
  p.q0 = {f(0), df(0)};
  p.qN = {f(2), df(2)};
  const auto fine = pardel::resample(p, coarse, 13);
  for (int k = 0; k <= 13; ++k) {
    const double t = 2.0 * k / 13;
    EXPECT_NEAR(fine.t[k], t, 1e-14);
    EXPECT_NEAR(fine.node(k)[0], f(t), 1e-13) << k;
    EXPECT_NEAR(fine.node(k)[1], df(t), 1e-12) << k;
  }
}

}  // namespace
