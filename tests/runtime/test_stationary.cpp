/**
 * @file test_stationary.cpp
 * Newton on the DEL residual (method stationary-newton) and the automatic method's second attempt
 * with it: DEL solutions that are saddles of the action, checked against exact discrete motions
 * (the harmonic oscillator and two springs past their conjugate points) and exact continuous ones
 * at second order in h (the oscillator, a circular orbit in a quartic potential), their Morse index against the count of conjugate points, no
 * second attempt for a model with a declared cost, and an honest stall at a fold where no
 * solution is near, and a stall at round-off said as such, with no second attempt (the refusal
 * over MPI ranks: tests/mpi/test_distributed.cpp).
 */
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

#ifdef PARDEL_HAVE_STATIONARY_MODELS
#include "costed_spring.hpp"
#include "hardening_spring.hpp"
#include "quartic_ring.hpp"
#include "twin_spring.hpp"
#endif

namespace {

constexpr double kPi = 3.14159265358979323846;

/** A one-coordinate model's trapezoid from x = 0 to x = 1 in T over N intervals. */
pardel::Problem spring_problem(const pardel_model& model, double T, int N) {
  pardel::Problem p;
  p.model = &model;
  p.discretization = pardel::find_discretization(model, "trapezoid");
  p.params.assign(model.param_defaults, model.param_defaults + model.nparams);
  p.T = T;
  p.N = N;
  p.q0 = {0.0};
  p.qN = {1.0};
  return p;
}

pardel::Problem harmonic_problem(double T, int N) { return spring_problem(hand::harmonic, T, N); }

/** The exact trapezoidal discrete motion of x'' = -omega^2 x from 0 to `end` at node k: the DEL
 *  equations x_{k+1} - 2 x_k + x_{k-1} = -(omega h)^2 x_k give x_k = end sin(theta k)/sin(theta N)
 *  with cos(theta) = 1 - (omega h)^2 / 2. */
double discrete_spring(double omega, double T, int N, int k, double end) {
  const double h = T / N, theta = std::acos(1 - omega * omega * h * h / 2);
  return end * std::sin(theta * k) / std::sin(theta * N);
}

/** max_k |x_k - sin(t_k)/sin(T)|: the distance to the exact motion of x'' = -x from 0 to 1. */
double harmonic_error(const pardel::Problem& p, const pardel::Trajectory& tr) {
  double err = 0;
  for (int k = 0; k <= p.N; ++k) {
    const double t = p.T * k / p.N;
    err = std::max(err, std::fabs(tr.node(k)[0] - std::sin(t) / std::sin(p.T)));
  }
  return err;
}

/** max_k |x_k - the exact discrete motion|. */
double harmonic_discrete_error(const pardel::Problem& p, const pardel::Trajectory& tr) {
  double err = 0;
  for (int k = 0; k <= p.N; ++k) err = std::max(err, std::fabs(tr.node(k)[0] - discrete_spring(1, p.T, p.N, k, 1)));
  return err;
}

pardel::Options automatic_options() {
  pardel::Options o;
  o.threads = 1;
  return o;
}

pardel::Options stationary_options() {
  pardel::Options o;
  o.method = pardel::Method::stationary_newton;
  o.threads = 1;
  return o;
}

TEST(Stationary, ConvergesToTheSaddlePastTheConjugatePointAtSecondOrder) {
  // omega T = 4 > pi: the only DEL solution is a saddle of index 1 (one conjugate point, t = pi).
  double previous = 0;
  for (int N : {100, 200, 400}) {
    const auto p = harmonic_problem(4.0, N);
    auto tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, stationary_options(), tr);
    ASSERT_TRUE(s.converged()) << s.brief_report();
    EXPECT_EQ(s.method, pardel::Method::stationary_newton);
    EXPECT_LE(s.iterations, 3) << "a linear problem: one Newton step per level";
    EXPECT_EQ(s.point.kind, pardel::PointKind::saddle) << s.point.note;
    EXPECT_EQ(s.point.negative, 1) << s.point.note;
    EXPECT_LE(pardel::residual_norm(p, tr), s.tolerance);
    EXPECT_LT(harmonic_discrete_error(p, tr), 1e-9) << "N " << N;
    const double err = harmonic_error(p, tr);
    if (previous > 0) EXPECT_NEAR(previous / err, 4.0, 0.2) << "second order from N/2 to N = " << N;
    previous = err;
  }
}

TEST(Stationary, TheAutomaticMethodFindsTheSaddleWhereNoMinimumExists) {
  // A model without a declared cost: the minimizing Newton finds the action unbounded below, and
  // the second attempt on the residual returns the motion, saying both.
  const auto p = harmonic_problem(4.0, 200);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, automatic_options(), tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_EQ(s.method, pardel::Method::stationary_newton);
  EXPECT_NE(s.message.find("after the minimizing Newton found no minimum of the action"), std::string::npos)
      << s.message;
  EXPECT_NE(s.message.find("diverged"), std::string::npos) << s.message;
  EXPECT_EQ(s.point.kind, pardel::PointKind::saddle);
  EXPECT_LT(harmonic_discrete_error(p, tr), 1e-9);
  // The history holds both attempts, numbered on.
  ASSERT_GE(s.history.size(), 2u);
  for (std::size_t i = 1; i < s.history.size(); ++i) EXPECT_GE(s.history[i].iteration, s.history[i - 1].iteration);
  EXPECT_EQ(s.history.back().iteration, s.iterations);
}

/** The oscillator over T solved with `o` and an absolute tolerance far below the residual's
 *  round-off level: the solve stalls, at the exact discrete motion all the same. */
pardel::Summary stall_below_round_off(double T, pardel::Options o) {
  const auto p = harmonic_problem(T, 200);
  o.tol = 1e-30;
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, o, tr);
  EXPECT_EQ(s.termination, pardel::Termination::stalled) << s.brief_report();
  EXPECT_LE(s.residual, 10 * s.residual_floor) << s.brief_report();
  EXPECT_LT(harmonic_discrete_error(p, tr), 1e-12);
  return s;
}

TEST(Stationary, AToleranceBelowRoundOffStallsOnceAndSaysSo) {
  // The minimizing Newton stalls at a solution as exact as double precision allows. The automatic
  // method says so and makes no second attempt, which could reach no smaller tolerance.
  const pardel::Summary s = stall_below_round_off(2.0, automatic_options());
  EXPECT_EQ(s.method, pardel::Method::newton);
  EXPECT_NE(s.message.find("cannot be reached in double precision"), std::string::npos) << s.message;
  EXPECT_EQ(s.message.find("Newton on the DEL residual"), std::string::npos) << "no second attempt: " << s.message;
}

TEST(Stationary, AStallAtRoundOffIsNoFold) {
  // The saddle past the conjugate point: stationary-newton stalls at the discrete motion and says
  // that the residual is at round-off, not that no solution is near.
  const pardel::Summary s = stall_below_round_off(4.0, stationary_options());
  EXPECT_NE(s.message.find("at the round-off level of this problem"), std::string::npos) << s.message;
  EXPECT_EQ(s.message.find("fold"), std::string::npos) << s.message;
}

TEST(Stationary, AMinimumIsFoundAsBeforeConjugatePoints) {
  // omega T = 2 < pi: the DEL solution is the minimum, and the method finds it too.
  const auto p = harmonic_problem(2.0, 200);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, stationary_options(), tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  EXPECT_LT(harmonic_discrete_error(p, tr), 1e-10);
}

#ifdef PARDEL_HAVE_STATIONARY_MODELS

pardel::Problem twin_problem(double T, int N) {
  pardel::Problem p;
  p.model = &twin_spring_model;
  p.discretization = pardel::find_discretization(twin_spring_model, "trapezoid");
  p.T = T;
  p.N = N;
  p.q0 = {0, 0};
  p.qN = {1, 0.5};
  return p;
}

TEST(Stationary, TheIndexOfTheSaddleCountsTheConjugatePoints) {
  // Morse's index theorem: the index is the number of conjugate times in (0, T), k pi for the
  // spring of frequency 1 and k pi / 2 for the one of frequency 2. T = 3.5: pi; pi/2, pi -> 3.
  // T = 5: pi; pi/2, pi, 3 pi/2 -> 4.
  for (const auto& [T, index] : {std::pair<double, long>{3.5, 3}, {5.0, 4}}) {
    for (int N : {400, 800}) {
      const auto p = twin_problem(T, N);
      auto tr = pardel::linear_guess(p);
      const pardel::Summary s = pardel::solve(p, pardel::Options{}, tr);
      ASSERT_TRUE(s.converged()) << "T " << T << " N " << N << ": " << s.brief_report();
      EXPECT_EQ(s.point.kind, pardel::PointKind::saddle);
      EXPECT_EQ(s.point.negative, index) << "T " << T << " N " << N << ": " << s.point.note;
      double err = 0;  // against the exact discrete motion of each spring
      for (int k = 0; k <= N; ++k) {
        err = std::max(err, std::fabs(tr.node(k)[0] - discrete_spring(1, T, N, k, 1)));
        err = std::max(err, std::fabs(tr.node(k)[1] - discrete_spring(2, T, N, k, 0.5)));
      }
      EXPECT_LT(err, 1e-9) << "T " << T << " N " << N;
    }
  }
}

TEST(Stationary, ANonlinearOrbitPastItsConjugatePointsAtSecondOrder) {
  // The unit circle at unit speed in V = |q|^4 / 4 over one and a quarter turns, from a guess
  // whose radius is off by up to 20 %.
  double previous = 0;
  long index = -1;
  for (int N : {200, 400, 800}) {
    pardel::Problem p;
    p.model = &quartic_ring_model;
    p.discretization = pardel::find_discretization(quartic_ring_model, "midpoint");
    p.T = 2.5 * kPi;
    p.N = N;
    p.q0 = {1, 0};
    p.qN = {0, 1};
    auto tr = pardel::linear_guess(p);
    for (int k = 1; k < N; ++k) {
      const double t = p.T * k / N, r = 1 + 0.2 * std::sin(3 * t);
      tr.node(k)[0] = r * std::cos(t);
      tr.node(k)[1] = r * std::sin(t);
    }
    const pardel::Summary s = pardel::solve(p, stationary_options(), tr);
    ASSERT_TRUE(s.converged()) << "N " << N << ": " << s.brief_report();
    EXPECT_EQ(s.point.kind, pardel::PointKind::saddle) << s.point.note;
    if (index >= 0) EXPECT_EQ(s.point.negative, index) << "the index does not depend on N";
    index = s.point.negative;
    double err = 0;
    for (int k = 0; k <= N; ++k) {
      const double t = p.T * k / N;
      err = std::max(err, std::hypot(tr.node(k)[0] - std::cos(t), tr.node(k)[1] - std::sin(t)));
    }
    if (previous > 0) EXPECT_NEAR(previous / err, 4.0, 0.3) << "second order from N/2 to N = " << N;
    previous = err;
  }
  EXPECT_GT(index, 0);
}

TEST(Stationary, AModelWithADeclaredCostGetsNoSaddle) {
  // The same oscillator declared as a cost: a saddle of it is no answer, so the automatic method
  // reports the minimizing Newton's failure and tries nothing else.
  const pardel::Problem p = spring_problem(costed_spring_model, 4.0, 200);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, automatic_options(), tr);
  EXPECT_FALSE(s.converged()) << s.brief_report();
  EXPECT_EQ(s.method, pardel::Method::newton);
  EXPECT_EQ(s.message.find("Newton on the DEL residual"), std::string::npos) << "no second attempt: " << s.message;
}

TEST(Stationary, AFoldWithNoSolutionNearbyStallsWithoutClaimingConvergence) {
  // x'' = -x - x^3 from 0 to 1 in T = 2: the motions near the straight line reach at most 0.507.
  const pardel::Problem p = spring_problem(hardening_spring_model, 2.0, 400);
  auto tr = pardel::linear_guess(p);
  const pardel::Summary s = pardel::solve(p, automatic_options(), tr);
  EXPECT_FALSE(s.converged()) << s.brief_report();
  EXPECT_GT(pardel::residual_norm(p, tr), 1e3 * s.tolerance);
  // Both attempts are named.
  EXPECT_NE(s.message.find("then Newton on the DEL residual (stationary-newton)"), std::string::npos) << s.message;
}

#endif

}  // namespace
