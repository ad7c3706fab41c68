/**
 * @file test_trajectory.cpp
 * Initial guesses and resampling: the straight line and the polyline hit the boundary values;
 * resampling reproduces linear data exactly (order 1), quadratics away from the end intervals (order
 * 1: central-difference slopes, per coordinate), and cubic polynomials exactly when
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

// Without stored derivatives the slopes are central differences of the old nodes (one-sided at the
// ends), exact for quadratics: on every old interval away from the ends the cubic Hermite
// interpolant is the quadratic itself, in each coordinate with its own quadratic.
TEST(Trajectory, ResampleIsExactForQuadraticsAwayFromTheEndsOfOrderOne) {
  pardel::Problem p;
  p.q0 = {0.0, 0.0, 0.0};
  p.qN = {0.0, 0.0, 0.0};
  p.t0 = 0.5;
  p.T = 2;
  const int M = 9, N = 40;
  auto f = [](int i, double s) { return (i + 1) * 0.7 - 1.3 * s * (i - 1) + (2.0 - i) * 3.1 * s * s; };
  pardel::Trajectory coarse;
  coarse.N = M;
  coarse.dim = 3;
  coarse.q.resize(static_cast<std::size_t>(M + 1) * 3);
  for (int k = 0; k <= M; ++k)
    for (int i = 0; i < 3; ++i) coarse.node(k)[i] = f(i, static_cast<double>(k) / M);
  const auto fine = pardel::resample(p, coarse, N);
  ASSERT_EQ(fine.N, N);
  int checked = 0;
  for (int k = 0; k <= N; ++k) {
    const double s = static_cast<double>(k) / N;
    if (s * M < 1 || s * M > M - 1) continue;  // the end intervals, with one-sided slopes
    ++checked;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(fine.node(k)[i], f(i, s), 1e-13) << "node " << k << " coordinate " << i;
    EXPECT_NEAR(fine.t[static_cast<std::size_t>(k)], 0.5 + 2 * s, 1e-14);
  }
  EXPECT_GT(checked, 30);
  // At the ends the one-sided slopes are first order: the quadratic term is not reproduced.
  EXPECT_GT(std::fabs(fine.node(2)[0] - f(0, 2.0 / N)), 1e-6);
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
