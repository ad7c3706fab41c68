/**
 * @file test_convergence_order.cpp
 * Errors against exact continuous solutions shrink at each discretization's order as N grows:
 * harmonic oscillator (trapezoid, midpoint: 2), Bratu (trapezoid: 2), and the order-2 test model
 * beam4, x'''' + x = 0 (trapezoid(alpha=1): 2, gauss2: 4), and the order-3 test model jerk_spring
 * along x = cosh t (hermite_gauss: the consistency order each discretization reports).
 * The observed order log2(e_N / e_2N) must lie within 0.3 of the nominal one. The bundled min_jerk
 * and min_snap reproduce their polynomial solutions (degrees 5 and 7) to near round-off.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"
#ifdef PARDEL_HAVE_BEAM4
#include "beam4.hpp"
#endif
#ifdef PARDEL_HAVE_HIGHER_ORDER_MODELS
#include "jerk_spring.hpp"
#endif

namespace {

/** Max nodal error of the coordinate 0 after a Newton solve at each N. */
std::vector<double> errors(pardel::Problem p, const std::vector<int>& Ns, const std::function<double(double)>& exact,
                           double tol = 1e-11) {
  std::vector<double> out;
  for (int N : Ns) {
    p.N = N;
    auto traj = pardel::linear_guess(p);
    pardel::Options opt;
    opt.method = pardel::Method::newton;
    opt.tol = tol;
    const auto s = pardel::solve(p, opt, traj);
    EXPECT_TRUE(s.converged()) << "N = " << N << ": " << s.brief_report();
    double e = 0;
    for (int k = 0; k <= N; ++k) e = std::max(e, std::fabs(traj.node(k)[0] - exact(traj.t[k])));
    out.push_back(e);
  }
  return out;
}

void expect_order(const std::vector<double>& e, double order, const char* what) {
  for (std::size_t i = 1; i < e.size(); ++i)
    EXPECT_NEAR(std::log2(e[i - 1] / e[i]), order, 0.3) << what << ": errors " << e[i - 1] << " -> " << e[i];
}

TEST(ConvergenceOrder, HarmonicTrapezoidAndMidpoint) {
  for (int d = 0; d < 2; ++d) {
    pardel::Problem p;
    p.model = &hand::harmonic;
    p.discretization = &hand::harmonic.discretizations[d];
    p.params = {2.0};
    p.T = 1.2;
    p.q0 = {0.0};
    p.qN = {std::sin(2.0 * 1.2)};
    expect_order(errors(p, {20, 40, 80}, [](double t) { return std::sin(2 * t); }), 2.0,
                 hand::harmonic.discretizations[d].name);
  }
}

TEST(ConvergenceOrder, BratuTrapezoid) {
  const double lambda = 1.0;
  double th = 1;
  for (int i = 0; i < 100; ++i)
    th -= (th - std::sqrt(2 * lambda) * std::cosh(th / 4)) / (1 - std::sqrt(2 * lambda) * std::sinh(th / 4) / 4);
  pardel::Problem p;
  p.model = &hand::bratu;
  p.discretization = &hand::bratu.discretizations[0];
  p.params = {lambda};
  p.q0 = {0.0};
  p.qN = {0.0};
  expect_order(errors(p, {16, 32, 64},
                      [th](double x) { return -2 * std::log(std::cosh((x - 0.5) * th / 2) / std::cosh(th / 4)); }),
               2.0, "bratu trapezoid");
}

#ifdef PARDEL_HAVE_BEAM4
TEST(ConvergenceOrder, OrderTwoModelTrapezoidAlphaOneAndGauss2) {
  const double r = 1 / std::sqrt(2.0), T = 2.0;
  auto x = [r](double t) { return std::exp(r * t) * std::cos(r * t); };
  auto dx = [r](double t) { return r * std::exp(r * t) * (std::cos(r * t) - std::sin(r * t)); };
  for (auto [name, order] : {std::pair<const char*, double>{"trapezoid(alpha=1)", 2.0}, {"gauss2", 4.0}}) {
    pardel::Problem p;
    p.model = &beam4_model;
    p.discretization = pardel::find_discretization(beam4_model, name);
    ASSERT_NE(p.discretization, nullptr) << name;
    p.T = T;
    p.q0 = {x(0), dx(0)};
    p.qN = {x(T), dx(T)};
    expect_order(errors(p, {4, 8, 16}, x), order, name);
  }
}
#endif

/** The jet [x, x', ..., x^(order-1)] of cosh at t (cosh and sinh alternate). */
std::vector<double> cosh_jet(int order, double t) {
  std::vector<double> out;
  for (int k = 0; k < order; ++k) out.push_back(k % 2 == 0 ? std::cosh(t) : std::sinh(t));
  return out;
}

#ifdef PARDEL_HAVE_HIGHER_ORDER_MODELS
// Order 3 along x = cosh t on [0, 5], N = 8 and 16: the observed order of every discretization
// must be the consistency_order its model reports. (Finer grids reach the round-off floor, about
// 5e-10 here: the DEL Hessian of an order-3 model has entries from h^-5 to h^-1.)
TEST(ConvergenceOrder, OrderThreeModelHermiteGauss) {
  const pardel_model* m = &jerk_spring_model;
  for (int d = 0; d < m->ndiscretizations; ++d) {
    pardel::Problem p;
    p.model = m;
    p.discretization = &m->discretizations[d];
    p.T = 5.0;
    p.q0 = cosh_jet(m->order, 0.0);
    p.qN = cosh_jet(m->order, p.T);
    std::vector<double> e;
    for (int N : {8, 16}) {
      p.N = N;
      auto traj = pardel::linear_guess(p);
      pardel::Options opt;
      opt.method = pardel::Method::newton;
      opt.rtol = 1e-15;  // down to the round-off level of the DEL residual
      const auto s = pardel::solve(p, opt, traj);
      EXPECT_TRUE(s.converged()) << "N = " << N << ": " << s.brief_report();
      double err = 0;
      for (int k = 0; k <= N; ++k) err = std::max(err, std::fabs(traj.node(k)[0] - std::cosh(traj.t[k])));
      e.push_back(err);
    }
    std::printf("%s %s: errors %.3e %.3e, order %.2f\n", m->name, m->discretizations[d].name, e[0], e[1],
                std::log2(e[0] / e[1]));
    expect_order(e, m->discretizations[d].consistency_order, m->discretizations[d].name);
  }
}
#endif

#ifdef PARDEL_HAVE_BUNDLED_MODELS
/**
 * The polynomial of degree 2 order - 1 on [0, T] with the jets a (at 0) and b (at T), each
 * [x, x', ..., x^(order-1)]: coefficients from the 2 order end conditions, solved by Eigen.
 */
Eigen::VectorXd end_state_polynomial(int order, double T, const std::vector<double>& a, const std::vector<double>& b) {
  const int n = 2 * order;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd rhs(n);
  for (int k = 0; k < order; ++k) {
    for (int j = k; j < n; ++j) {
      double falling = 1;  // j (j-1) ... (j-k+1)
      for (int i = 0; i < k; ++i) falling *= j - i;
      A(k, j) = j == k ? falling : 0;
      A(order + k, j) = falling * std::pow(T, j - k);
    }
    rhs(k) = a[static_cast<std::size_t>(k)];
    rhs(order + k) = b[static_cast<std::size_t>(k)];
  }
  return A.fullPivLu().solve(rhs);
}

double polynomial_derivative(const Eigen::VectorXd& c, int k, double t) {
  double sum = 0;
  for (int j = static_cast<int>(c.size()) - 1; j >= k; --j) {
    double falling = 1;
    for (int i = 0; i < k; ++i) falling *= j - i;
    sum += falling * c(j) * std::pow(t, j - k);
  }
  return sum;
}

// Minimum jerk (order 3) and minimum snap (order 4) between fixed end states: the exact solutions
// are the polynomials of degree 5 and 7 through those states, which the Hermite interpolant of
// hermite_gauss holds; every stored derivative at every node must match to round-off.
TEST(ConvergenceOrder, MinimumJerkAndSnapArePolynomialsReproducedExactly) {
  for (const char* name : {"min_jerk", "min_snap"}) {
    const pardel_model* m = pardel::find_model(name);
    ASSERT_NE(m, nullptr) << name;
    const int g = m->order, nc = m->ncoords;
    const double T = 1.7;
    std::vector<Eigen::VectorXd> poly;
    pardel::Problem p;
    p.model = m;
    p.discretization = &m->discretizations[0];
    p.T = T;
    p.N = 12;
    p.q0.assign(static_cast<std::size_t>(m->dim), 0.0);
    p.qN.assign(static_cast<std::size_t>(m->dim), 0.0);
    for (int i = 0; i < nc; ++i) {
      std::vector<double> a, b;
      for (int k = 0; k < g; ++k) {
        a.push_back(std::sin(1.0 + i + 0.7 * k));
        b.push_back(std::cos(2.0 * i - 0.3 * k) + k);
        p.q0[static_cast<std::size_t>(k * nc + i)] = a.back();
        p.qN[static_cast<std::size_t>(k * nc + i)] = b.back();
      }
      poly.push_back(end_state_polynomial(g, T, a, b));
    }
    auto traj = pardel::linear_guess(p);
    pardel::Options opt;
    opt.method = pardel::Method::newton;
    opt.rtol = 1e-15;  // down to the round-off level of the DEL residual
    const auto s = pardel::solve(p, opt, traj);
    ASSERT_TRUE(s.converged()) << name << ": " << s.brief_report();
    double worst = 0;
    for (int k = 0; k <= p.N; ++k) {
      for (int d = 0; d < g; ++d) {
        for (int i = 0; i < nc; ++i) {
          const double exact = polynomial_derivative(poly[static_cast<std::size_t>(i)], d, traj.t[static_cast<std::size_t>(k)]);
          worst = std::max(worst, std::fabs(traj.node(k)[d * nc + i] - exact) / std::max(1.0, std::fabs(exact)));
        }
      }
    }
    std::printf("%s: largest relative error of a stored derivative %.2e\n", name, worst);
    // Round-off amplified by the conditioning of the DEL Hessian (entries from h^(1-2 order) to
    // h^-1): measured 1.0e-11 (min_jerk) and 3.0e-9 (min_snap).
    EXPECT_LT(worst, 1e-8) << name;
  }
}
#endif

}  // namespace
