/**
 * @file test_convergence_order.cpp
 * Errors against exact continuous solutions shrink at each discretization's order as N grows:
 * harmonic oscillator (trapezoid, midpoint: 2), Bratu (trapezoid: 2), and the order-2 test model
 * beam4, x'''' + x = 0 (trapezoid(alpha=1): 2, gauss2: 4). The observed order log2(e_N / e_2N)
 * must lie within 0.3 of the nominal one.
 */
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"
#ifdef PARDEL_HAVE_BEAM4
#include "beam4.hpp"
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

}  // namespace
