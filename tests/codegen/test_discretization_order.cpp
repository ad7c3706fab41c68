// Measured consistency orders of the discretizations: along exact solutions of test Lagrangians,
// |L_d(q(t0), q(t0+h)) - L_d^exact| ~ C h^(r+1); the slope of log(error) against log(h) over a
// range of h gives r + 1. Exact discrete Lagrangians come from closed forms (harmonic oscillator,
// x'''' = x) or from GiNaC's exact integration of polynomial solutions (time-dependent cases).
// Everything is evaluated by GiNaC with 40 digits, so rounding does not touch the slopes.
// The hermite_gauss family is also checked piece by piece: its Hermite basis and Gauss-Legendre
// rules, and its equality with gauss2 at order 2 with two points.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "pardel_codegen/discretize.hpp"
#include "pardel_codegen/lag_parser.hpp"

namespace {

using GiNaC::ex;
using GiNaC::numeric;
using pardel_codegen::Gauss2Positions;
using pardel_codegen::KernelSymbols;
using pardel_codegen::LagModel;

/** An exact solution on [t0, t0 + h] and its exact action there, for a given h. */
struct ExactInterval {
  ex t0;
  std::vector<ex> q0, q1;  ///< [x, x', ...] up to order - 1
  ex action;               ///< the exact discrete Lagrangian
};

double evaluate(const ex& e) {
  ex v = e.evalf();
  return GiNaC::ex_to<numeric>(v).to_double();
}

/** Least-squares slope of log(err) against log(h). */
double fitted_slope(const std::vector<double>& hs, const std::vector<double>& errs) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(hs.size());
  for (std::size_t i = 0; i < hs.size(); ++i) {
    const double x = std::log(hs[i]), y = std::log(errs[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

/** The measured r + 1 of discretization `disc` of `model` against `exact(h)`. */
template <class Exact>
double measured_slope(const LagModel& model, std::size_t disc, Exact exact,
                      Gauss2Positions positions = Gauss2Positions::hermite) {
  GiNaC::Digits = 40;
  KernelSymbols s(model);
  const ex Ld = pardel_codegen::discrete_lagrangian(model, model.discretizations.at(disc), s, positions);
  std::vector<double> hs, errs;
  for (int k = 0; k < 5; ++k) {  // h = 1/20 ... 1/320: the asymptotic range for these problems
    const ex h = numeric(1, 20) / GiNaC::pow(numeric(2), k);
    ExactInterval x = exact(h);
    GiNaC::exmap at;
    at[s.h] = h;
    at[s.t0] = x.t0;
    at[s.t1] = x.t0 + h;
    for (std::size_t i = 0; i < x.q0.size(); ++i) {
      at[s.q0[i]] = x.q0[i];
      at[s.q1[i]] = x.q1[i];
    }
    for (const auto& p : model.params) at[p.symbol] = numeric(p.default_value);
    const double err = std::fabs(evaluate(Ld.subs(at, GiNaC::subs_options::no_pattern) - x.action));
    hs.push_back(evaluate(h));
    errs.push_back(err);
  }
  for (double e : errs) EXPECT_GT(e, 0.0) << "the error vanished: this test cannot measure an order";
  if (std::getenv("PARDEL_ORDER_DEBUG")) { for (std::size_t i = 0; i < errs.size(); ++i) std::printf("h=%g err=%.6e\n", hs[i], errs[i]); }
  return fitted_slope(hs, errs);
}

const double kSlopeTolerance = 0.25;

// ---- Order 1: the harmonic oscillator L = (x'^2 - x^2)/2, exact solution through q0, q1.
LagModel harmonic() {
  return pardel_codegen::parse_lag("model osc\ncoords x\nL = 1/2*(x'^2 - x^2)\ndiscretizations trapezoid midpoint\n",
                                   "osc.lag");
}
ExactInterval harmonic_exact(const ex& h) {
  // Closed form: L_d^e(q0, q1) = ((q0^2 + q1^2) cos h - 2 q0 q1) / (2 sin h).
  // x = cos t + sin t (for x = 0.7 cos t + 0.5 sin t the h^3 term of the error nearly cancels).
  const ex q0 = 1, q1 = GiNaC::cos(h) + GiNaC::sin(h);
  return {0, {q0}, {q1}, ((q0 * q0 + q1 * q1) * GiNaC::cos(h) - 2 * q0 * q1) / (2 * GiNaC::sin(h))};
}

TEST(DiscretizationOrder, TrapezoidIsOrderTwo) {
  EXPECT_NEAR(measured_slope(harmonic(), 0, harmonic_exact), 3.0, kSlopeTolerance);
}

TEST(DiscretizationOrder, MidpointIsOrderTwo) {
  EXPECT_NEAR(measured_slope(harmonic(), 1, harmonic_exact), 3.0, kSlopeTolerance);
}

// ---- Order 1, time-dependent: L = x'^2/2 - t x, x'' = -t, x = -t^3/6 + t/2 + 1 on [0.7, 0.7 + h].
LagModel forced() {
  return pardel_codegen::parse_lag(
      "model forced\ncoords x\nL = 1/2*x'^2 - t*x\ndiscretizations trapezoid midpoint\n", "forced.lag");
}
ExactInterval forced_exact(const ex& h) {
  GiNaC::symbol t("t");
  const ex x = -GiNaC::pow(t, 3) / 6 + t / 2 + 1;
  const ex L = GiNaC::pow(x.diff(t), 2) / 2 - t * x;
  const ex t0 = numeric(7, 10);
  const ex action = GiNaC::integral(t, t0, t0 + h, L).eval_integ();
  return {t0, {x.subs(t == t0)}, {x.subs(t == t0 + h)}, action};
}

TEST(DiscretizationOrder, TimeDependentTrapezoidIsOrderTwo) {
  EXPECT_NEAR(measured_slope(forced(), 0, forced_exact), 3.0, kSlopeTolerance);
}

TEST(DiscretizationOrder, TimeDependentMidpointIsOrderTwo) {
  EXPECT_NEAR(measured_slope(forced(), 1, forced_exact), 3.0, kSlopeTolerance);
}

// ---- Order 2: L = (x''^2 - x^2)/2, x'''' = x, exact solution x = cos t + sinh t, whose action on
// [0, h] is -(sin h sinh h + cos h cosh h - 1).
LagModel fourth_order() {
  return pardel_codegen::parse_lag(
      "model quartic\norder 2\ncoords x\nL = 1/2*(x''^2 - x^2)\n"
      "discretizations trapezoid trapezoid(alpha=1/2) gauss2\n",
      "quartic.lag");
}
ExactInterval fourth_order_exact(const ex& h) {
  using GiNaC::cos;
  using GiNaC::cosh;
  using GiNaC::sin;
  using GiNaC::sinh;
  return {0,
          {1, 1},
          {cos(h) + sinh(h), -sin(h) + cosh(h)},
          -(sin(h) * sinh(h) + cos(h) * cosh(h) - 1)};
}

TEST(DiscretizationOrder, SecondOrderTrapezoidAlphaOneIsOrderTwo) {
  EXPECT_NEAR(measured_slope(fourth_order(), 0, fourth_order_exact), 3.0, kSlopeTolerance);
}

TEST(DiscretizationOrder, SecondOrderTrapezoidAlphaHalfIsOrderTwo) {
  EXPECT_NEAR(measured_slope(fourth_order(), 1, fourth_order_exact), 3.0, kSlopeTolerance);
}

TEST(DiscretizationOrder, Gauss2IsOrderFour) {
  EXPECT_NEAR(measured_slope(fourth_order(), 2, fourth_order_exact), 5.0, kSlopeTolerance);
}

// ---- Order 2, time-dependent: L = x''^2/2 - t x, x'''' = t, x = t^5/120 + t^3/6 - t on [0.7, 0.7 + h].
LagModel forced_fourth_order() {
  return pardel_codegen::parse_lag(
      "model forced4\norder 2\ncoords x\nL = 1/2*x''^2 - t*x\ndiscretizations trapezoid gauss2\n", "forced4.lag");
}
ExactInterval forced_fourth_order_exact(const ex& h) {
  GiNaC::symbol t("t");
  const ex x = GiNaC::pow(t, 5) / 120 + GiNaC::pow(t, 3) / 6 - t;
  const ex L = GiNaC::pow(x.diff(t, 2), 2) / 2 - t * x;
  const ex t0 = numeric(7, 10), t1 = t0 + h;
  return {t0,
          {x.subs(t == t0), x.diff(t).subs(t == t0)},
          {x.subs(t == t1), x.diff(t).subs(t == t1)},
          GiNaC::integral(t, t0, t1, L).eval_integ()};
}

TEST(DiscretizationOrder, TimeDependentSecondOrderTrapezoidIsOrderTwo) {
  EXPECT_NEAR(measured_slope(forced_fourth_order(), 0, forced_fourth_order_exact), 3.0, kSlopeTolerance);
}

TEST(DiscretizationOrder, TimeDependentGauss2IsOrderFour) {
  EXPECT_NEAR(measured_slope(forced_fourth_order(), 1, forced_fourth_order_exact), 5.0, kSlopeTolerance);
}

// The seed's printed stage positions Q_i (linear interpolation - h/12 (v1 - v0)), measured the
// same way; docs/discretizations.md reports the result next to the Hermite positions emitted.
// PARDEL_ORDER_DEBUG=1 prints the errors of every measurement.
TEST(DiscretizationOrder, Gauss2WithTheSeedsStagePositions) {
  const double slope = measured_slope(fourth_order(), 2, fourth_order_exact, Gauss2Positions::seed);
  const double forced_slope =
      measured_slope(forced_fourth_order(), 1, forced_fourth_order_exact, Gauss2Positions::seed);
  RecordProperty("slope_quartic", std::to_string(slope));
  RecordProperty("slope_forced", std::to_string(forced_slope));
  std::printf("seed stage positions: slopes %.3f (x''''=x), %.3f (x''''=t)\n", slope, forced_slope);
  // Order 4 on the forced problem; on the linear x'''' = x the error even falls like h^7.
  EXPECT_NEAR(forced_slope, 5.0, kSlopeTolerance);
  EXPECT_GE(slope, 5.0 - kSlopeTolerance);
}

// ---- hermite_gauss(s=S): the Hermite interpolant of degree 2 order - 1 and S-point Gauss-Legendre.

TEST(HermiteGauss, HermiteBasisMatchesTheJetsAtBothEnds) {
  GiNaC::symbol u("u");
  for (int order = 1; order <= 6; ++order) {
    const pardel_codegen::HermiteBasis b = pardel_codegen::hermite_basis(order, u);
    for (int k = 0; k < order; ++k) {
      EXPECT_EQ(b.at[k].degree(u), 2 * order - 1);
      for (int j = 0; j < order; ++j) {
        const ex da = b.at[k].diff(u, j), db = b.bt[k].diff(u, j);
        EXPECT_EQ(da.subs(u == 0), ex(j == k ? 1 : 0)) << "order " << order << " k " << k << " j " << j;
        EXPECT_EQ(da.subs(u == 1), ex(0)) << "order " << order << " k " << k << " j " << j;
        EXPECT_EQ(db.subs(u == 0), ex(0)) << "order " << order << " k " << k << " j " << j;
        EXPECT_EQ(db.subs(u == 1), ex(j == k ? 1 : 0)) << "order " << order << " k " << k << " j " << j;
      }
    }
  }
}

TEST(HermiteGauss, GaussLegendreIsExactUpToDegreeTwoSMinusOne) {
  GiNaC::Digits = 40;
  for (int s = 1; s <= 9; ++s) {
    const pardel_codegen::Quadrature q = pardel_codegen::gauss_legendre(s);
    ASSERT_EQ(static_cast<int>(q.nodes.size()), s);
    for (int i = 1; i < s; ++i) EXPECT_LT(evaluate(q.nodes[i - 1]), evaluate(q.nodes[i])) << "s = " << s;
    for (int d = 0; d <= 2 * s; ++d) {
      ex sum = 0;
      for (int i = 0; i < s; ++i) sum += q.weights[i] * GiNaC::pow(q.nodes[i], d);
      const double err = std::fabs(evaluate(sum - numeric(1, d + 1)));
      if (d < 2 * s) EXPECT_LT(err, 1e-35) << "s = " << s << ", degree " << d;
      else EXPECT_GT(err, 1e-30) << "s = " << s << " integrates degree " << d << " exactly";
    }
  }
}

// At order 2 with two points the family is gauss2: both discrete Lagrangians of a nonlinear,
// time-dependent L with two coordinates agree at random arguments (seeded).
TEST(HermiteGauss, AtOrderTwoWithTwoPointsItIsGauss2) {
  GiNaC::Digits = 40;
  const LagModel m = pardel_codegen::parse_lag(
      "model g\norder 2\ncoords x y\nparam k = 3/2\n"
      "L = 1/2*(x''^2 + y''^2) + k*sin(x)*y'*t + x''*y''*cos(y) - exp(x'/3) + x*y*y''^2\n"
      "discretizations gauss2 hermite_gauss(s=2)\n",
      "g.lag");
  ASSERT_EQ(m.discretizations[1].name, "hermite_gauss(s=2)");
  EXPECT_EQ(m.discretizations[1].consistency_order, m.discretizations[0].consistency_order);
  KernelSymbols s(m);
  const ex a = pardel_codegen::discrete_lagrangian(m, m.discretizations[0], s);
  const ex b = pardel_codegen::discrete_lagrangian(m, m.discretizations[1], s);
  std::mt19937 rng(20240601);
  std::uniform_real_distribution<double> value(-1.5, 1.5), step(0.05, 0.8);
  for (int trial = 0; trial < 20; ++trial) {
    GiNaC::exmap at;
    const double h = step(rng), t0 = value(rng);
    at[s.h] = h;
    at[s.t0] = t0;
    at[s.t1] = t0 + 1.3 * h;
    for (std::size_t i = 0; i < s.q0.size(); ++i) {
      at[s.q0[i]] = value(rng);
      at[s.q1[i]] = value(rng);
    }
    at[s.p[0]] = value(rng);
    const double va = evaluate(a.subs(at, GiNaC::subs_options::no_pattern));
    const double vb = evaluate(b.subs(at, GiNaC::subs_options::no_pattern));
    EXPECT_LE(std::fabs(va - vb), 1e-13 * std::max(1.0, std::fabs(va))) << "trial " << trial << ": " << va << " vs " << vb;
  }
}

/** The measured r + 1 of every discretization of `model` equals its consistency_order + 1. */
template <class Exact>
void expect_reported_orders(const LagModel& model, Exact exact) {
  for (std::size_t d = 0; d < model.discretizations.size(); ++d) {
    const double slope = measured_slope(model, d, exact);
    std::printf("%s, %s: slope %.3f\n", model.name.c_str(), model.discretizations[d].name.c_str(), slope);
    EXPECT_NEAR(slope, model.discretizations[d].consistency_order + 1.0, kSlopeTolerance)
        << model.name << ", " << model.discretizations[d].name;
  }
}

/** The jet [x, x', ..., x^(order-1)] of x(t) at t = at. */
std::vector<ex> jet(const ex& x, const GiNaC::symbol& t, int order, const ex& at) {
  std::vector<ex> out;
  for (int k = 0; k < order; ++k) out.push_back(x.diff(t, k).subs(t == at));
  return out;
}

// ---- Order 1: hermite_gauss(s=1) is the midpoint rule; s = 2 keeps order 2 (linear interpolation).
TEST(HermiteGauss, OrderOneOnTheHarmonicOscillator) {
  const LagModel m = pardel_codegen::parse_lag(
      "model osc\ncoords x\nL = 1/2*(x'^2 - x^2)\ndiscretizations hermite_gauss hermite_gauss(s=2)\n", "osc.lag");
  EXPECT_EQ(m.discretizations[0].name, "hermite_gauss(s=1)");
  expect_reported_orders(m, harmonic_exact);
}

// ---- Order 2: hermite_gauss(s=2) and (s=3) on x'''' = t (both order 4: the interpolant limits s = 3).
TEST(HermiteGauss, OrderTwoOnTheForcedBeam) {
  const LagModel m = pardel_codegen::parse_lag(
      "model forced4\norder 2\ncoords x\nL = 1/2*x''^2 - t*x\ndiscretizations hermite_gauss(s=2) hermite_gauss(s=3)\n",
      "forced4.lag");
  expect_reported_orders(m, forced_fourth_order_exact);
}

// ---- Order 3: L = x'''^2/2 - t x, x'''''' = -t, x = -t^7/5040 + t^5/120 - t on [0.7, 0.7 + h]
// (order 6).
ExactInterval forced_sixth_order_exact(const ex& h) {
  GiNaC::symbol t("t");
  const ex x = -GiNaC::pow(t, 7) / 5040 + GiNaC::pow(t, 5) / 120 - t;
  const ex L = GiNaC::pow(x.diff(t, 3), 2) / 2 - t * x;
  const ex t0 = numeric(7, 10), t1 = t0 + h;
  return {t0, jet(x, t, 3, t0), jet(x, t, 3, t1), GiNaC::integral(t, t0, t1, L).eval_integ()};
}

TEST(HermiteGauss, OrderThreeTimeDependent) {
  const LagModel m = pardel_codegen::parse_lag(
      "model forced6\norder 3\ncoords x\nL = 1/2*x'''^2 - t*x\ndiscretizations hermite_gauss\n",
      "forced6.lag");
  EXPECT_EQ(m.discretizations[0].name, "hermite_gauss(s=3)");
  EXPECT_EQ(m.discretizations[0].consistency_order, 6);
  expect_reported_orders(m, forced_sixth_order_exact);
}

// ---- Order 3, not polynomial: L = (x'''^2 + x^2)/2, x'''''' = x, x = e^t, action (e^(2h) - 1)/2 on [0, h]
// (s = 3 and s = 4: order 6, the interpolant limits s = 4).
TEST(HermiteGauss, OrderThreeExponential) {
  const LagModel m = pardel_codegen::parse_lag(
      "model exp6\norder 3\ncoords x\nL = 1/2*(x'''^2 + x^2)\ndiscretizations hermite_gauss(s=3) hermite_gauss(s=4)\n",
      "exp6.lag");
  EXPECT_EQ(m.discretizations[1].consistency_order, 6);
  expect_reported_orders(m, [](const ex& h) {
    const ex e = GiNaC::exp(h);
    return ExactInterval{0, {1, 1, 1}, {e, e, e}, (GiNaC::exp(2 * h) - 1) / 2};
  });
}

// ---- Order 4: L = x''''^2/2 - t x, x^(8) = t, x = t^9/362880 - t^6/720 + t^3 on [0.7, 0.7 + h]
// (order 8), and L = (x''''^2 - x^2)/2 along x = e^t, whose action vanishes.
ExactInterval forced_eighth_order_exact(const ex& h) {
  GiNaC::symbol t("t");
  const ex x = GiNaC::pow(t, 9) / 362880 - GiNaC::pow(t, 6) / 720 + GiNaC::pow(t, 3);
  const ex L = GiNaC::pow(x.diff(t, 4), 2) / 2 - t * x;
  const ex t0 = numeric(7, 10), t1 = t0 + h;
  return {t0, jet(x, t, 4, t0), jet(x, t, 4, t1), GiNaC::integral(t, t0, t1, L).eval_integ()};
}

TEST(HermiteGauss, OrderFourTimeDependent) {
  const LagModel m = pardel_codegen::parse_lag("model forced8\norder 4\ncoords x\nL = 1/2*x''''^2 - t*x\n", "forced8.lag");
  ASSERT_EQ(m.discretizations.size(), 1u);  // the default of an order-4 model
  EXPECT_EQ(m.discretizations[0].name, "hermite_gauss(s=4)");
  EXPECT_EQ(m.discretizations[0].consistency_order, 8);
  expect_reported_orders(m, forced_eighth_order_exact);
}

TEST(HermiteGauss, OrderFourExponential) {
  const LagModel m = pardel_codegen::parse_lag(
      "model exp8\norder 4\ncoords x\nL = 1/2*(x''''^2 - x^2)\ndiscretizations hermite_gauss(s=4) hermite_gauss(s=5)\n",
      "exp8.lag");
  expect_reported_orders(m, [](const ex& h) {
    const ex e = GiNaC::exp(h);
    return ExactInterval{0, {1, 1, 1, 1}, {e, e, e, e}, 0};
  });
}

}  // namespace

// ---- Galerkin discretizations, s = 1 ... 8: consistency order 2 s on a nonlinear Lagrangian.
// L = u'^2/2 - exp(u) (u'' = -exp(u)) along u = log(2 b^2 / cosh^2(b t)), b = 0.8, whose action on
// [t0, t1] is 2 b^2 [t - 2 tanh(b t)/b] between t0 and t1. The discrete Lagrangian is the
// interval's action made stationary in its interior values: GiNaC solves dS/dz = 0 by Newton's
// method in 80-digit arithmetic from the starting values the kernels use.
namespace galerkin_consistency {

const numeric kB = numeric(4, 5);

ex u_exact(const ex& t) { return GiNaC::log(2 * kB * kB / GiNaC::pow(GiNaC::cosh(kB * t), 2)); }
ex action_exact(const ex& t0, const ex& t1) {
  auto F = [](const ex& t) { return 2 * kB * kB * (t - 2 * GiNaC::tanh(kB * t) / kB); };
  return F(t1) - F(t0);
}

/** |L_d - L_d^exact| at step h from t0 = 0.3. */
double error_at(const LagModel& model, const pardel_codegen::DiscretizationSpec& spec, const numeric& h) {
  KernelSymbols s(model);
  const pardel_codegen::GalerkinInterval gi = pardel_codegen::galerkin_interval(model, spec, s);
  const numeric t0 = numeric(3, 10);
  GiNaC::exmap at;
  at[s.h] = h;
  at[s.t0] = t0;
  at[s.t1] = t0 + h;
  at[s.q0[0]] = u_exact(t0).evalf();
  at[s.q1[0]] = u_exact(t0 + h).evalf();
  const std::size_t M = gi.z.size();
  std::vector<ex> g(M), H(M * M);
  for (std::size_t i = 0; i < M; ++i) g[i] = gi.action.diff(gi.z[i]);
  for (std::size_t i = 0; i < M; ++i)
    for (std::size_t j = 0; j < M; ++j) H[i * M + j] = g[i].diff(gi.z[j]);
  std::vector<ex> z(M);
  for (std::size_t i = 0; i < M; ++i) z[i] = gi.start[i].subs(at, GiNaC::subs_options::no_pattern).evalf();
  for (int it = 0; it < 40 && M > 0; ++it) {
    GiNaC::exmap atz = at;
    for (std::size_t i = 0; i < M; ++i) atz[gi.z[i]] = z[i];
    GiNaC::matrix Hm(static_cast<unsigned>(M), static_cast<unsigned>(M)), gm(static_cast<unsigned>(M), 1);
    for (std::size_t i = 0; i < M; ++i) {
      gm(static_cast<unsigned>(i), 0) = g[i].subs(atz, GiNaC::subs_options::no_pattern).evalf();
      for (std::size_t j = 0; j < M; ++j)
        Hm(static_cast<unsigned>(i), static_cast<unsigned>(j)) = H[i * M + j].subs(atz, GiNaC::subs_options::no_pattern).evalf();
    }
    const GiNaC::matrix step = Hm.inverse().mul(gm);
    for (std::size_t i = 0; i < M; ++i) z[i] = (z[i] - step(static_cast<unsigned>(i), 0)).evalf();
  }
  GiNaC::exmap atz = at;
  for (std::size_t i = 0; i < M; ++i) atz[gi.z[i]] = z[i];
  const ex Ld = gi.action.subs(atz, GiNaC::subs_options::no_pattern);
  return std::fabs(evaluate(Ld - action_exact(t0, t0 + h)));
}

}  // namespace galerkin_consistency

TEST(GalerkinOrder, GaussAndLobattoAreOrderTwoSForSOneToEight) {
  const long saved = GiNaC::Digits;
  GiNaC::Digits = 80;
  std::string line = "discretizations";
  for (int s = 1; s <= 8; ++s) line += " galerkin_gauss(s=" + std::to_string(s) + ") galerkin_lobatto(s=" + std::to_string(s) + ")";
  const LagModel m = pardel_codegen::parse_lag("model liouville\ncoords u\nL = 1/2*u'^2 - exp(u)\n" + line + "\n",
                                               "liouville.lag");
  for (const auto& spec : m.discretizations) {
    std::vector<double> hs, errs;
    for (int k = 0; k < 4; ++k) {  // h = 1/16 ... 1/128
      const numeric h = numeric(1, 16 << k);
      hs.push_back(h.to_double());
      errs.push_back(galerkin_consistency::error_at(m, spec, h));
    }
    for (double e : errs) EXPECT_GT(e, 0.0) << spec.name;
    if (std::getenv("PARDEL_ORDER_DEBUG"))
      std::printf("%s: %.3e %.3e %.3e %.3e slope %.3f\n", spec.name.c_str(), errs[0], errs[1], errs[2], errs[3],
                  fitted_slope(hs, errs));
    EXPECT_NEAR(fitted_slope(hs, errs), spec.consistency_order + 1, kSlopeTolerance) << spec.name;
  }
  GiNaC::Digits = saved;
}

