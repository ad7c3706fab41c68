/**
 * @file test_component_scale.cpp
 * What a solve may claim, on models written for it: the convergence test holds every component to
 * its own scale (two uncoupled pendulums whose Lagrangians differ by 10^8, against the same motions
 * solved at equal scales; a coordinate at rest; a coordinate of size 1e-7 from a guess 1e10 times
 * off, against the linear discrete solution by Thomas' algorithm), the inertia is judged in the Jacobi-scaled Hessian
 * (a badly scaled minimum is no degenerate point; a singular matrix still has its zero), node times
 * that do not increase under a clock are never converged, and a solve that did not converge is not
 * assessed (nor one interrupted during its assessment) and returns the requested grid.
 */
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "block_tridiagonal.hpp"
#include "pardel/pardel.hpp"

#ifdef PARDEL_HAVE_SCALE_MODELS
#include "clock_line.hpp"
#include "faint_coupled.hpp"
#include "lopsided_pendulums.hpp"
#endif

namespace {

using pardel::Termination;

TEST(ComponentScaleInertia, BadlyScaledBlocksArePositiveDefinite) {
  // H = blockdiag over the nodes of diag(1e12, 1) x the 1-D Laplacian tridiag(-1, 2, -1): positive
  // definite; its y-part eigenvalues are 1e-12 of the x-part's (and of Gershgorin's bound).
  const int N = 40;
  pardel::detail::BlockTridiagonal<2> H;
  H.resize(N, 2);
  for (int i = 0; i < N - 1; ++i) {
    H.diag(i).setZero();
    H.diag(i)(0, 0) = 2e12;
    H.diag(i)(1, 1) = 2;
    H.off(i).setZero();
    if (i + 1 < N - 1) {
      H.off(i)(0, 0) = -1e12;
      H.off(i)(1, 1) = -1;
    }
  }
  const auto in = H.inertia();
  EXPECT_EQ(in.positive, 2L * (N - 1));
  EXPECT_EQ(in.zero, 0L);
  EXPECT_EQ(in.negative, 0L);
}

TEST(ComponentScaleInertia, ASingularScaledMatrixKeepsItsZero) {
  // The same, but the y-part is the Laplacian with free ends (singular: the constant vector).
  const int N = 30;
  pardel::detail::BlockTridiagonal<2> H;
  H.resize(N, 2);
  const int n = N - 1;
  for (int i = 0; i < n; ++i) {
    H.diag(i).setZero();
    H.diag(i)(0, 0) = 2e12;
    H.diag(i)(1, 1) = (i == 0 || i == n - 1) ? 1 : 2;
    H.off(i).setZero();
    if (i + 1 < n) {
      H.off(i)(0, 0) = -1e12;
      H.off(i)(1, 1) = -1;
    }
  }
  const auto in = H.inertia();
  EXPECT_EQ(in.zero, 1L);
  EXPECT_EQ(in.positive, 2L * n - 1);
  EXPECT_EQ(in.negative, 0L);
}

#ifdef PARDEL_HAVE_SCALE_MODELS

pardel::Problem pendulums(double A, int N, double B = 1) {
  const pardel_model& m = lopsided_pendulums_model;
  pardel::Problem p;
  p.model = &m;
  p.discretization = pardel::find_discretization(m, "trapezoid");
  std::string error;
  EXPECT_TRUE(pardel::params_by_name(m, {{"A", A}, {"B", B}}, &p.params, &error)) << error;
  p.T = 1.5;
  p.N = N;
  p.q0 = {0.0, 0.0};
  p.qN = {1.0, 2.0};
  return p;
}

/** The largest difference of component i between two trajectories on one grid. */
double max_difference(const pardel::Trajectory& a, const pardel::Trajectory& b, int i) {
  double d = 0;
  for (int k = 0; k <= a.N; ++k) d = std::max(d, std::fabs(a.node(k)[i] - b.node(k)[i]));
  return d;
}

pardel::Options with_method(pardel::Method method) {
  pardel::Options o;
  o.method = method;
  o.threads = 1;
  return o;
}

/** Both pendulums solved with the factor A between their Lagrangians, against the solve at A = 1:
 *  the motions do not depend on A (uncoupled), so every component must come out the same. */
void expect_both_solved(double A, pardel::Method method, int N) {
  for (double B : {1.0, 0.0}) {  // B = 0: x's straight-line start is its solution already
  const pardel::Problem ref_problem = pendulums(1, N, B);
  pardel::Trajectory ref = pardel::linear_guess(ref_problem);
  const pardel::Summary ref_summary = pardel::solve(ref_problem, with_method(method), ref);
  ASSERT_EQ(ref_summary.termination, Termination::converged) << ref_summary.message;

  const pardel::Problem p = pendulums(A, N, B);
  pardel::Trajectory tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, with_method(method), tr);
  ASSERT_EQ(s.termination, Termination::converged) << "A = " << A << ", B = " << B << ": " << s.message;
  ASSERT_EQ(tr.N, ref.N);
  // rtol 1e-10 of each pendulum's own terms: the nodes agree far below the pendulum's O(1) motion.
  EXPECT_LT(max_difference(tr, ref, 0), 1e-7) << "x, A = " << A << ", B = " << B << ", " << pardel::to_string(method);
  EXPECT_LT(max_difference(tr, ref, 1), 1e-7) << "y, A = " << A << ", B = " << B << ", " << pardel::to_string(method);
  }
}

TEST(ComponentScale, EveryComponentIsSolvedWhateverItsScaleNewton) {
  for (double A : {1e8, 1e-8, 1e4, 1e12}) expect_both_solved(A, pardel::Method::newton, 200);
}

TEST(ComponentScale, EveryComponentIsSolvedWhateverItsScaleAutomatic) {
  for (double A : {1e8, 1e-8}) expect_both_solved(A, pardel::Method::automatic, 2000);
}

// At 1e16 and 1e-16 a node block diag(A m, m) has a reciprocal condition number of 1e-16, below
// the singularity test's 1e-14, but its Jacobi-scaled form is the identity: no singular block.
TEST(ComponentScale, EveryComponentIsSolvedWhateverItsScaleJacobiNewton) {
  for (double A : {1e8, 1e-8, 1e16, 1e-16}) expect_both_solved(A, pardel::Method::jacobi_newton, 24);
}

TEST(ComponentScale, EveryComponentIsSolvedWhateverItsScaleNonlinearJacobi) {
  for (double A : {1e8, 1e-8, 1e16, 1e-16}) expect_both_solved(A, pardel::Method::jacobi, 24);
}

TEST(ComponentScale, AnUnresolvedComponentIsNamedAndNotConverged) {
  // x a free particle already solved by the straight start; Newton's iterates, stopped after 1,
  // 2, ... iterations: there is one whose overall residual is below 1e-10 of the largest (x's)
  // terms while y's equations are not solved (a test with one scale for all components would call
  // it converged); it is named and not converged.
  const pardel::Problem p = pendulums(1e8, 200, 0);
  bool named = false;
  for (long m = 1; m <= 30 && !named; ++m) {
    pardel::Options o = with_method(pardel::Method::newton);
    o.max_iterations = m;
    pardel::Trajectory tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, o, tr);
    if (s.termination == Termination::converged) break;
    ASSERT_EQ(s.termination, Termination::max_iterations) << s.message;
    if (s.message.find("component y's equations are resolved only to") == std::string::npos) continue;
    named = true;
    EXPECT_LE(s.residual, s.tolerance) << s.message;
    EXPECT_EQ(s.point.kind, pardel::PointKind::unknown);
  }
  EXPECT_TRUE(named);
}

TEST(ComponentScale, ACoordinateAtRestConverges) {
  // y from 0 to 0 (T = 1.5 < pi: y = 0 is the only solution near), from a guess that moves it.
  pardel::Problem p = pendulums(1, 200);
  p.qN = {1.0, 0.0};
  for (pardel::Method method : {pardel::Method::newton, pardel::Method::automatic, pardel::Method::jacobi_newton}) {
    if (method == pardel::Method::jacobi_newton) p.N = 24;
    pardel::Trajectory tr = pardel::polyline_guess(p, {{0.0, 0.0}, {0.5, 0.7}, {1.0, 0.0}});
    const pardel::Summary s = pardel::solve(p, with_method(method), tr);
    ASSERT_EQ(s.termination, Termination::converged) << pardel::to_string(method) << ": " << s.message;
    double ymax = 0;
    for (int k = 0; k <= tr.N; ++k) ymax = std::max(ymax, std::fabs(tr.node(k)[1]));
    EXPECT_LT(ymax, 1e-9) << pardel::to_string(method);
  }
}

/** A problem of model m under the trapezoid with its default params, over [0, T] on N intervals. */
pardel::Problem trapezoid_problem(const pardel_model& m, double T, int N, std::vector<double> q0,
                                  std::vector<double> qN) {
  pardel::Problem p;
  p.model = &m;
  p.discretization = pardel::find_discretization(m, "trapezoid");
  p.params.assign(m.param_defaults, m.param_defaults + m.nparams);
  p.T = T;
  p.N = N;
  p.q0 = std::move(q0);
  p.qN = std::move(qN);
  return p;
}

/** The solution of a tridiagonal system (sub- and superdiagonal `off`, diagonal `diag`) by Thomas'
 *  algorithm. */
std::vector<double> thomas(double off, const std::vector<double>& diag, std::vector<double> rhs) {
  const std::size_t n = diag.size();
  std::vector<double> c(n), x(n);
  double denom = diag[0];
  c[0] = off / denom;
  rhs[0] /= denom;
  for (std::size_t i = 1; i < n; ++i) {
    denom = diag[i] - off * c[i - 1];
    c[i] = off / denom;
    rhs[i] = (rhs[i] - off * rhs[i - 1]) / denom;
  }
  x[n - 1] = rhs[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) x[i] = rhs[i] - c[i] * x[i + 1];
  return x;
}

TEST(ComponentScale, ACoordinateFarFromItsGuessIsSolved) {
  // faint_coupled: x of size 1e5, y of size 1e-7, from a guess whose middle node has y = 1000.
  // The trapezoid's DEL equations are linear: (2 q_k - q_{k-1} - q_{k+1}) / h + h grad W(q_k) = 0
  // with grad W = (-x + c y, y + c x). x's do not feel c y (1e-19 against terms of 1e5 / h), so x
  // solves its own tridiagonal system, and then y the one forced by -h c x_k: the reference, by
  // Thomas' algorithm, against which y must hold to far below its size.
  const pardel::Problem p = trapezoid_problem(faint_coupled_model, 2, 64, {1e5, 0.0}, {-5e4, 1e-7});
  const double h = p.T / p.N, c = 1e-12;
  const std::size_t n = static_cast<std::size_t>(p.N - 1);
  std::vector<double> dx(n, 2 / h - h), rx(n, 0.0), dy(n, 2 / h + h);
  rx.front() += p.q0[0] / h;
  rx.back() += p.qN[0] / h;
  const std::vector<double> x = thomas(-1 / h, dx, rx);
  std::vector<double> ry(n);
  for (std::size_t k = 0; k < n; ++k) ry[k] = -h * c * x[k];
  ry.front() += p.q0[1] / h;
  ry.back() += p.qN[1] / h;
  const std::vector<double> y = thomas(-1 / h, dy, ry);
  double ysize = 0;
  for (double v : y) ysize = std::max(ysize, std::fabs(v));
  ASSERT_GT(ysize, 5e-8);
  for (pardel::Method method : {pardel::Method::automatic, pardel::Method::newton}) {
    pardel::Trajectory tr = pardel::polyline_guess(p, {{1e5, 0.0}, {0.0, 1000.0}, {-5e4, 1e-7}});
    const pardel::Summary s = pardel::solve(p, with_method(method), tr);
    ASSERT_EQ(s.termination, Termination::converged) << pardel::to_string(method) << ": " << s.message;
    ASSERT_EQ(tr.N, p.N);
    double xerr = 0, yerr = 0;
    for (std::size_t k = 0; k < n; ++k) {
      xerr = std::max(xerr, std::fabs(tr.node(static_cast<int>(k) + 1)[0] - x[k]));
      yerr = std::max(yerr, std::fabs(tr.node(static_cast<int>(k) + 1)[1] - y[k]));
    }
    EXPECT_LT(xerr, 1e-8 * 1e5) << pardel::to_string(method);
    EXPECT_LT(yerr, 1e-8 * ysize) << pardel::to_string(method);
  }
}

TEST(ComponentScale, ABadlyScaledMinimumIsAMinimum) {
  // W = diag(1e12, 1): a regular model at a strict minimum (T below both pendulums' conjugate time).
  const pardel::Problem p = pendulums(1e12, 300);
  pardel::Trajectory tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, with_method(pardel::Method::newton), tr);
  ASSERT_EQ(s.termination, Termination::converged) << s.message;
  EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  EXPECT_EQ(s.point.zero, 0L);
  EXPECT_EQ(s.point.negative, 0L);
}

pardel::Problem clock_problem(pardel::ClockMode mode, double from, double to) {
  pardel::Problem p = trapezoid_problem(clock_line_model, 1, 60, {from}, {to});
  p.clock = mode;
  return p;
}

TEST(ComponentScaleClock, ANonPositiveClockAtTheStartIsRefused) {
  for (pardel::ClockMode mode : {pardel::ClockMode::free_final_time, pardel::ClockMode::fixed_total_time}) {
    // x from -3 to 1: the clock 1 + x is negative on the first third of the straight guess.
    const pardel::Problem p = clock_problem(mode, -3, 1);
    pardel::Trajectory tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, with_method(pardel::Method::newton), tr);
    EXPECT_EQ(s.termination, Termination::invalid_input) << s.message;
    EXPECT_NE(s.message.find("node times do not increase"), std::string::npos) << s.message;
  }
}

TEST(ComponentScaleClock, APositiveClockConvergesWithIncreasingTimes) {
  for (pardel::ClockMode mode : {pardel::ClockMode::free_final_time, pardel::ClockMode::fixed_total_time}) {
    const pardel::Problem p = clock_problem(mode, 0, 2);
    pardel::Trajectory tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, with_method(pardel::Method::automatic), tr);
    ASSERT_EQ(s.termination, Termination::converged) << s.message;
    for (int k = 0; k < tr.N; ++k) ASSERT_LT(tr.t[static_cast<std::size_t>(k)], tr.t[static_cast<std::size_t>(k) + 1]);
    EXPECT_GT(s.final_time, p.t0);
  }
}

TEST(ComponentScaleEnding, AnInterruptedSolveClaimsNothingAboutItsIterate) {
  const pardel::Problem p = pendulums(1, 400);
  pardel::Options o = with_method(pardel::Method::newton);
  o.on_iteration = [](const pardel::IterationRecord& r) { return r.iteration < 1; };
  pardel::Trajectory tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, o, tr);
  ASSERT_EQ(s.termination, Termination::interrupted) << s.message;
  EXPECT_EQ(s.point.kind, pardel::PointKind::unknown);
  EXPECT_NE(s.point.note.find("not assessed"), std::string::npos) << s.point.note;
}

TEST(ComponentScaleEnding, AnInterruptionAfterConvergenceStopsTheAssessment) {
  // keep_going is polled by the assessment's block solves: false stops it, and the converged
  // solve's point is reported not assessed; left empty or true, the point is the minimum.
  const pardel::Problem p = pendulums(1, 400);
  for (bool stop : {true, false}) {
    pardel::Options o = with_method(pardel::Method::newton);
    long polled = 0;
    o.keep_going = [&polled, stop] {
      ++polled;
      return !stop;
    };
    pardel::Trajectory tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, o, tr);
    ASSERT_EQ(s.termination, Termination::converged) << s.message;
    EXPECT_GE(polled, 1);
    if (stop) {
      EXPECT_EQ(s.point.kind, pardel::PointKind::unknown);
      EXPECT_NE(s.point.note.find("interrupted during the assessment"), std::string::npos) << s.point.note;
    } else {
      EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
    }
  }
}

TEST(ComponentScaleEnding, AStopAtACoarseLevelReturnsTheRequestedGrid) {
  pardel::Problem p = pendulums(1, 1600);
  pardel::Options o = with_method(pardel::Method::jacobi_newton);
  o.refine_start_N = 50;
  o.max_iterations = 5;
  pardel::Trajectory tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, o, tr);
  ASSERT_EQ(s.termination, Termination::max_iterations) << s.message;
  EXPECT_EQ(tr.N, 1600);
  EXPECT_EQ(tr.q.size(), 1601u * 2);
  EXPECT_EQ(tr.t.size(), 1601u);
  EXPECT_EQ(s.N, 1600);
  EXPECT_NE(s.message.find("interpolated to the requested N = 1600"), std::string::npos) << s.message;
  // The boundary values are the problem's.
  EXPECT_EQ(tr.node(1600)[1], 2.0);
  EXPECT_EQ(s.point.kind, pardel::PointKind::unknown);
}

#endif  // PARDEL_HAVE_SCALE_MODELS

}  // namespace
