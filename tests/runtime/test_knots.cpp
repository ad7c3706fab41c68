/**
 * @file test_knots.cpp
 * Interpolation constraints (seed Section 5.3, eq. eq2-interpolation): the discrete solution of
 * L = q''^2/2 with knots against a clamped cubic spline through the same points computed
 * independently (a dense solve of the spline's interpolation and continuity equations), second
 * order convergence for trapezoid(alpha=1) (fourth for the bundled gauss2), knots held exactly,
 * order-1 knots fixing the whole node, and knots off the grid rejected with a clear message.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

/** Clamped cubic spline through (x_i, y_i) with end slopes s0, s1: 4 coefficients per piece. */
struct Spline {
  std::vector<double> x;
  Eigen::VectorXd c;
  Spline(std::vector<double> xs, const std::vector<double>& y, double s0, double s1) : x(std::move(xs)) {
    const int m = static_cast<int>(x.size()) - 1;
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(4 * m, 4 * m);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(4 * m);
    int row = 0;
    auto basis = [](double t, int der, int p) {  // d^der/dt^der of t^p
      double v = 1;
      for (int i = 0; i < der; ++i) v *= (p - i);
      return p - der < 0 ? 0.0 : v * std::pow(t, p - der);
    };
    for (int i = 0; i < m; ++i) {
      const double hi = x[i + 1] - x[i];
      for (int p = 0; p < 4; ++p) A(row, 4 * i + p) = basis(0, 0, p);
      b[row++] = y[i];
      for (int p = 0; p < 4; ++p) A(row, 4 * i + p) = basis(hi, 0, p);
      b[row++] = y[i + 1];
      if (i + 1 < m)
        for (int der = 1; der <= 2; ++der) {
          for (int p = 0; p < 4; ++p) {
            A(row, 4 * i + p) = basis(hi, der, p);
            A(row, 4 * (i + 1) + p) = -basis(0, der, p);
          }
          b[row++] = 0;
        }
    }
    for (int p = 0; p < 4; ++p) A(row, p) = basis(0, 1, p);
    b[row++] = s0;
    for (int p = 0; p < 4; ++p) A(row, 4 * (m - 1) + p) = basis(x[m] - x[m - 1], 1, p);
    b[row++] = s1;
    c = A.fullPivLu().solve(b);
  }
  double operator()(double t) const {
    int i = 0;
    while (i + 2 < static_cast<int>(x.size()) && t > x[i + 1]) ++i;
    const double u = t - x[i];
    return c[4 * i] + u * (c[4 * i + 1] + u * (c[4 * i + 2] + u * c[4 * i + 3]));
  }
};

// The residual of an order-2 model has terms of size ~12 |q| / h^3, so its round-off level is
// ~16 eps 12 |q| / h^3; the spans and tolerances below keep tol well above it.
const std::vector<double> kKnotT = {0.0, 1.0, 2.0, 3.0};
const std::vector<double> kKnotY = {0.0, 0.5, -0.5, 1.0};

pardel::Problem spline_problem(int N) {
  pardel::Problem p;
  p.model = &hand::spline;
  p.discretization = &hand::spline.discretizations[0];
  p.params = {1.0};  // alpha = 1
  p.T = 3;
  p.N = N;
  p.q0 = {0.0, 1.0};  // x(0) = 0, x'(0) = 1
  p.qN = {1.0, 0.0};  // x(1) = 1, x'(1) = 0
  p.knots = {{1.0, {0.5}}, {2.0, {-0.5}}};
  return p;
}

double max_error(const pardel::Problem& p, const pardel::Trajectory& tr, const Spline& s, int coord, int stride) {
  double e = 0;
  for (int k = 0; k <= p.N; ++k) e = std::max(e, std::fabs(tr.node(k)[coord * stride] - s(tr.t[k])));
  return e;
}

TEST(Knots, SplineWithKnotsMatchesIndependentCubicSpline) {
  const Spline exact(kKnotT, kKnotY, 1.0, 0.0);
  double previous = 0;
  for (int N : {30, 60, 120}) {
    const auto p = spline_problem(N);
    auto traj = pardel::linear_guess(p);
    pardel::Options opt;
    opt.method = pardel::Method::newton;
    opt.tol = 1e-8;
    const auto s = pardel::solve(p, opt, traj);
    ASSERT_TRUE(s.converged()) << s.brief_report();
    EXPECT_LE(pardel::residual_norm(p, traj), 1e-8);
    // Knots hold exactly.
    EXPECT_EQ(traj.node(N / 3)[0], 0.5);
    EXPECT_EQ(traj.node(2 * N / 3)[0], -0.5);
    const double err = max_error(p, traj, exact, 0, 1);
    EXPECT_LT(err, 20.0 / (N * N)) << "N = " << N;
    if (previous > 0) EXPECT_NEAR(std::log2(previous / err), 2.0, 0.25) << "N = " << N;
    previous = err;
  }
}

TEST(Knots, JacobiNewtonHoldsKnotsAndAgreesWithNewton) {
  const auto p = spline_problem(12);
  pardel::Options nopt;
  nopt.method = pardel::Method::newton;
  nopt.tol = 1e-10;
  auto ref = pardel::linear_guess(p);
  ASSERT_TRUE(pardel::solve(p, nopt, ref).converged());
  pardel::Options opt;
  opt.threads = 1;
  opt.tol = 1e-9;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_EQ(traj.node(4)[0], 0.5);
  EXPECT_EQ(traj.node(8)[0], -0.5);
  for (std::size_t i = 0; i < traj.q.size(); ++i) EXPECT_NEAR(traj.q[i], ref.q[i], 1e-6);
}

TEST(Knots, OrderOneKnotFixesTheWholeNode) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.params = {1.0};
  p.N = 20;
  p.q0 = {0.0};
  p.qN = {0.0};
  p.knots = {{0.5, {0.25}}};
  pardel::Options opt;
  opt.method = pardel::Method::newton;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_EQ(traj.node(10)[0], 0.25);
  // Each half is the exact discrete solution of its own boundary-value problem.
  const double h = 0.05, th = std::acos(1 - h * h / 2);
  for (int k = 0; k <= 10; ++k) EXPECT_NEAR(traj.node(k)[0], 0.25 * std::sin(k * th) / std::sin(10 * th), 1e-10);
}

TEST(Knots, KnotOffTheGridIsInvalidInput) {
  auto p = spline_problem(30);
  p.knots[1].t = 2.13;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, pardel::Options{}, traj);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("knot 1 at t = 2.13"), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("nearest nodes: 21"), std::string::npos) << s.message;
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
// trapezoid(alpha=1) converges at order 2; gauss2 integrates q''^2 of a cubic Hermite piece
// exactly, and the cubic spline through the knots is such a piecewise cubic, so gauss2 reproduces
// it up to round-off (its order 4 is measured on a non-polynomial solution in
// test_convergence_order.cpp).
TEST(Knots, BundledSplineConvergesAtEachDiscretizationsOrder) {
  const pardel_model* m = pardel::find_model("spline");
  if (!m) GTEST_SKIP() << "spline is not bundled";
  const Spline sx(kKnotT, kKnotY, 1.0, 0.0);
  const Spline sy(kKnotT, {0.0, -0.25, 0.75, 0.5}, 0.0, -1.0);
  for (auto [name, order] : {std::pair<const char*, double>{"trapezoid(alpha=1)", 2.0}, {"gauss2", 4.0}}) {
    const pardel_discretization* disc = pardel::find_discretization(*m, name);
    if (!disc) continue;
    double previous = 0;
    for (int N : {24, 48, 96}) {
      pardel::Problem p;
      p.model = m;
      p.discretization = disc;
      p.T = 3;
      p.N = N;
      p.q0 = {0.0, 0.0, 1.0, 0.0};  // x, y, x', y'
      p.qN = {1.0, 0.5, 0.0, -1.0};
      p.knots = {{1.0, {0.5, -0.25}}, {2.0, {-0.5, 0.75}}};
      auto traj = pardel::linear_guess(p);
      pardel::Options opt;
      opt.method = pardel::Method::newton;
      opt.tol = 1e-8;  // above the round-off level ~16 eps 12 |q| / h^3 of an order-2 residual
      const auto s = pardel::solve(p, opt, traj);
      ASSERT_TRUE(s.converged()) << name << " N = " << N << ": " << s.brief_report();
      double err = 0;
      for (int k = 0; k <= N; ++k)
        err = std::max({err, std::fabs(traj.node(k)[0] - sx(traj.t[k])), std::fabs(traj.node(k)[1] - sy(traj.t[k]))});
      if (order == 2.0 && previous > 0) EXPECT_NEAR(std::log2(previous / err), 2.0, 0.3) << name << " N = " << N;
      if (order == 4.0) EXPECT_LT(err, 1e-8) << name << " N = " << N;
      previous = err;
    }
  }
}
#endif

}  // namespace
