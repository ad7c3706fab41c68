// Measured consistency orders of the discretizations: along exact solutions of test Lagrangians,
// |L_d(q(t0), q(t0+h)) - L_d^exact| ~ C h^(r+1); the slope of log(error) against log(h) over a
// range of h gives r + 1. Exact discrete Lagrangians come from closed forms (harmonic oscillator,
// x'''' = x) or from GiNaC's exact integration of polynomial solutions (time-dependent cases).
// Everything is evaluated by GiNaC with 40 digits, so rounding does not touch the slopes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
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

}  // namespace
