/**
 * @file test_assessment.cpp
 * What a solve with the default options reports about the point it returns, on models written for
 * these tests (tests/runtime/models): the inertia of the Hessian against the eigenvalues of a
 * finite-difference Hessian of the discrete action and its two smallest eigenvalues (upper bounds;
 * a repeated smallest eigenvalue found twice); Newton leaving a saddle of a Kepler arc past
 * its conjugate point; a Lagrangian without velocities refused before solving; an order-2
 * minimum-acceleration path through knots converged (not stalled) and converging to the clamped
 * cubic spline at second order; a double-pendulum swing converged at N = 2e5 on the grid that was asked, with the
 * discretization's second order against coarser solves; a regular order-4 model accepted by the
 * solve-time regularity check on fine grids, and its converged message saying where round-off hides
 * whether the equations hold; a harmonic oscillator just before its conjugate point reported as a
 * nearly degenerate minimum, against the exact eigenvalues of its Hessian; the same exact
 * eigenvalues (one spring, two springs whose two lowest modes lie on different coordinates) and a
 * triple one after the automatic method's nested levels, whose eigenvector estimates start the
 * next level's Lanczos runs, and an order-3 model's there equal to its point's own assessment; a
 * two-fold smallest eigenvalue of a diagonal Hessian compared with the third (nearly degenerate
 * where it lies below 1e-4 of it), which is computed only where the two smallest are nearly equal.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "assessment.hpp"
#include "hand_models.hpp"
#include "pardel/pardel.hpp"

#ifdef PARDEL_HAVE_ASSESSMENT_MODELS
#include "double_swing.hpp"
#include "kepler_arc.hpp"
#include "min_accel3.hpp"
#include "no_velocity.hpp"
#include "plate_pair.hpp"
#include "twin_spring.hpp"
#endif

namespace {

TEST(Assessment, AMinimumJustBeforeAConjugatePointIsNearlyDegenerate) {
  // The harmonic oscillator's trapezoid action (hand_models.hpp) has the Hessian
  // tridiag(-1/h, 2/h - h w^2, -1/h), whose eigenvalues are exactly
  // lambda_k = (4/h) sin^2(k pi / 2N) - h w^2. With w^2 = (4/h^2) sin^2(pi / 2N) (1 - delta) the
  // interval T is just short of the discrete conjugate point: lambda_1 = (4/h) sin^2(pi/2N) delta,
  // about delta/3 of lambda_2. Antisymmetric end values keep the solution bounded (the soft mode
  // is symmetric). The assessment must call this minimum nearly degenerate, with both eigenvalues.
  const int N = 100;
  const double T = 3, h = T / N, delta = 1e-5, kPiHere = 3.14159265358979323846;
  const double s1 = std::sin(kPiHere / (2 * N)), s2 = std::sin(2 * kPiHere / (2 * N));
  const double w2 = 4 / (h * h) * s1 * s1 * (1 - delta);
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.params = {std::sqrt(w2)};
  p.T = T;
  p.N = N;
  p.q0 = {0.3};
  p.qN = {-0.3};
  const double lambda1 = 4 / h * s1 * s1 - h * w2, lambda2 = 4 / h * s2 * s2 - h * w2;
  ASSERT_LT(lambda1, 1e-4 * lambda2);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  EXPECT_TRUE(s.point.nearly_degenerate) << s.point.note;
  EXPECT_TRUE(s.point.lambda_settled) << s.point.note;
  // lambda_1 is 5e-9 of the diagonal: the assembled Hessian carries it to about 1e-5.
  EXPECT_NEAR(s.point.lambda_min, lambda1, 1e-3 * lambda1) << s.point.note;
  EXPECT_NEAR(s.point.lambda_next, lambda2, 1e-3 * lambda2) << s.point.note;
  EXPECT_NE(s.point.note.find("a nearly degenerate minimum"), std::string::npos) << s.point.note;
  EXPECT_NEAR(s.point.soft_motion, std::sqrt(2e-16 * std::fabs(s.action) / s.point.lambda_min),
              1e-9 * s.point.soft_motion);
}

/** lambda_k = (4/h) sin^2(k pi / 2N) - h w^2: the k-th eigenvalue of a spring's trapezoid Hessian
 *  tridiag(-1/h, 2/h - h w^2, -1/h) on N - 1 interior nodes. */
double spring_eigenvalue(int k, int N, double T, double w) {
  const double h = T / N, s = std::sin(k * 3.14159265358979323846 / (2 * N));
  return 4 / h * s * s - h * w * w;
}

TEST(Assessment, OnNestedLevelsTheEigenvaluesAreTheExactOnes) {
  // The automatic method's levels 800, 3200, 12800: each coarse level's eigenvector estimates start
  // the next level's Lanczos runs (LevelEigenvectors), and the final assessment's. The spring's
  // Hessian has exact eigenvalues; the values reported are upper bounds within 1e-4 and 3e-3
  // (the assembled Hessian carries lambda_1, 1e-8 of its diagonal, to about 1e-8).
  const int N = 12800;
  const double T = 3, w = 0.8;
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.params = {w};
  p.T = T;
  p.N = N;
  p.q0 = {0.4};
  p.qN = {-1.1};
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  ASSERT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  EXPECT_TRUE(s.point.lambda_settled) << s.point.note;
  const double l1 = spring_eigenvalue(1, N, T, w), l2 = spring_eigenvalue(2, N, T, w);
  EXPECT_GE(s.point.lambda_min, l1 * (1 - 1e-6));
  EXPECT_LE(s.point.lambda_min, l1 * (1 + 1e-4));
  EXPECT_GE(s.point.lambda_next, l2 * (1 - 1e-6));
  EXPECT_LE(s.point.lambda_next, l2 * (1 + 3e-3));
}

TEST(Assessment, StartsAlongModesInTheOtherOrderGiveTheSmallestFirst) {
  // smallest_eigenvalues on H = diag(1, 2, 3, ...) (solve: divide), its runs started as a coarse
  // level whose two lowest modes were in the other order would start them: lambda_1's run from
  // the eigenvector of 2, lambda_2's from that of 1. Each run settles at once on its own mode;
  // the smallest must still come first.
  const std::size_t n = 50;
  std::vector<unsigned char> free(n, 1);
  pardel::detail::LanczosOperator op;
  op.n = n;
  op.dim = 1;
  op.first_node = 1;
  op.N = static_cast<int>(n) + 1;
  op.free = free.data();
  op.solve = [n](const double* b, double* x) {
    for (std::size_t i = 0; i < n; ++i) x[i] = b[i] / static_cast<double>(i + 1);
  };
  op.reduce = [](double*, int) {};
  op.start = [n](int which, double* v) {
    std::fill(v, v + n, 0.0);
    v[which == 0 ? 1 : 0] = 1;
    return true;
  };
  const pardel::detail::SmallestEigenvalues e = pardel::detail::smallest_eigenvalues(op, static_cast<long>(n));
  EXPECT_TRUE(e.settled);
  EXPECT_NEAR(e.lambda[0], 1, 1e-12);
  EXPECT_NEAR(e.lambda[1], 2, 1e-12);
  // From the built-in start the same values.
  op.start = nullptr;
  const pardel::detail::SmallestEigenvalues cold = pardel::detail::smallest_eigenvalues(op, static_cast<long>(n));
  EXPECT_TRUE(cold.settled);
  EXPECT_NEAR(cold.lambda[0], 1, 1e-4);
  EXPECT_NEAR(cold.lambda[1], 2, 6e-3);
}

/** A diagonal Hessian with the eigenvalues d (dim 2: two components a node) as the Lanczos runs
 *  see it: x = H^-1 b by division, each solve counted in *solves. */
pardel::detail::LanczosOperator diagonal_operator(const std::vector<double>& d, const std::vector<unsigned char>& free,
                                                   int* solves) {
  pardel::detail::LanczosOperator op;
  op.n = d.size();
  op.dim = 2;
  op.first_node = 1;
  op.N = static_cast<int>(d.size()) / 2 + 1;
  op.free = free.data();
  op.solve = [&d, solves](const double* b, double* x) {
    ++*solves;
    for (std::size_t i = 0; i < d.size(); ++i) x[i] = b[i] / d[i];
  };
  op.reduce = [](double*, int) {};
  return op;
}

TEST(Assessment, ATwoFoldLowestModeIsComparedWithTheThirdEigenvalue) {
  // H = diag(d) on 60 unknowns: a two-fold smallest eigenvalue (entries 13 and 40) under the rest,
  // d_i = 0.9 + 0.05 i, whose smallest, d_0 = 0.9, is the third eigenvalue. With
  // the two-fold value 1e-6 the minimum is nearly degenerate (1e-6 < 1e-4 * 0.9, the ratio of the
  // two smallest is 1); with 0.3 it is not. A third Lanczos run with both Ritz vectors deflated
  // gives the third eigenvalue; none is made where the two smallest are not nearly equal.
  const std::size_t n = 60;
  const std::vector<unsigned char> free(n, 1);
  for (const double soft : {1e-6, 0.3}) {
    std::vector<double> d(n);
    for (std::size_t i = 0; i < n; ++i) d[i] = 0.9 + 0.05 * static_cast<double>(i);
    d[13] = d[40] = soft;
    int solves = 0;
    const pardel::detail::LanczosOperator op = diagonal_operator(d, free, &solves);
    const pardel::detail::SmallestEigenvalues e = pardel::detail::smallest_eigenvalues(op, static_cast<long>(n));
    EXPECT_TRUE(e.settled);
    EXPECT_TRUE(e.settled_third);
    EXPECT_GE(e.lambda[0], soft * (1 - 1e-12));
    EXPECT_LE(e.lambda[0], soft * (1 + 1e-4));
    EXPECT_GE(e.lambda[1], soft * (1 - 1e-12));
    EXPECT_LE(e.lambda[1], soft * (1 + 3e-3));
    EXPECT_GE(e.lambda[2], 0.9 * (1 - 1e-12));
    EXPECT_LE(e.lambda[2], 0.9 * (1 + 3e-3));
    // Without the third run: the same two values, fewer solves.
    int fewer = 0;
    const pardel::detail::SmallestEigenvalues two =
        pardel::detail::smallest_eigenvalues(diagonal_operator(d, free, &fewer), static_cast<long>(n), false);
    EXPECT_EQ(two.lambda[0], e.lambda[0]);
    EXPECT_EQ(two.lambda[1], e.lambda[1]);
    EXPECT_EQ(two.lambda[2], 0);
    EXPECT_LT(fewer, solves);

    pardel::PointAssessment out;
    out.positive = static_cast<long>(n);
    out.lambda_max = 4;
    pardel::detail::describe_minimum(e, 1.0, out);
    EXPECT_EQ(out.nearly_degenerate, soft < 1e-4 * 0.9) << out.note;
    if (out.nearly_degenerate) {
      EXPECT_EQ(out.note.find("a nearly degenerate minimum whose lowest mode is two-fold"), 0u) << out.note;
      EXPECT_NE(out.note.find("a two-dimensional subspace"), std::string::npos) << out.note;
      EXPECT_NEAR(out.soft_motion, std::sqrt(2e-16 / out.lambda_min), 1e-12 * out.soft_motion);
    } else {
      EXPECT_NE(out.note.find("the two smallest eigenvalues lie within a factor 2 of each other (as a two-fold lowest mode makes them), and the third"),
                std::string::npos)
          << out.note;
      EXPECT_EQ(out.soft_motion, 0);
    }
    // Only the two values (the third not computed): the flag cannot be set, and the note says why.
    pardel::PointAssessment blind;
    blind.positive = static_cast<long>(n);
    blind.lambda_max = 4;
    pardel::detail::describe_minimum(two, 1.0, blind);
    EXPECT_FALSE(blind.nearly_degenerate) << blind.note;
    EXPECT_NE(blind.note.find("so their ratio does not tell"), std::string::npos) << blind.note;
  }
  // Distinct smallest eigenvalues (1, 2, 3, ...): no third run, the same solves as without one.
  std::vector<double> d(n);
  for (std::size_t i = 0; i < n; ++i) d[i] = 1 + static_cast<double>(i);
  int with = 0, without = 0;
  const pardel::detail::SmallestEigenvalues a =
      pardel::detail::smallest_eigenvalues(diagonal_operator(d, free, &with), static_cast<long>(n));
  const pardel::detail::SmallestEigenvalues b =
      pardel::detail::smallest_eigenvalues(diagonal_operator(d, free, &without), static_cast<long>(n), false);
  EXPECT_EQ(a.lambda[2], 0);
  EXPECT_EQ(with, without);
  EXPECT_EQ(a.lambda[0], b.lambda[0]);
  EXPECT_EQ(a.lambda[1], b.lambda[1]);
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
TEST(Assessment, AnOrderThreeModelOnNestedLevelsHasTheEigenvaluesOfItsPointAlone) {
  // The shipped minimum-jerk flight through two gates (scenes/min_jerk.toml) at N = 3000 (levels
  // 188, 750, 3000): its node blocks hold positions, velocities and accelerations, whose Hessian
  // entries scale with different powers of h, so its lowest modes change order between levels.
  // The assessment after the nested solve must report the values that the point's own
  // assessment (one level, the built-in start vectors) finds: within their 1e-4 and 3e-3.
  const pardel_model* m = pardel::find_model("min_jerk");
  if (!m) GTEST_SKIP() << "min_jerk is not bundled";
  pardel::Problem p;
  p.model = m;
  p.discretization = pardel::find_discretization(*m, "hermite_gauss(s=3)");
  ASSERT_NE(p.discretization, nullptr);
  p.T = 4;
  p.N = 3000;
  p.q0 = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  p.qN = {4, 0, 1, 0, 0, 0, 0, 0, 0};
  p.knots = {{1.0, {1, 2, 1}}, {3.0, {3, -1, 2}}};
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  ASSERT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  const pardel::PointAssessment alone = pardel::assess_point(p, tr, 1);
  ASSERT_EQ(alone.kind, pardel::PointKind::minimum) << alone.note;
  ASSERT_TRUE(alone.lambda_settled) << alone.note;
  ASSERT_TRUE(s.point.lambda_settled) << s.point.note;
  EXPECT_NEAR(s.point.lambda_min, alone.lambda_min, 2e-4 * alone.lambda_min);
  EXPECT_NEAR(s.point.lambda_next, alone.lambda_next, 6e-3 * alone.lambda_next);
  // At N = 3000 the Hessian's condition (about N^6) is beyond double precision, and both are
  // found in extended precision. The truth: lambda_min falls like 1/N here (N lambda_min = 31.74
  // from N = 100 to 3200), and at N = 200 double precision resolves it. In double, N = 3000 gave
  // 0.0406, four times the value, in both assessments alike.
  EXPECT_NE(s.point.note.find("extended precision"), std::string::npos) << s.point.note;
  pardel::Problem coarse = p;
  coarse.N = 200;
  auto coarse_tr = pardel::linear_guess(coarse);
  const pardel::Summary c = pardel::solve(coarse, pardel::Options{}, coarse_tr);
  ASSERT_TRUE(c.converged()) << c.brief_report();
  ASSERT_EQ(c.point.note.find("extended precision"), std::string::npos) << c.point.note;
  EXPECT_NEAR(3000 * s.point.lambda_min, 200 * c.point.lambda_min, 1e-3 * 200 * c.point.lambda_min);
}
#endif

#ifdef PARDEL_HAVE_ASSESSMENT_MODELS
TEST(Assessment, OnNestedLevelsTheNextEigenvalueMayBeAnotherCoordinates) {
  // Two uncoupled springs (frequencies 1 and 2) on T = 1.2 at N = 12800 (levels 800, 3200,
  // 12800): the smallest eigenvalue is the stiff spring's first mode, the next one the soft
  // spring's first mode (below the stiff spring's second), so the two eigenvectors that a
  // coarse level hands to the next one live on different coordinates.
  const int N = 12800;
  const double T = 1.2;
  pardel::Problem p;
  p.model = &twin_spring_model;
  p.discretization = pardel::find_discretization(twin_spring_model, "trapezoid");
  p.T = T;
  p.N = N;
  p.q0 = {0.2, -0.3};
  p.qN = {1, 0.5};
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  ASSERT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  EXPECT_TRUE(s.point.lambda_settled) << s.point.note;
  const double l1 = spring_eigenvalue(1, N, T, 2), l2 = spring_eigenvalue(1, N, T, 1);
  ASSERT_LT(l2, spring_eigenvalue(2, N, T, 2));
  EXPECT_GE(s.point.lambda_min, l1 * (1 - 1e-6));
  EXPECT_LE(s.point.lambda_min, l1 * (1 + 1e-4));
  EXPECT_GE(s.point.lambda_next, l2 * (1 - 1e-6));
  EXPECT_LE(s.point.lambda_next, l2 * (1 + 3e-3));
}
#endif

TEST(Assessment, ItsTimeIsPartOfTheSolvesAndZeroWhereNothingWasAssessed) {
  const pardel::Problem p = hand::problem(hand::harmonic, 1.3, 2, 400, 0.3, -0.7);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_GT(s.assessment_seconds, 0);
  EXPECT_LT(s.assessment_seconds, s.wall_seconds);
  pardel::Options one_step;
  one_step.max_iterations = 1;
  one_step.method = pardel::Method::jacobi;
  auto again = pardel::linear_guess(p);
  const pardel::Summary stopped = pardel::solve(p, one_step, again);
  ASSERT_EQ(stopped.termination, pardel::Termination::max_iterations) << stopped.brief_report();
  EXPECT_EQ(stopped.assessment_seconds, 0) << stopped.point.note;
}

#ifdef PARDEL_HAVE_ASSESSMENT_MODELS

constexpr double kPi = 3.14159265358979323846;


/** The Hessian of the discrete action in the interior unknowns by central second differences of
 *  discrete_action (only the block-tridiagonal band, the rest is zero by construction). */
Eigen::MatrixXd finite_difference_hessian(const pardel::Problem& p, const pardel::Trajectory& at) {
  const int d = p.model->dim, n = (p.N - 1) * d;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  pardel::Trajectory x = at;
  const double e = 1e-4;
  auto S = [&](int i, double si, int j, double sj) {
    x.q[static_cast<std::size_t>(d + i)] += si;
    x.q[static_cast<std::size_t>(d + j)] += sj;
    const double v = pardel::discrete_action(p, x);
    x.q = at.q;
    return v;
  };
  const double S0 = pardel::discrete_action(p, x);
  for (int i = 0; i < n; ++i) {
    H(i, i) = (S(i, e, i, 0) - 2 * S0 + S(i, -e, i, 0)) / (e * e);
    for (int j = i + 1; j < n && j < (i / d + 2) * d; ++j) {
      H(i, j) = H(j, i) = (S(i, e, j, e) - S(i, e, j, -e) - S(i, -e, j, e) + S(i, -e, j, -e)) / (4 * e * e);
    }
  }
  return H;
}

pardel::Problem kepler_problem(int N) {
  pardel::Problem p;
  p.model = &kepler_arc_model;
  p.discretization = pardel::find_discretization(kepler_arc_model, "midpoint");
  p.T = 2.5 * kPi;  // one and a quarter turns of the circular orbit of radius 1 (period 2 pi)
  p.N = N;
  p.q0 = {1, 0};
  p.qN = {0, 1};
  return p;
}

/** The circular orbit sampled at the nodes: the exact motion, a saddle of the action. */
pardel::Trajectory circle(const pardel::Problem& p) {
  pardel::Trajectory tr = pardel::linear_guess(p);
  for (int k = 0; k <= p.N; ++k) {
    const double t = p.T * k / p.N;
    tr.node(k)[0] = std::cos(t);
    tr.node(k)[1] = std::sin(t);
  }
  return tr;
}

pardel::Problem swing_problem(int N) {
  pardel::Problem p;
  p.model = &double_swing_model;
  p.discretization = pardel::find_discretization(double_swing_model, "midpoint");
  p.T = 0.4;
  p.N = N;
  p.q0 = {0.3, -0.2};
  p.qN = {0.5, 0.4};
  return p;
}

/** A minimum-acceleration path in 3-D (order 2) through two knots at t = 1/3 and 2/3. */
pardel::Problem min_accel_problem(int N) {
  pardel::Problem p;
  p.model = &min_accel3_model;
  p.discretization = pardel::find_discretization(min_accel3_model, "trapezoid(alpha=1)");
  p.T = 1;
  p.N = N;
  p.q0 = {0, 0, 0, 1, 0, -1};
  p.qN = {1, 2, 0.5, 0, 1, 0};
  p.knots = {{1.0 / 3, {2, -1, 1}}, {2.0 / 3, {-1, 1, 3}}};
  return p;
}

TEST(Assessment, InertiaAgreesWithAFiniteDifferenceHessian) {
  // At the Kepler circle (a saddle) and at the double-pendulum solution (a minimum).
  const auto kp = kepler_problem(40);
  const auto at_circle = circle(kp);
  const pardel::PointAssessment a = pardel::assess_point(kp, at_circle, 1);
  const Eigen::VectorXd ek = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(finite_difference_hessian(kp, at_circle))
                                 .eigenvalues();
  long negative = 0;
  for (int i = 0; i < ek.size(); ++i) negative += ek[i] < 0 ? 1 : 0;
  ASSERT_GT(negative, 0) << "past the conjugate point the circle is not a minimum";
  EXPECT_EQ(a.kind, pardel::PointKind::saddle) << a.note;
  EXPECT_EQ(a.negative, negative);
  EXPECT_EQ(a.positive, ek.size() - negative);
  EXPECT_EQ(a.zero, 0);

  const auto sp = swing_problem(40);
  auto swing = pardel::linear_guess(sp);
  const pardel::Summary s = pardel::solve(sp, pardel::Options{}, swing);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  const Eigen::VectorXd es =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(finite_difference_hessian(sp, swing)).eigenvalues();
  EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  EXPECT_EQ(s.point.positive, es.size());
  EXPECT_GT(es[0], 0);
  // The smallest eigenvalue to the accuracy of second differences (relative ~1e-6 here); the next
  // one is a Ritz value of a few subspace iterations: from above, within 1 %.
  EXPECT_TRUE(s.point.lambda_settled) << s.point.note;
  EXPECT_EQ(s.point.note.find("upper bounds"), std::string::npos) << s.point.note;
  EXPECT_NEAR(s.point.lambda_min, es[0], 1e-4 * es[0]);
  EXPECT_GE(s.point.lambda_next, es[1] * (1 - 1e-4));
  EXPECT_LE(s.point.lambda_next, es[1] * 1.01) << es[0] << " " << es[1] << " " << es[2] << " " << es[3];
  EXPECT_GE(s.point.lambda_max, es[es.size() - 1]);  // Gershgorin bounds the largest
  EXPECT_FALSE(s.point.nearly_degenerate);
}

TEST(Assessment, ARepeatedSmallestEigenvalueIsReportedTwice) {
  // Minimum acceleration in 3-D through two knots (order 2: positions and velocities): the three
  // coordinates move alike, so every eigenvalue of the Hessian is triple (the finite differences
  // split them by ~1e-5). The assessment finds the smallest one twice (lambda_next = lambda_min):
  // its second Lanczos run, in the complement of the first one's Ritz vector, still holds the
  // other copies, where one Krylov space would see each distinct eigenvalue once.
  pardel::Problem p = min_accel_problem(60);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  ASSERT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  // The Hessian on the free unknowns: the knots hold the positions (components 0-2) of their nodes.
  const Eigen::MatrixXd H = finite_difference_hessian(p, tr);
  std::vector<int> free;
  for (int i = 0; i < H.rows(); ++i) {
    const int node = i / 6 + 1, component = i % 6;
    if (!((node == 20 || node == 40) && component < 3)) free.push_back(i);
  }
  Eigen::MatrixXd Hf(free.size(), free.size());
  for (std::size_t a = 0; a < free.size(); ++a)
    for (std::size_t b = 0; b < free.size(); ++b) Hf(a, b) = H(free[a], free[b]);
  const Eigen::VectorXd e = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Hf).eigenvalues();
  ASSERT_GT(e[0], 0);
  ASSERT_LT(e[2] - e[0], 1e-4 * e[0]);  // the triple eigenvalue
  ASSERT_GT(e[3], 1.5 * e[0]);           // and a gap after it
  EXPECT_EQ(s.point.positive, static_cast<long>(free.size()));
  EXPECT_TRUE(s.point.lambda_settled) << s.point.note;
  EXPECT_EQ(s.point.note.find("upper bounds"), std::string::npos) << s.point.note;
  EXPECT_GE(s.point.lambda_min, e[0] * (1 - 1e-5));
  EXPECT_GE(s.point.lambda_next, e[1] * (1 - 1e-5));
  EXPECT_NEAR(s.point.lambda_min, e[0], 1e-4 * e[0]);
  EXPECT_NEAR(s.point.lambda_next, e[1], 3e-3 * e[1]);  // settled to 3e-3 (docs/solvers.md)
  EXPECT_FALSE(s.point.nearly_degenerate);
  // The two nearly equal: the third is computed too, and found nearly equal as well.
  EXPECT_NE(s.point.note.find("the three smallest eigenvalues lie within factors 2 of each other (the third "), std::string::npos)
      << s.point.note;
}

TEST(Assessment, ARepeatedSmallestEigenvalueIsReportedTwiceOnNestedLevels) {
  // The same model at N = 3600 (levels 225, 900, 3600), too large for a dense Hessian: the
  // eigenvalue is still triple (the coordinates move alike), so the two smallest are equal, and
  // the smallest agrees with the assessment of the same point by itself (assess_point: one
  // level, the built-in start vectors).
  pardel::Problem p = min_accel_problem(3600);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  ASSERT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  EXPECT_TRUE(s.point.lambda_settled) << s.point.note;
  const pardel::PointAssessment alone = pardel::assess_point(p, tr, 1);
  ASSERT_EQ(alone.kind, pardel::PointKind::minimum) << alone.note;
  ASSERT_TRUE(alone.lambda_settled) << alone.note;
  EXPECT_NEAR(s.point.lambda_min, alone.lambda_min, 2e-4 * alone.lambda_min);
  EXPECT_NEAR(s.point.lambda_next, s.point.lambda_min, 3e-3 * s.point.lambda_min);
  EXPECT_NEAR(alone.lambda_next, alone.lambda_min, 3e-3 * alone.lambda_min);
}

TEST(Assessment, NewtonDoesNotStopAtTheSaddleOfAKeplerArc) {
  // Started on the exact motion past the conjugate point, the default solve must not report the
  // saddle next to it as converged: it leaves along negative curvature to a lower action.
  const auto p = kepler_problem(201);
  auto tr = circle(p);
  const double saddle_action = pardel::discrete_action(p, tr);
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  ASSERT_NE(s.point.kind, pardel::PointKind::unknown) << s.brief_report();
  if (s.converged()) {
    EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.brief_report() << "\n" << s.point.note;
    EXPECT_LT(s.action, saddle_action - 1e-3 * std::fabs(saddle_action)) << s.brief_report();
    EXPECT_LE(pardel::residual_norm(p, tr), s.tolerance);
    // What the summary says, recomputed from the returned trajectory.
    const pardel::PointAssessment again = pardel::assess_point(p, tr, 1);
    EXPECT_EQ(again.kind, pardel::PointKind::minimum);
    EXPECT_EQ(again.negative, 0);
  } else {
    // Not converged: then the status is not "converged" and the point says what it is.
    EXPECT_NE(s.termination, pardel::Termination::converged);
  }
}

TEST(Assessment, ALagrangianWithoutVelocitiesIsRefusedBeforeSolving) {
  pardel::Problem p;
  p.model = &no_velocity_model;
  p.discretization = pardel::find_discretization(no_velocity_model, "trapezoid");
  p.T = 2;
  p.N = 83;
  p.q0 = {0, 1};
  p.qN = {1, 2};
  auto tr = pardel::linear_guess(p);
  const auto before = tr.q;
  const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input) << s.brief_report();
  EXPECT_NE(s.message.find("no_velocity"), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("degenerate"), std::string::npos) << s.message;
  EXPECT_EQ(tr.q, before);  // nothing was solved
  // Its certificate, asked for anyway, has no NaN in it.
  const pardel::Certificate c = pardel::certify(p, tr, 1);
  EXPECT_FALSE(std::isnan(c.jacobi_spectral_radius));
  EXPECT_EQ(c.report().find("nan"), std::string::npos) << c.report();
}

/** The clamped cubic spline of one coordinate through (tau_i, P_i), i = 0..3, equally spaced. */
double clamped_spline(const double tau[4], const double P[4], double m0, double m3, double t) {
  const double L = tau[1] - tau[0];
  // C2 at the interior knots: 8 m1 + 2 m2 = 6 (P2 - P0) / L - 2 m0, 2 m1 + 8 m2 = 6 (P3 - P1) / L - 2 m3.
  Eigen::Matrix2d A;
  A << 8, 2, 2, 8;
  const Eigen::Vector2d m = A.partialPivLu().solve(Eigen::Vector2d(6 * (P[2] - P[0]) / L - 2 * m0, 6 * (P[3] - P[1]) / L - 2 * m3));
  const double slopes[4] = {m0, m[0], m[1], m3};
  const int i = t < tau[1] ? 0 : t < tau[2] ? 1 : 2;
  const double s = (t - tau[i]) / L, s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * P[i] + (s3 - 2 * s2 + s) * L * slopes[i] + (-2 * s3 + 3 * s2) * P[i + 1] +
         (s3 - s2) * L * slopes[i + 1];
}

/** The order-4 plate pair on [0, 1] between two rests (N to be set). */
pardel::Problem plate_pair_problem() {
  pardel::Problem p;
  p.model = &plate_pair_model;
  p.discretization = &plate_pair_model.discretizations[0];
  p.T = 1;
  p.q0 = {0, 0, 1, 0, 0, 0, 0, 0};
  p.qN = {1, -1, 0, 0, 0, 0, 0, 0};
  return p;
}

TEST(Assessment, ARegularOrderFourModelIsAcceptedOnFineGrids) {
  // D12 Ld of an order-4 discretization pairs derivatives whose entries differ by h^6: unscaled,
  // its smallest relative singular value fell below the degeneracy threshold from h = 1/16 on.
  pardel::Problem p = plate_pair_problem();
  for (int N : {8, 64, 256}) {
    p.N = N;
    auto tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
    EXPECT_NE(s.termination, pardel::Termination::invalid_input) << "N = " << N << ": " << s.message;
    EXPECT_EQ(s.termination, pardel::Termination::converged) << "N = " << N << ": " << s.brief_report();
  }
}

TEST(Assessment, ConvergedSaysWhenRoundOffHidesWhetherTheEquationsHold) {
  // The same order-4 model: its Hessian's entries span h^-7 to h^-1, so at N = 256 the round-off
  // of the DEL residual (eps |H| |q| per node, in the kernels' cancellations) exceeds the DEL
  // terms themselves. The solve still ends at its round-off level, and the message must not
  // call the equations resolved; at N = 8 they are resolved to far below their scale.
  pardel::Problem p = plate_pair_problem();
  const std::string unresolved = "so the residual does not show that the DEL equations hold";
  p.N = 8;
  auto coarse = pardel::linear_guess(p);
  const pardel::Summary c = pardel::solve(p, pardel::Options{}, coarse);
  ASSERT_TRUE(c.converged()) << c.brief_report();
  EXPECT_EQ(c.message.find(unresolved), std::string::npos) << c.message;
  p.N = 256;
  auto fine = pardel::linear_guess(p);
  const pardel::Summary f = pardel::solve(p, pardel::Options{}, fine);
  ASSERT_TRUE(f.converged()) << f.brief_report();
  EXPECT_NE(f.message.find(unresolved), std::string::npos) << f.message;
  EXPECT_NE(f.point.note.find("round-off alone can move the trajectory"), std::string::npos) << f.point.note;
}

TEST(Assessment, MinimumAccelerationThroughKnotsConvergesToTheClampedSpline) {
  pardel::Problem p = min_accel_problem(300);
  const double tau[4] = {0, 1.0 / 3, 2.0 / 3, 1};
  std::vector<double> errors;
  for (int N : {300, 600, 1200}) {
    p.N = N;
    auto tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
    // Converged with the default tolerance at every N (not "stalled" at the round-off level).
    ASSERT_EQ(s.termination, pardel::Termination::converged) << "N = " << N << ": " << s.brief_report();
    EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
    double worst = 0;
    for (int c = 0; c < 3; ++c) {
      const double P[4] = {p.q0[c], p.knots[0].q[c], p.knots[1].q[c], p.qN[c]};
      for (int k = 0; k <= p.N; ++k)
        worst = std::max(worst, std::fabs(tr.node(k)[c] - clamped_spline(tau, P, p.q0[3 + c], p.qN[3 + c], tr.t[k])));
    }
    errors.push_back(worst);
  }
  // The discrete paths converge to the spline at the discretization's second order.
  EXPECT_LT(errors[0], 1e-4);
  EXPECT_NEAR(errors[0] / errors[1], 4.0, 0.2) << errors[0] << " " << errors[1];
  EXPECT_NEAR(errors[1] / errors[2], 4.0, 0.2) << errors[1] << " " << errors[2];
}

TEST(Assessment, DoublePendulumSwingConvergesOnTheRequestedLargeGrid) {
  std::vector<pardel::Trajectory> solutions;
  for (int N : {1000, 2000, 200000}) {
    const auto p = swing_problem(N);
    auto tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
    ASSERT_EQ(s.termination, pardel::Termination::converged) << "N = " << N << ": " << s.brief_report();
    ASSERT_EQ(tr.N, N);
    EXPECT_EQ(s.N, N);
    EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
    solutions.push_back(tr);
  }
  // Second order: the N = 1000 and 2000 solutions differ from the N = 2e5 one (at their common
  // nodes) by errors in the ratio 4.
  auto deviation = [&](const pardel::Trajectory& coarse) {
    const int stride = 200000 / coarse.N;
    double worst = 0;
    for (int k = 0; k <= coarse.N; ++k)
      for (int a = 0; a < 2; ++a)
        worst = std::max(worst, std::fabs(coarse.node(k)[a] - solutions[2].node(k * stride)[a]));
    return worst;
  };
  const double e1000 = deviation(solutions[0]), e2000 = deviation(solutions[1]);
  EXPECT_LT(e2000, 1e-4);
  EXPECT_NEAR(e1000 / e2000, 4.0, 0.2) << e1000 << " " << e2000;
}

#else
TEST(Assessment, NeedsTheGenerator) { GTEST_SKIP() << "the test models need pardel-gen (GiNaC)"; }
#endif

}  // namespace
