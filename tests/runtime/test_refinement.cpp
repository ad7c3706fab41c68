/**
 * @file test_refinement.cpp
 * Coarse-to-fine refinement: starting at refine_start_N and growing N by refine_factor reaches
 * the same solution as a direct solve (Jacobi-Newton and Newton), records the grid sizes in the
 * history, and keeps knots on grid nodes at every level; Newton's nested iteration (coarse levels
 * solved to tol, each level started from the extrapolation of the two before, one step on every
 * level) and its resumption.
 */
#include <gtest/gtest.h>

#include <algorithm>
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
  pardel::Options direct;  // both solves well below the 1e-9 the comparison asks
  direct.method = pardel::Method::newton;
  direct.tol = 1e-12;
  auto ref = pardel::linear_guess(p);
  ASSERT_TRUE(pardel::solve(p, direct, ref).converged());
  for (auto method : {pardel::Method::jacobi_newton, pardel::Method::newton}) {
    pardel::Options opt;
    opt.tol = 1e-12;
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

TEST(Refinement, NewtonStepsOnEveryLevelEvenWhenItsStartMeetsTheTolerance) {
  // Bratu from N = 100 to 400 with an absolute tol of 1e-2: the level N = 100 stops after one step
  // (residual 2e-3), and each finer level's start, its resampled solution, already has a residual
  // below 1e-2 while it is 2.6e-2 away from that level's discrete solution (max norm). Newton
  // still takes a step on each level, so the answer is within 1e-4 of the discrete solution at
  // N = 400 instead of a resampled coarse iterate reported as converged.
  const auto p = bratu_problem(400);
  pardel::Options direct;
  direct.method = pardel::Method::newton;
  direct.tol = 1e-13;
  auto ref = pardel::linear_guess(p);
  ASSERT_TRUE(pardel::solve(p, direct, ref).converged());
  pardel::Options opt;
  opt.method = pardel::Method::newton;
  opt.tol = 1e-2;
  opt.threads = 1;
  opt.history_every = 1;
  opt.refine_start_N = 100;
  opt.refine_factor = 2;
  auto x = pardel::linear_guess(bratu_problem(100));
  const auto s = pardel::solve(p, opt, x);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  ASSERT_EQ(x.N, 400);
  for (int N : {200, 400}) {
    int records = 0;
    for (const auto& r : s.history) records += r.N == N ? 1 : 0;
    EXPECT_GE(records, 1) << "level N = " << N << " (a record after each step; none when no step)";
  }
  double worst = 0;
  for (int k = 0; k <= 400; ++k) worst = std::max(worst, std::fabs(x.node(k)[0] - ref.node(k)[0]));
  EXPECT_LT(worst, 1e-4);
}

TEST(Refinement, CoarseStartNeedsFewerSweepsThanAStraightLine) {
  const auto p = bratu_problem(160);
  pardel::Options opt;  // the seed's method at an absolute tolerance
  opt.method = pardel::Method::jacobi_newton;
  opt.tol = 1e-10;
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
  pardel::Options opt;  // an absolute tolerance
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

/** The history's first record at grid size N (the start of that level). */
const pardel::IterationRecord* first_record_at(const pardel::Summary& s, int N) {
  for (const auto& r : s.history)
    if (r.N == N) return &r;
  return nullptr;
}

TEST(Refinement, NewtonStartsEachLevelFromTheExtrapolationOfTheTwoBefore) {
  // Levels 20, 40, 80, 160; each coarse level is solved to tol, and the start of level 160 is
  // q_80 + (q_80 - q_40) (h_160^2 - h_80^2) / (h_80^2 - h_40^2): at the nodes of all three grids it
  // removes the O(h^2) difference of the discrete solutions (the other nodes carry the resampling's
  // interpolation error too, which the first Newton step removes).
  const auto p = bratu_problem(160);
  pardel::Options opt;  // an absolute tolerance
  opt.method = pardel::Method::newton;
  opt.threads = 1;
  opt.tol = 1e-12;
  opt.refine_start_N = 20;
  opt.refine_factor = 2;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  for (int N : {20, 40, 80}) {
    // Every coarse level ended converged: its last record is at or below tol.
    const pardel::IterationRecord* next = first_record_at(s, 2 * N);
    ASSERT_NE(next, nullptr);
    const pardel::IterationRecord* last = nullptr;
    for (const auto& r : s.history)
      if (r.N == N) last = &r;
    ASSERT_NE(last, nullptr);
    EXPECT_LE(last->residual, opt.tol) << "level N = " << N;
  }
  // The same levels solved one by one.
  pardel::Options direct = opt;
  direct.refine_start_N = 0;
  auto q40 = pardel::linear_guess(bratu_problem(40));
  ASSERT_TRUE(pardel::solve(bratu_problem(40), direct, q40).converged());
  auto q80 = pardel::resample(bratu_problem(80), q40, 80);
  ASSERT_TRUE(pardel::solve(bratu_problem(80), direct, q80).converged());
  auto q160 = pardel::linear_guess(p);
  ASSERT_TRUE(pardel::solve(p, direct, q160).converged());
  const auto plain = pardel::resample(p, q80, 160);
  const auto a40 = pardel::resample(p, q40, 160);
  const double w = (1.0 / (160.0 * 160) - 1.0 / (80.0 * 80)) / (1.0 / (80.0 * 80) - 1.0 / (40.0 * 40));
  double err_plain = 0, err_extrapolated = 0;
  for (int k = 0; k <= 160; k += 4) {
    const double start = plain.node(k)[0] + w * (plain.node(k)[0] - a40.node(k)[0]);
    err_plain = std::max(err_plain, std::fabs(plain.node(k)[0] - q160.node(k)[0]));
    err_extrapolated = std::max(err_extrapolated, std::fabs(start - q160.node(k)[0]));
  }
  EXPECT_LT(err_extrapolated, 0.01 * err_plain) << "plain " << err_plain << ", extrapolated " << err_extrapolated;
  // Level 160 takes no more Newton iterations from there than from the plain resampling.
  long end80 = 0;
  for (const auto& r : s.history)
    if (r.N == 80) end80 = r.iteration;
  auto from_plain = plain;
  const auto sp = pardel::solve(p, direct, from_plain);
  ASSERT_TRUE(sp.converged());
  EXPECT_LE(s.iterations - end80, sp.iterations);
  for (int k = 0; k <= 160; ++k) EXPECT_NEAR(traj.node(k)[0], q160.node(k)[0], 1e-10);
}

TEST(Refinement, NewtonNestedIterationResumesBitForBit) {
  // Interrupted on the third level (its start needs the two levels before it), then resumed.
  const auto p = bratu_problem(160);
  pardel::Options opt;  // an absolute tolerance
  opt.method = pardel::Method::newton;
  opt.threads = 1;
  opt.tol = 1e-12;
  opt.refine_start_N = 20;
  opt.refine_factor = 2;
  auto reference = pardel::linear_guess(p);
  const auto sr = pardel::solve(p, opt, reference);
  ASSERT_TRUE(sr.converged()) << sr.brief_report();
  const pardel::IterationRecord* at80 = first_record_at(sr, 80);
  ASSERT_NE(at80, nullptr);
  pardel::Options stop = opt;
  stop.on_iteration = [&](const pardel::IterationRecord& r) { return r.iteration < at80->iteration + 1; };
  auto part = pardel::linear_guess(p);
  const auto sp = pardel::solve(p, stop, part);
  ASSERT_EQ(sp.termination, pardel::Termination::interrupted) << sp.brief_report();
  ASSERT_EQ(sp.state.N, 80);
  EXPECT_EQ(sp.state.previous_level.N, 40);
  pardel::Options resume = opt;
  resume.resume_from = &sp.state;
  auto resumed = pardel::linear_guess(p);
  const auto sc = pardel::solve(p, resume, resumed);
  ASSERT_TRUE(sc.converged()) << sc.brief_report();
  EXPECT_EQ(sc.iterations, sr.iterations);
  EXPECT_EQ(resumed.q, reference.q);
}

}  // namespace
