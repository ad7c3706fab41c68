/**
 * @file test_galerkin.cpp
 * The Galerkin discretizations (galerkin_gauss(s=S), galerkin_lobatto(s=S)): their condensed
 * kernels against finite differences of their own action, and their global order 2 S measured
 * against exact motions written for these tests: an arc of an eccentric Kepler orbit (nonlinear,
 * Kepler's equation), a spring driven at twice its frequency (time-dependent) and an order-2
 * model x'''' = x - t (Hermite end jets plus interior values). Every solver sees node blocks only,
 * so Jacobi-Newton solves them unchanged.
 */
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"
#ifdef PARDEL_HAVE_GALERKIN_MODELS
#include "galerkin_beam.hpp"
#include "galerkin_forced.hpp"
#include "galerkin_orbit.hpp"
#endif

#ifdef PARDEL_HAVE_GALERKIN_MODELS
namespace {

/** The exact jet of a motion at t: [x, x', ...] of the model's point (order * ncoords values). */
using Jet = std::function<std::vector<double>(double)>;

/** The eccentric orbit a = 1, e = 0.3, mu = 1, pericentre at t = 0: x = cos E - e,
 *  y = sqrt(1 - e^2) sin E with E - e sin E = t. */
std::vector<double> orbit(double t) {
  const double e = 0.3;
  double E = t;
  for (int i = 0; i < 60; ++i) E -= (E - e * std::sin(E) - t) / (1 - e * std::cos(E));
  return {std::cos(E) - e, std::sqrt(1 - e * e) * std::sin(E)};
}

pardel::Problem problem(const pardel_model& model, const char* disc, double t0, double T, const Jet& exact) {
  pardel::Problem p;
  p.model = &model;
  p.discretization = pardel::find_discretization(model, disc);
  EXPECT_NE(p.discretization, nullptr) << disc;
  p.t0 = t0;
  p.T = T;
  p.q0 = exact(t0);
  p.qN = exact(t0 + T);
  return p;
}

/** The largest error of the coordinates' values (not their derivatives) over the nodes after a
 *  solve with `method` from the straight-line guess. */
double max_error(pardel::Problem p, int N, const Jet& exact, pardel::Method method = pardel::Method::newton) {
  p.N = N;
  pardel::Trajectory traj = pardel::linear_guess(p);
  pardel::Options opt;
  opt.method = method;
  opt.rtol = 1e-13;
  if (method == pardel::Method::jacobi_newton) opt.max_iterations = 200000;
  const pardel::Summary s = pardel::solve(p, opt, traj);
  EXPECT_TRUE(s.converged()) << p.discretization->name << ", N = " << N << ": " << s.brief_report();
  const int n = p.model->ncoords;
  double err = 0;
  for (int k = 0; k <= N; ++k) {
    const std::vector<double> x = exact(traj.t[k]);
    for (int i = 0; i < n; ++i) err = std::max(err, std::fabs(traj.node(k)[i] - x[static_cast<std::size_t>(i)]));
  }
  return err;
}

/** log2(e_N / e_2N) must be the reported order 2 s within 0.2. */
void expect_order(const pardel::Problem& p, int N, const Jet& exact) {
  const double coarse = max_error(p, N, exact), fine = max_error(p, 2 * N, exact);
  const double observed = std::log2(coarse / fine);
  EXPECT_GT(fine, 2e-13) << p.discretization->name << ": the finer grid must stay above round-off (about 3e-14 here)";
  EXPECT_NEAR(observed, p.discretization->consistency_order, 0.2)
      << p.discretization->name << ": max error " << coarse << " at N = " << N << ", " << fine << " at N = " << 2 * N;
}

// ---- The condensed kernels against central differences of the discretization's own values.

TEST(Galerkin, CondensedDerivativesMatchDifferencesOfTheAction) {
  const pardel_model& m = galerkin_orbit_model;
  const double q0[2] = {0.9, 0.25}, q1[2] = {0.7, 0.55}, p[1] = {1.3};
  const double h = 0.4, t0 = 0.2, t1 = 0.6;
  for (int d = 0; d < m.ndiscretizations; ++d) {
    const pardel_discretization& disc = m.discretizations[d];
    double Ld, D1[2], D2[2], D11[4], D12[4], D22[4];
    disc.full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, D12, D22);
    EXPECT_NEAR(Ld, disc.action(h, t0, t1, q0, q1, p), 1e-14 * std::fabs(Ld)) << disc.name;
    const double delta = 1e-5;
    for (int i = 0; i < 2; ++i) {
      double a[2] = {q0[0], q0[1]}, b[2] = {q1[0], q1[1]};
      a[i] += delta;
      const double up0 = disc.action(h, t0, t1, a, q1, p);
      a[i] -= 2 * delta;
      const double down0 = disc.action(h, t0, t1, a, q1, p);
      b[i] += delta;
      const double up1 = disc.action(h, t0, t1, q0, b, p);
      b[i] -= 2 * delta;
      const double down1 = disc.action(h, t0, t1, q0, b, p);
      EXPECT_NEAR(D1[i], (up0 - down0) / (2 * delta), 1e-8) << disc.name << " D1[" << i << "]";
      EXPECT_NEAR(D2[i], (up1 - down1) / (2 * delta), 1e-8) << disc.name << " D2[" << i << "]";
      // Second derivatives: differences of the gradient kernel.
      double LdA, gA1[2], gA2[2], LdB, gB1[2], gB2[2];
      double c[2] = {q1[0], q1[1]};
      c[i] += delta;
      disc.grad(h, t0, t1, q0, c, p, &LdA, gA1, gA2);
      c[i] -= 2 * delta;
      disc.grad(h, t0, t1, q0, c, p, &LdB, gB1, gB2);
      double e[2] = {q0[0], q0[1]};
      e[i] += delta;
      double LdC, gC1[2], gC2[2], LdD, gD1[2], gD2[2];
      disc.grad(h, t0, t1, e, q1, p, &LdC, gC1, gC2);
      e[i] -= 2 * delta;
      disc.grad(h, t0, t1, e, q1, p, &LdD, gD1, gD2);
      for (int r = 0; r < 2; ++r) {
        EXPECT_NEAR(D12[r * 2 + i], (gA1[r] - gB1[r]) / (2 * delta), 1e-6) << disc.name << " D12";
        EXPECT_NEAR(D22[r * 2 + i], (gA2[r] - gB2[r]) / (2 * delta), 1e-6) << disc.name << " D22";
        EXPECT_NEAR(D11[r * 2 + i], (gC1[r] - gD1[r]) / (2 * delta), 1e-6) << disc.name << " D11";
      }
    }
    // The sweep kernel returns the full kernel's blocks.
    double S1[2], S2[2], S11[4], S22[4];
    disc.sweep(h, t0, t1, q0, q1, p, S1, S2, S11, S22);
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(S11[i], D11[i]) << disc.name;
      EXPECT_EQ(S22[i], D22[i]) << disc.name;
    }
  }
}

// With one point (s = 1) the Galerkin family is the midpoint rule (Gauss) and the trapezoid
// (Lobatto), which have no interior values.
TEST(Galerkin, OnePointIsMidpointOrTrapezoid) {
  const pardel_model& m = galerkin_orbit_model;
  const double q0[2] = {0.9, 0.25}, q1[2] = {0.7, 0.55}, p[1] = {1.0};
  const double h = 0.3, t0 = 0, t1 = 0.3;
  const double mid = pardel::find_discretization(m, "midpoint")->action(h, t0, t1, q0, q1, p);
  EXPECT_NEAR(pardel::find_discretization(m, "galerkin_gauss(s=1)")->action(h, t0, t1, q0, q1, p), mid, 1e-15);
  // Trapezoid: h/2 [L(q0, v) + L(q1, v)].
  const double v2 = ((q1[0] - q0[0]) * (q1[0] - q0[0]) + (q1[1] - q0[1]) * (q1[1] - q0[1])) / (h * h);
  const double trap = h / 2 * (v2 + 1 / std::hypot(q0[0], q0[1]) + 1 / std::hypot(q1[0], q1[1]));
  EXPECT_NEAR(pardel::find_discretization(m, "galerkin_lobatto(s=1)")->action(h, t0, t1, q0, q1, p), trap, 1e-15);
}

// ---- Measured orders against exact motions.

TEST(Galerkin, EccentricOrbitConvergesAtOrderTwoS) {
  for (const char* disc : {"galerkin_gauss(s=2)", "galerkin_lobatto(s=2)", "galerkin_gauss(s=3)",
                           "galerkin_lobatto(s=3)", "galerkin_gauss(s=4)", "galerkin_lobatto(s=4)"}) {
    const pardel::Problem p = problem(galerkin_orbit_model, disc, 0.3, 1.7, orbit);
    const int s = p.discretization->consistency_order / 2;
    // Coarser grids for higher orders, so that the finer error stays far above round-off
    // (at N = 16 and 32 s = 4 reaches 1e-12 to 1e-14).
    expect_order(p, s <= 3 ? 12 : 8, orbit);
  }
}

TEST(Galerkin, DrivenSpringIsTimeDependentAndOrderSix) {
  const Jet exact = [](double t) { return std::vector<double>{0.8 * std::cos(t) - 0.4 * std::sin(t) - std::sin(2 * t) / 3}; };
  // Over 2.5 < pi, short of the first conjugate point: the motion is a minimum of the action.
  for (const char* disc : {"galerkin_gauss(s=3)", "galerkin_lobatto(s=3)"}) {
    expect_order(problem(galerkin_forced_model, disc, 0.7, 2.5, exact), 4, exact);
  }
}

TEST(Galerkin, OrderTwoModelGainsOrderFromInteriorValues) {
  const Jet exact = [](double t) {
    return std::vector<double>{std::cos(t) + std::sinh(t) + t, -std::sin(t) + std::cosh(t) + 1};
  };
  // galerkin_gauss(s=2) has no interior values: it is the Hermite interpolant under 2 Gauss
  // points, gauss2 (order 4); s = 3 and 4 add one and two interior values (orders 6 and 8).
  const pardel::Problem g2 = problem(galerkin_beam_model, "gauss2", 0.2, 2.5, exact);
  const pardel::Problem s2 = problem(galerkin_beam_model, "galerkin_gauss(s=2)", 0.2, 2.5, exact);
  EXPECT_NEAR(max_error(s2, 6, exact), max_error(g2, 6, exact), 1e-13);
  for (const char* disc : {"galerkin_gauss(s=3)", "galerkin_lobatto(s=3)", "galerkin_gauss(s=4)"}) {
    expect_order(problem(galerkin_beam_model, disc, 0.2, 2.5, exact), 3, exact);
  }
}

// More points at a fixed grid: the error falls by more than a factor 10 with each s (the
// discretizations converge geometrically in s for an analytic motion).
TEST(Galerkin, ErrorFallsFastWithSAtFixedN) {
  double previous = 1;
  for (const char* disc : {"galerkin_gauss(s=1)", "galerkin_gauss(s=2)", "galerkin_gauss(s=3)", "galerkin_gauss(s=4)",
                           "galerkin_gauss(s=6)"}) {
    const double e = max_error(problem(galerkin_orbit_model, disc, 0.3, 1.7, orbit), 3, orbit);
    EXPECT_LT(e, previous / 10) << disc;
    previous = e;
  }
  EXPECT_LT(previous, 1e-9);
}

// An order-16 discretization on a fine enough grid: both grids of the error estimate agree to
// rounding, and the estimate reports the round-off level of the coordinates, not less.
TEST(Galerkin, AnEstimateBelowRoundOffIsReportedAsRoundOff) {
  pardel::Problem p = problem(galerkin_orbit_model, "galerkin_lobatto(s=8)", 0.3, 1.7, orbit);
  p.N = 8;
  pardel::Trajectory traj = pardel::linear_guess(p);
  pardel::Options opt;
  opt.method = pardel::Method::newton;
  opt.rtol = 1e-13;
  const pardel::Summary s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  double size = 0;
  for (int k = 0; k <= p.N; ++k) size = std::max(size, std::fabs(traj.node(k)[0]));
  EXPECT_GE(s.error_estimate, 8 * 2.220446049250313e-16 * size) << s.error_note;
  EXPECT_NE(s.error_note.find("round-off"), std::string::npos) << s.error_note;
  EXPECT_LT(max_error(p, 8, orbit), 1e-13);  // the true error is round-off too
}

// Jacobi-Newton (the seed's method) sees node blocks only: the same answer as Newton.
TEST(Galerkin, JacobiNewtonSolvesTheCondensedSystem) {
  const pardel::Problem p = problem(galerkin_orbit_model, "galerkin_lobatto(s=3)", 0.3, 1.7, orbit);
  const double newton = max_error(p, 6, orbit);
  const double jacobi = max_error(p, 6, orbit, pardel::Method::jacobi_newton);
  EXPECT_NEAR(jacobi, newton, 1e-10);
}

// An interval whose interior Newton iteration starts at a pole of L (the midpoint of a chord
// through the attracting centre, where mu/|q| is infinite) cannot be condensed: every output is
// NaN, never a number.
TEST(Galerkin, UncondensableIntervalGivesNaN) {
  const pardel_discretization* disc = pardel::find_discretization(galerkin_orbit_model, "galerkin_lobatto(s=2)");
  const double q0[2] = {-1, 0}, q1[2] = {1, 0}, p[1] = {1.0};
  double Ld, D1[2], D2[2], D11[4], D12[4], D22[4];
  disc->full(0.5, 0, 0.5, q0, q1, p, &Ld, D1, D2, D11, D12, D22);
  EXPECT_TRUE(std::isnan(Ld));
  for (int i = 0; i < 2; ++i) EXPECT_TRUE(std::isnan(D1[i]) && std::isnan(D2[i]));
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(std::isnan(D11[i]) && std::isnan(D12[i]) && std::isnan(D22[i]));
  EXPECT_TRUE(std::isnan(disc->action(0.5, 0, 0.5, q0, q1, p)));
}

}  // namespace
#else
TEST(Galerkin, NeedsTheGenerator) { GTEST_SKIP() << "the Galerkin test models need pardel-gen"; }
#endif
