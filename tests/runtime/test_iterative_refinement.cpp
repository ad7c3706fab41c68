/**
 * @file test_iterative_refinement.cpp
 * Iterative refinement with the DEL residual in extended precision (Options::iterative_refinement):
 * on test models whose discrete solution equals the exact one (polynomials that hermite_gauss
 * represents exactly: order 3, degree 5; order 4, degree 7), the node error is round-off alone.
 * Without refinement it grows like eps N^(2 order); with it, it is at round-off (below 1e-9) up to
 * N = 1000 at orders 3 and 4 (beyond N = 480 at order 3 and N = 120 at order 4 through the Hessian
 * in extended precision, where the double one is too ill-conditioned for the corrections to
 * converge; docs/solvers.md, "Iterative refinement"); also on exponential motions (tension_jerk,
 * tension_snap), which the discretization does not hold exactly. On an order-1 model refinement
 * changes nothing that matters.
 */
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "drift_line.hpp"
#include "pardel/pardel.hpp"
#include "quintic_pair.hpp"
#include "septic_rod.hpp"
#include "tension_jerk.hpp"
#include "tension_snap.hpp"

namespace {

/** A polynomial by its coefficients c[0] + c[1] t + ...; derivative j at t. */
double poly(const std::vector<double>& c, int j, double t) {
  double s = 0;
  for (std::size_t e = static_cast<std::size_t>(j); e < c.size(); ++e) {
    double f = 1;
    for (int r = 0; r < j; ++r) f *= static_cast<double>(e) - r;
    s += c[e] * f * std::pow(t, static_cast<double>(e - static_cast<std::size_t>(j)));
  }
  return s;
}

/** One coordinate's exact motion: a polynomial plus b cosh(w t) + s sinh(w t). */
struct Motion {
  std::vector<double> coefficients;
  double b = 0, s = 0, w = 0;
  /** Derivative j at t. */
  double at(int j, double t) const {
    const double wj = std::pow(w, j), even = b * std::cosh(w * t) + s * std::sinh(w * t),
                 odd = b * std::sinh(w * t) + s * std::cosh(w * t);
    return poly(coefficients, j, t) + wj * (j % 2 == 0 ? even : odd);
  }
};

struct Case {
  const pardel_model* model;
  std::vector<Motion> coefficients;  // per coordinate
  double T;
};

/** The state [coords, coords', ...] of the exact solution at t. */
std::vector<double> state(const Case& c, double t) {
  std::vector<double> q;
  for (int j = 0; j < c.model->order; ++j)
    for (const Motion& m : c.coefficients) q.push_back(m.at(j, t));
  return q;
}

/** Max node error of the coordinates (positions) after a solve at N, and the summary. */
double solve_error(const Case& c, int N, pardel::Refinement mode, pardel::Summary* out = nullptr) {
  pardel::Problem p;
  p.model = c.model;
  p.discretization = &c.model->discretizations[0];
  p.N = N;
  p.T = c.T;
  p.q0 = state(c, 0);
  p.qN = state(c, c.T);
  auto traj = pardel::linear_guess(p);
  pardel::Options opt;
  opt.iterative_refinement = mode;
  opt.error_estimate = false;
  const pardel::Summary s = pardel::solve(p, opt, traj);
  EXPECT_TRUE(s.converged()) << c.model->name << " N = " << N << ": " << s.brief_report();
  double e = 0;
  const std::size_t nc = c.coefficients.size();
  for (int k = 0; k <= N; ++k) {
    const std::vector<double> exact = state(c, traj.t[static_cast<std::size_t>(k)]);
    for (std::size_t i = 0; i < nc; ++i) e = std::max(e, std::fabs(traj.node(k)[i] - exact[i]));
  }
  if (out) *out = s;
  return e;
}

const Case kQuintic{&quintic_pair_model, {{{0, 1, 2, 0, -3, 1}}, {{0, -1, 0, 1, 0, -2}}}, 1.0};
const Case kSeptic{&septic_rod_model, {{{1, 0.5, 0, -1, 0, 0.3, 0, -0.2}}}, 1.0};
// x^(6) = c x^(4) with c = 1.44 (w = 1.2), and x^(8) = c x^(6) with c = 2.25 (w = 1.5), on [0, 2].
const Case kTensionJerk{&tension_jerk_model, {{{0.5, -1, 0.25, 0.1}, 0.3, -0.2, 1.2}, {{0, 2, 0, -0.3}, -0.1, 0.4, 1.2}}, 2.0};
const Case kTensionSnap{&tension_snap_model, {{{1, 0, -0.5, 0.2, 0.05, -0.01}, 0.2, 0.1, 1.5}}, 2.0};

void check_refined(const Case& c, const std::vector<int>& Ns) {
  for (int N : Ns) {
    pardel::Summary s;
    const double e = solve_error(c, N, pardel::Refinement::on, &s);
    EXPECT_LE(e, 1e-9) << c.model->name << " N = " << N << ": " << s.refinement_note;
    std::printf("%s N = %4d: error %.2e with refinement (%s)\n", c.model->name, N, e, s.refinement_note.c_str());
  }
  const int N = Ns.back();
  pardel::Summary s_off, s_on;
  const double off = solve_error(c, N, pardel::Refinement::off, &s_off);
  const double on = solve_error(c, N, pardel::Refinement::on, &s_on);
  std::printf("%s N = %d: error %.2e without refinement, %.2e with (solve %.1f ms, %.1f ms)\n", c.model->name, N, off,
              on, 1e3 * s_off.wall_seconds, 1e3 * s_on.wall_seconds);
  EXPECT_GT(off, 1e-8) << "round-off without refinement should be visible at N = " << N;
  EXPECT_GT(off, 1e4 * on);
}

#if defined(PARDEL_TEST_QUADRUPLE)
// The runtime factors the Hessian in quadruple precision where the double one fails.
const std::vector<int> kOrder3Grids{60, 120, 240, 480, 1000}, kOrder4Grids{60, 120, 240, 480, 1000};
#else
// long double (64 significand bits) only: the grids the double Hessian reaches.
const std::vector<int> kOrder3Grids{60, 120, 240, 480}, kOrder4Grids{60, 90, 120};
#endif

TEST(IterativeRefinement, Order3QuinticToRoundOff) { check_refined(kQuintic, kOrder3Grids); }

TEST(IterativeRefinement, Order4SepticToRoundOff) { check_refined(kSeptic, kOrder4Grids); }

// Exponential motions (not held exactly by the discretization; its truncation error at these N is
// below 1e-12): the error with refinement is round-off, without it eps N^(2 order).
TEST(IterativeRefinement, Order3TensionToRoundOff) {
  check_refined(kTensionJerk, std::vector<int>(kOrder3Grids.begin() + 1, kOrder3Grids.end()));
}

TEST(IterativeRefinement, Order4TensionToRoundOff) { check_refined(kTensionSnap, kOrder4Grids); }

TEST(IterativeRefinement, AutomaticRefinesOrder3AtLargeN) {
  pardel::Summary s;
  const double e = solve_error(kQuintic, 480, pardel::Refinement::automatic, &s);
  EXPECT_LE(e, 1e-9);
  EXPECT_GT(s.refinement_steps, 0);
  EXPECT_GT(s.refinement_change, 0);
  EXPECT_NE(s.refinement_note.find("correction"), std::string::npos) << s.refinement_note;
}

TEST(IterativeRefinement, Order1DoesNotWorsen) {
  const Case line{&drift_line_model, {{{1, -2}}, {{0.5, 3}}}, 2.0};
  for (int N : {100, 1000, 10000}) {
    const double off = solve_error(line, N, pardel::Refinement::off);
    const double on = solve_error(line, N, pardel::Refinement::on);
    EXPECT_LE(on, std::max(off, 1e-14)) << "N = " << N;
    EXPECT_LE(on, 1e-12) << "N = " << N;
  }
}

TEST(IterativeRefinement, OffLeavesTheSummaryEmpty) {
  pardel::Summary s;
  solve_error(kQuintic, 60, pardel::Refinement::off, &s);
  EXPECT_EQ(s.refinement_steps, 0);
  EXPECT_TRUE(s.refinement_note.empty());
}

}  // namespace
