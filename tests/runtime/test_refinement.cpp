/**
 * @file test_refinement.cpp
 * Coarse-to-fine refinement: starting at refine_start_N and growing N by refine_factor reaches
 * the same solution as a direct solve (Jacobi-Newton and Newton), records the grid sizes in the
 * history, and keeps knots on grid nodes at every level.
 */
#include <gtest/gtest.h>

#include <cmath>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

pardel::Problem bratu_problem(int N) {
  pardel::Problem p;
  p.model = &hand::bratu;
  p.discretization = &hand::bratu.discretizations[0];
  p.params = {2.0};
  p.N = N;
  p.q0 = {0.0};
  p.qN = {0.3};
  return p;
}

TEST(Refinement, ReachesTheDirectSolution) {
  const auto p = bratu_problem(120);
  pardel::Options direct;
  direct.method = pardel::Method::newton;
  auto ref = pardel::linear_guess(p);
  ASSERT_TRUE(pardel::solve(p, direct, ref).converged());
  for (auto method : {pardel::Method::jacobi_newton, pardel::Method::newton}) {
    pardel::Options opt;
    opt.method = method;
    opt.threads = 1;
    opt.refine_start_N = 10;
    opt.refine_factor = 1.5;
    auto coarse = pardel::linear_guess(bratu_problem(10));
    const auto s = pardel::solve(p, opt, coarse);
    ASSERT_TRUE(s.converged()) << s.brief_report();
    ASSERT_EQ(coarse.N, 120);
    EXPECT_EQ(s.N, 120);
    for (int k = 0; k <= 120; ++k) EXPECT_NEAR(coarse.node(k)[0], ref.node(k)[0], 1e-9);
    // The history walks through the levels 10, 15, 23, ... in increasing order.
    ASSERT_FALSE(s.history.empty());
    EXPECT_EQ(s.history.front().N, 10);
    EXPECT_EQ(s.history.back().N, 120);
    for (std::size_t i = 1; i < s.history.size(); ++i) EXPECT_GE(s.history[i].N, s.history[i - 1].N);
  }
}

TEST(Refinement, CoarseStartNeedsFewerSweepsThanAStraightLine) {
  const auto p = bratu_problem(160);
  pardel::Options opt;
  opt.threads = 1;
  auto direct = pardel::linear_guess(p);
  const auto sd = pardel::solve(p, opt, direct);
  opt.refine_start_N = 8;
  auto refined = pardel::linear_guess(p);
  const auto sr = pardel::solve(p, opt, refined);
  ASSERT_TRUE(sd.converged());
  ASSERT_TRUE(sr.converged()) << sr.brief_report();
  EXPECT_LT(sr.iterations, sd.iterations);
  for (int k = 0; k <= 160; ++k) EXPECT_NEAR(refined.node(k)[0], direct.node(k)[0], 1e-8);
}

TEST(Refinement, KnotsStayOnNodesAtEveryLevel) {
  pardel::Problem p;
  p.model = &hand::spline;
  p.discretization = &hand::spline.discretizations[0];
  p.params = {1.0};
  p.N = 60;
  p.q0 = {0.0, 1.0};
  p.qN = {1.0, 0.0};
  p.knots = {{0.25, {0.5}}, {0.75, {-0.5}}};
  pardel::Options opt;
  opt.method = pardel::Method::newton;
  opt.refine_start_N = 5;  // not a multiple of 4: the first level is moved to 8
  opt.tol = 1e-7;          // order 2 with h = 1/60: the residual's round-off level is ~1e-8
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  for (const auto& r : s.history) EXPECT_EQ(r.N % 4, 0) << "level N = " << r.N;
  EXPECT_EQ(traj.node(15)[0], 0.5);
  EXPECT_EQ(traj.node(45)[0], -0.5);
}

}  // namespace
