/**
 * @file test_newton.cpp
 * Globalized Newton on the whole DEL system: exact harmonic discrete solution, Bratu against its
 * exact solution, no convergence claimed where no minimizer exists (beyond the first conjugate
 * point, beyond Bratu's fold), block LDL^T and cyclic reduction agreeing, bit-identical results
 * for 1 and 2 threads, and the fuel-optimal example of the seed when the bundled models are built.
 */
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"
#include "trust_region.hpp"

namespace {


/** Bratu: theta = sqrt(2 lambda) cosh(theta/4), lower branch, by Newton from theta = 1. */
double bratu_theta(double lambda) {
  double th = 1;
  for (int i = 0; i < 100; ++i) {
    const double f = th - std::sqrt(2 * lambda) * std::cosh(th / 4);
    const double df = 1 - std::sqrt(2 * lambda) * std::sinh(th / 4) / 4;
    th -= f / df;
  }
  return th;
}
double bratu_exact(double lambda, double x) {
  const double th = bratu_theta(lambda);
  return -2 * std::log(std::cosh((x - 0.5) * th / 2) / std::cosh(th / 4));
}

pardel::Options newton_options(int threads = 1) {
  pardel::Options o;  // an absolute tolerance unless the test says otherwise
  o.tol = 1e-10;
  o.method = pardel::Method::newton;
  o.threads = threads;
  o.max_iterations = 500;
  return o;
}

TEST(Newton, HarmonicMatchesExactDiscreteSolution) {
  const auto problem = hand::problem(hand::harmonic, 1.0, 2.0, 40, 0.3, -0.7);
  auto traj = pardel::linear_guess(problem);
  auto opt = newton_options();
  opt.tol = 1e-13;
  const auto s = pardel::solve(problem, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_LE(s.iterations, 3);  // a quadratic action: one Newton step up to round-off
  const double h = 2.0 / 40, th = std::acos(1 - h * h / 2);
  for (int k = 0; k <= 40; ++k) {
    const double exact = 0.3 * std::cos(k * th) + (-0.7 - 0.3 * std::cos(40 * th)) * std::sin(k * th) / std::sin(40 * th);
    EXPECT_NEAR(traj.node(k)[0], exact, 1e-11) << "node " << k;
  }
}

// The residual, its round-off level and the action that a solve reports are those of the iterate
// it returns: equal to the bit to a fresh evaluation there (a solve of no iterations from it).
// After an accepted step the solver reads them from the trial evaluation instead of evaluating
// the new iterate again, so the trial's round-off term |H| |q| must be that of the new iterate.
TEST(Newton, TheReportedResidualIsThatOfTheReturnedIterate) {
  for (pardel::Method method : {pardel::Method::automatic, pardel::Method::newton, pardel::Method::stationary_newton}) {
    for (int N : {150, 3200}) {  // one level; nested levels 200, 800, 3200 under automatic
      const auto problem = hand::problem(hand::bratu, 3.0, 1.0, N, 0.2, -0.1);
      auto traj = pardel::linear_guess(problem);
      pardel::Options o;
      o.method = method;
      o.threads = 1;
      const auto s = pardel::solve(problem, o, traj);
      ASSERT_TRUE(s.converged()) << to_string(method) << " N = " << N << ": " << s.brief_report();
      ASSERT_GE(s.iterations, 2) << "a nonlinear problem: more than one step";
      auto again = traj;
      pardel::Options fresh;
      fresh.method = pardel::Method::newton;
      fresh.threads = 1;
      fresh.max_iterations = 0;
      const auto e = pardel::solve(problem, fresh, again);
      EXPECT_EQ(e.iterations, 0);
      EXPECT_EQ(s.residual, e.residual) << to_string(method) << " N = " << N;
      EXPECT_EQ(s.residual_floor, e.residual_floor) << to_string(method) << " N = " << N;
      EXPECT_EQ(s.action, e.action) << to_string(method) << " N = " << N;
    }
  }
}

TEST(Newton, ConvergedMessageSaysWhenTheRoundOffLevelSetsTheTarget) {
  // The harmonic oscillator's discrete solution is known: with the default rtol its DEL equations
  // are resolved to rtol and the message says nothing more; with rtol far below double precision
  // the target is 10x the round-off level, and the message says how little that resolves.
  const auto problem = hand::problem(hand::harmonic, 1.0, 2.0, 40, 0.3, -0.7);
  auto traj = pardel::linear_guess(problem);
  const auto plain = pardel::solve(problem, pardel::Options{}, traj);
  ASSERT_TRUE(plain.converged()) << plain.brief_report();
  EXPECT_EQ(plain.message.find("round-off level dominates"), std::string::npos) << plain.message;
  pardel::Options tight;
  tight.rtol = 1e-30;
  traj = pardel::linear_guess(problem);
  const auto s = pardel::solve(problem, tight, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_NE(s.message.find("the round-off level dominates: at this N the DEL equations are resolved only to"),
            std::string::npos)
      << s.message;
  EXPECT_NE(s.message.find("(rtol 1e-30)"), std::string::npos) << s.message;
}

TEST(Newton, BratuMatchesExactSolution) {
  for (double lambda : {1.0, 3.0}) {
    const int N = 200;
    const auto problem = hand::problem(hand::bratu, lambda, 1.0, N, 0.0, 0.0);
    auto traj = pardel::linear_guess(problem);
    const auto s = pardel::solve(problem, newton_options(), traj);
    ASSERT_TRUE(s.converged()) << "lambda " << lambda << ": " << s.brief_report();
    EXPECT_LE(pardel::residual_norm(problem, traj), 1e-10);
    double err = 0;
    for (int k = 0; k <= N; ++k) err = std::max(err, std::fabs(traj.node(k)[0] - bratu_exact(lambda, double(k) / N)));
    // Second order: the error is a small multiple of h^2 = 2.5e-5.
    EXPECT_LT(err, 2e-4) << "lambda " << lambda;
    EXPECT_GT(err, 0.0);
  }
}

TEST(Newton, NoConvergenceBeyondBratuFold) {
  // lambda_c ~ 3.5138: no solution exists beyond it.
  const auto problem = hand::problem(hand::bratu, 4.0, 1.0, 100, 0.0, 0.0);
  auto traj = pardel::linear_guess(problem);
  auto opt = newton_options();
  opt.max_iterations = 2000;
  const auto s = pardel::solve(problem, opt, traj);
  EXPECT_FALSE(s.converged()) << s.brief_report();
  EXPECT_GT(pardel::residual_norm(problem, traj), 1e-10);
  for (double v : traj.q) EXPECT_TRUE(std::isfinite(v));
}

TEST(Newton, NoConvergenceBeyondTheConjugatePoint) {
  // omega T = 4 > pi: the unique DEL solution is a saddle; the action is unbounded below.
  const auto problem = hand::problem(hand::harmonic, 1.0, 4.0, 40, 1.0, 1.0);
  auto traj = pardel::linear_guess(problem);
  const auto s = pardel::solve(problem, newton_options(), traj);
  EXPECT_FALSE(s.converged()) << s.brief_report();
  EXPECT_TRUE(s.termination == pardel::Termination::diverged ||
              s.termination == pardel::Termination::max_iterations)
      << s.brief_report();
  // A divergence names its usual causes: a saddle past a conjugate point is one.
  if (s.termination == pardel::Termination::diverged) {
    EXPECT_NE(s.message.find("converge to minima of the action"), std::string::npos) << s.message;
    EXPECT_NE(s.message.find("past a conjugate point"), std::string::npos) << s.message;
  }
}

TEST(Newton, CyclicReductionAgreesWithLdlt) {
  const int N = 1500;
  const auto problem = hand::problem(hand::bratu, 2.0, 1.0, N, 0.0, 0.5);
  auto a = pardel::linear_guess(problem);
  auto sa = pardel::solve(problem, newton_options(), a);
  auto opt = newton_options();
  opt.linear_solver = pardel::LinearSolver::cyclic_reduction;
  auto b = pardel::linear_guess(problem);
  auto sb = pardel::solve(problem, opt, b);
  ASSERT_TRUE(sa.converged()) << sa.brief_report();
  ASSERT_TRUE(sb.converged()) << sb.brief_report();
  for (int k = 0; k <= N; ++k) EXPECT_NEAR(a.node(k)[0], b.node(k)[0], 1e-10);
}

TEST(Newton, BitIdenticalForOneAndTwoThreads) {
  const int N = 3000;
  const auto problem = hand::problem(hand::bratu, 2.0, 1.0, N, 0.0, 0.5);
  for (auto solver : {pardel::LinearSolver::block_ldlt, pardel::LinearSolver::cyclic_reduction}) {
    auto o1 = newton_options(1);
    o1.linear_solver = solver;
    auto o2 = newton_options(2);
    o2.linear_solver = solver;
    auto a = pardel::linear_guess(problem);
    auto b = pardel::linear_guess(problem);
    const auto sa = pardel::solve(problem, o1, a);
    const auto sb = pardel::solve(problem, o2, b);
    ASSERT_TRUE(sa.converged()) << sa.brief_report();
    EXPECT_EQ(sa.iterations, sb.iterations);
    EXPECT_EQ(sa.residual, sb.residual);
    EXPECT_EQ(sa.action, sb.action);
    EXPECT_EQ(a.q, b.q) << pardel::to_string(solver);
  }
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
pardel::Problem fuel_problem(int N) {
  pardel::Problem p;
  p.model = pardel::find_model("fuel_nav");
  if (!p.model) return p;
  p.discretization = pardel::find_discretization(*p.model, "trapezoid");
  p.T = 30;
  p.N = N;
  p.q0 = {0, 0};
  p.qN = {6, 5};
  return p;
}

TEST(Newton, FuelOptimalExampleOfTheSeed) {
  const auto problem = fuel_problem(200);
  if (!problem.model || !problem.discretization) GTEST_SKIP() << "fuel_nav/trapezoid is not bundled";
  auto traj = pardel::linear_guess(problem);
  const auto s = pardel::solve(problem, newton_options(), traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_LE(s.residual, 1e-10);
  EXPECT_NEAR(s.action, 5.59683215, 5e-9);
}

// Nested iteration (refine_start_N = 200, refine_factor = 2: coarse levels solved to tol, each
// level started from the extrapolation of the two before) reaches the solution that Newton from
// the straight line reaches at N = 2000, to 1e-10.
TEST(Newton, NestedIterationReachesTheStraightLineSolutionOfTheFuelExample) {
  const auto problem = fuel_problem(2000);
  if (!problem.model || !problem.discretization) GTEST_SKIP() << "fuel_nav/trapezoid is not bundled";
  auto direct = pardel::linear_guess(problem);
  auto direct_options = newton_options();
  direct_options.max_iterations = 1000;
  const auto sd = pardel::solve(problem, direct_options, direct);
  ASSERT_TRUE(sd.converged()) << sd.brief_report();
  auto nested = pardel::linear_guess(problem);
  auto options = newton_options();
  options.max_iterations = 2000;
  options.refine_start_N = 200;
  options.refine_factor = 2;
  const auto sn = pardel::solve(problem, options, nested);
  ASSERT_TRUE(sn.converged()) << sn.brief_report();
  EXPECT_EQ(sn.N, 2000);
  EXPECT_LE(pardel::residual_norm(problem, nested), 1e-10);
  EXPECT_NEAR(sn.action, sd.action, 1e-10);
  double diff = 0;
  for (std::size_t i = 0; i < nested.q.size(); ++i) diff = std::max(diff, std::fabs(nested.q[i] - direct.q[i]));
  // Both iterates are within residual / lambda_min(H) of the minimizer, and lambda_min is tiny along
  // the valley (a residual of 1e-10 leaves node differences of ~1e-5 there); another local
  // minimum would differ by O(0.1) (docs/solvers.md, nested iteration).
  EXPECT_LT(diff, 1e-4);
  // Levels 200, 400, 800, 1600, 2000 in increasing order.
  EXPECT_EQ(sn.history.front().N, 200);
  for (std::size_t i = 1; i < sn.history.size(); ++i) EXPECT_GE(sn.history[i].N, sn.history[i - 1].N);
}

// Known limitation (docs/solvers.md, "Measured"): from the straight line, at N = 20000 the
// Levenberg-Marquardt iteration creeps along the flat valley of this problem and does not reach
// 1e-10 within 500 iterations. Disabled so that the suite stays green; run with
// --gtest_also_run_disabled_tests to check.
// The difference-metric shift damps every wavelength alike: the same problem converges at large N.
TEST(Newton, DifferenceShiftConvergesAtLargeN) {
  for (int N : {2000, 20000}) {
    const auto problem = fuel_problem(N);
    if (!problem.model || !problem.discretization) GTEST_SKIP() << "fuel_nav/trapezoid is not bundled";
    auto traj = pardel::linear_guess(problem);
    auto options = newton_options();
    options.newton_shift = pardel::NewtonShift::difference;
    const auto s = pardel::solve(problem, options, traj);
    ASSERT_TRUE(s.converged()) << "N = " << N << ": " << s.brief_report();
    EXPECT_LE(s.residual, 1e-10);
    EXPECT_LE(pardel::residual_norm(problem, traj), 1e-10);
  }
}

TEST(Newton, FuelOptimalDoesNotStallAtLargeN) {
  // Plain Newton (no grid sequencing) from the straight line, the default relative tolerance: it
  // converges along the flat valley to a minimum within 300 iterations (109 at N = 2e4).
  for (int N : {2000, 20000}) {
    const auto problem = fuel_problem(N);
    if (!problem.model || !problem.discretization) GTEST_SKIP() << "fuel_nav/trapezoid is not bundled";
    auto traj = pardel::linear_guess(problem);
    pardel::Options o;
    o.method = pardel::Method::newton;
    o.threads = 1;
    o.max_iterations = 300;
    const auto s = pardel::solve(problem, o, traj);
    ASSERT_TRUE(s.converged()) << "N = " << N << ": " << s.brief_report();
    EXPECT_LE(pardel::residual_norm(problem, traj), s.tolerance);
    EXPECT_EQ(s.point.kind, pardel::PointKind::minimum) << s.point.note;
  }
}
#endif

/** A refused trial leaves the context as it was before the trial, to the bit: the interval arrays
 *  and residual at q, with the refused trial's round-off level and component sizes; the first
 *  refusal of a level by evaluating q again, the later ones by swapping the kept second set. */
TEST(TrialEvaluation, ARefusedTrialRestoresTheEvaluationAtQToTheBit) {
  const auto problem = hand::problem(hand::bratu, 2.0, 1.0, 50, 0.2, -0.1);
  pardel::detail::Context ctx;
  std::string error;
  ASSERT_TRUE(pardel::detail::context_at(problem, pardel::linear_guess(problem), 1, ctx, &error)) << error;
  pardel::detail::ensure_interval_arrays(ctx, pardel::detail::Evaluated::full);
  auto evaluate = [&ctx](const std::vector<double>& q) {
    pardel::detail::eval_full(ctx, q);
    pardel::detail::compute_residual(ctx);
  };
  evaluate(ctx.q);
  const std::vector<std::vector<double>> at_q = {ctx.Ld, ctx.D1, ctx.D2, ctx.D11, ctx.D12, ctx.D22, ctx.res};
  pardel::detail::TrialEvaluation trial;
  trial.begin_level();
  for (int attempt = 0; attempt < 3; ++attempt) {
    ctx.q_next = ctx.q;
    for (int k = 1; k < ctx.N; ++k) ctx.q_next[static_cast<std::size_t>(k)] += 0.3 * (attempt + 1) * std::sin(0.7 * k);
    trial.before_trial(ctx);
    evaluate(ctx.q_next);
    const double floor = ctx.residual_floor, scale = ctx.residual_scale;
    const std::vector<double> comp_residual = ctx.comp_residual, comp_scale = ctx.comp_scale, comp_hq = ctx.comp_hq;
    ASSERT_NE(ctx.D11, at_q[3]) << "the trial point has other second derivatives";
    trial.refused(ctx, [&] { evaluate(ctx.q); });
    const std::vector<std::vector<double>> now = {ctx.Ld, ctx.D1, ctx.D2, ctx.D11, ctx.D12, ctx.D22, ctx.res};
    for (std::size_t a = 0; a < at_q.size(); ++a) EXPECT_EQ(now[a], at_q[a]) << "array " << a << ", attempt " << attempt;
    EXPECT_EQ(ctx.residual_floor, floor);
    EXPECT_EQ(ctx.residual_scale, scale);
    EXPECT_EQ(ctx.comp_residual, comp_residual);
    EXPECT_EQ(ctx.comp_scale, comp_scale);
    EXPECT_EQ(ctx.comp_hq, comp_hq);
  }
}

}  // namespace
