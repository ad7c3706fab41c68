/**
 * @file test_jacobi_newton.cpp
 * The seed's block Jacobi-Newton (eq. NewtonRaphson): against the exact discrete solution of the
 * harmonic oscillator's trapezoid DEL (a three-term recurrence solved in closed form), m-step
 * variants, damping, bit-identical results for 1, 2 and 3 threads, one fused sweep of a 2-D model
 * against the block Newton step formed from the kernels here, and failure statuses.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

pardel::Problem harmonic_problem(double omega, double T, int N, double a, double b) {
  return hand::problem(hand::harmonic, omega, T, N, a, b);  // its first discretization: trapezoid
}

/** x_{k+1} = (2 - h^2 w^2) x_k - x_{k-1}: x_k = a cos(k th) + (b - a cos(N th)) sin(k th) / sin(N th). */
double exact_discrete(double omega, double T, int N, double a, double b, int k) {
  const double h = T / N, th = std::acos(1 - h * h * omega * omega / 2);
  return a * std::cos(k * th) + (b - a * std::cos(N * th)) * std::sin(k * th) / std::sin(N * th);
}

TEST(JacobiNewton, HarmonicMatchesExactDiscreteSolution) {
  const auto problem = harmonic_problem(1.0, 2.0, 40, 0.3, -0.7);
  auto traj = pardel::linear_guess(problem);
  pardel::Options opt;  // the seed's method at an absolute tolerance
  opt.method = pardel::Method::jacobi_newton;
  opt.threads = 1;
  opt.tol = 1e-13;  // the error is at most residual / lambda_min(H) ~ residual * T^2 / (pi^2 h)
  const auto s = pardel::solve(problem, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_LE(s.residual, 1e-13);
  EXPECT_LE(pardel::residual_norm(problem, traj), 1e-13);
  for (int k = 0; k <= problem.N; ++k)
    EXPECT_NEAR(traj.node(k)[0], exact_discrete(1.0, 2.0, 40, 0.3, -0.7, k), 1e-11) << "node " << k;
  EXPECT_NEAR(s.action, pardel::discrete_action(problem, traj), 1e-14);
  EXPECT_FALSE(s.history.empty());
  EXPECT_EQ(s.history.back().iteration, s.iterations);
}

TEST(JacobiNewton, SubstepsAndDampingReachTheSameSolution) {
  const auto problem = harmonic_problem(1.5, 1.5, 24, 1.0, 0.5);
  pardel::Options base;
  base.threads = 1;
  auto ref = pardel::linear_guess(problem);
  ASSERT_TRUE(pardel::solve(problem, base, ref).converged());
  for (int m : {2, 3}) {
    pardel::Options opt = base;
    opt.newton_substeps = m;
    auto traj = pardel::linear_guess(problem);
    const auto s = pardel::solve(problem, opt, traj);
    ASSERT_TRUE(s.converged()) << "m = " << m << ": " << s.brief_report();
    for (int k = 0; k <= problem.N; ++k) EXPECT_NEAR(traj.node(k)[0], ref.node(k)[0], 1e-9);
  }
  pardel::Options damped = base;
  damped.damping = 0.3;
  auto traj = pardel::linear_guess(problem);
  const auto s = pardel::solve(problem, damped, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  for (int k = 0; k <= problem.N; ++k) EXPECT_NEAR(traj.node(k)[0], ref.node(k)[0], 1e-9);
}

TEST(JacobiNewton, BitIdenticalForOneAndTwoThreads) {
  // N above the size where loops go parallel; the same iterate after the same number of sweeps.
  const auto problem = harmonic_problem(2.0, 1.0, 3000, -0.2, 0.9);
  pardel::Options opt;  // the seed's method at an absolute tolerance
  opt.method = pardel::Method::jacobi_newton;
  opt.tol = 1e-10;
  opt.max_iterations = 40;
  opt.threads = 1;
  auto a = pardel::linear_guess(problem);
  const auto sa = pardel::solve(problem, opt, a);
  opt.threads = 2;
  auto b = pardel::linear_guess(problem);
  const auto sb = pardel::solve(problem, opt, b);
  EXPECT_EQ(sa.iterations, sb.iterations);
  EXPECT_EQ(sa.residual, sb.residual);
  EXPECT_EQ(a.q, b.q);
  EXPECT_EQ(sb.threads, 2);
}

TEST(JacobiNewton, BeyondTheConjugatePointDoesNotConverge) {
  // omega T = 4 > pi: the Hessian of the action is indefinite, the linear iteration diverges.
  const auto problem = harmonic_problem(1.0, 4.0, 40, 1.0, 1.0);
  auto traj = pardel::linear_guess(problem);
  pardel::Options opt;  // the seed's method at an absolute tolerance
  opt.method = pardel::Method::jacobi_newton;
  opt.tol = 1e-10;
  opt.threads = 1;
  opt.max_iterations = 100000;
  const auto s = pardel::solve(problem, opt, traj);
  EXPECT_FALSE(s.converged()) << s.brief_report();
  EXPECT_EQ(s.termination, pardel::Termination::diverged) << s.brief_report();
}

TEST(JacobiNewton, MaxIterationsIsReported) {
  const auto problem = harmonic_problem(1.0, 2.0, 200, 0.0, 1.0);
  auto traj = pardel::linear_guess(problem);
  pardel::Options opt;  // the seed's method at an absolute tolerance
  opt.method = pardel::Method::jacobi_newton;
  opt.tol = 1e-10;
  opt.max_iterations = 7;
  const auto s = pardel::solve(problem, opt, traj);
  EXPECT_EQ(s.termination, pardel::Termination::max_iterations);
  EXPECT_EQ(s.iterations, 7);
  EXPECT_NE(s.brief_report().find("max_iterations"), std::string::npos);
}

TEST(JacobiNewton, InterruptedByCallback) {
  const auto problem = harmonic_problem(1.0, 2.0, 100, 0.0, 1.0);
  auto traj = pardel::linear_guess(problem);
  pardel::Options opt;  // the seed's method at an absolute tolerance
  opt.method = pardel::Method::jacobi_newton;
  opt.tol = 1e-10;
  long seen = 0;
  opt.on_iteration = [&](const pardel::IterationRecord& r) {
    seen = r.iteration;
    return r.iteration < 5;
  };
  const auto s = pardel::solve(problem, opt, traj);
  EXPECT_EQ(s.termination, pardel::Termination::interrupted);
  EXPECT_EQ(seen, 5);
  EXPECT_EQ(s.iterations, 5);
}

TEST(JacobiNewton, NonFiniteIterateIsCaughtWithNodeAndIteration) {
  // Bratu far beyond its fold: exp overflows after a few sweeps.
  pardel::Problem p;
  p.model = &hand::bratu;
  p.discretization = &hand::bratu.discretizations[0];
  p.params = {400.0};
  p.N = 20;
  p.q0 = {0.0};
  p.qN = {0.0};
  auto traj = pardel::linear_guess(p);
  pardel::Options opt;  // the seed's method at an absolute tolerance
  opt.method = pardel::Method::jacobi_newton;
  opt.tol = 1e-10;
  opt.divergence_factor = 1e300;
  const auto s = pardel::solve(p, opt, traj);
  EXPECT_FALSE(s.converged());
  EXPECT_TRUE(s.termination == pardel::Termination::non_finite || s.termination == pardel::Termination::diverged)
      << s.brief_report();
  for (double v : traj.q) EXPECT_TRUE(std::isfinite(v));
  if (s.termination == pardel::Termination::non_finite) {
    EXPECT_NE(s.message.find("node"), std::string::npos) << s.message;
    EXPECT_NE(s.message.find("iteration"), std::string::npos) << s.message;
  }
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
TEST(JacobiNewton, FusedSweepIsTheBlockNewtonStepOfEveryNodeForAnyThreadCount) {
  // fuel_nav (2-D): one sweep from a wavy guess, against x_k - (D22(k-1) + D11(k))^{-1} (D2(k-1) + D1(k))
  // with the kernels called here and a dense LU; N above the parallel threshold, so the thread
  // ranges (and the interval each thread recomputes at its left end) are exercised.
  pardel::Problem p;
  p.model = pardel::find_model("fuel_nav");
  ASSERT_NE(p.model, nullptr);
  p.discretization = pardel::find_discretization(*p.model, "trapezoid");
  p.T = 30;
  p.N = 3001;
  p.q0 = {0, 0};
  p.qN = {6, 5};
  pardel::Trajectory guess = pardel::linear_guess(p);
  for (int k = 1; k < p.N; ++k) {
    guess.node(k)[0] += 0.3 * std::sin(0.01 * k);
    guess.node(k)[1] -= 0.2 * std::sin(0.02 * k);
  }
  const double h = p.T / p.N;
  std::vector<double> expected = guess.q;
  double D1[2], D2[2], D11[4], D22[4], prevD2[2], prevD22[4];
  for (int k = 0; k < p.N; ++k) {
    p.discretization->sweep(h, k * h, (k + 1) * h, guess.node(k), guess.node(k + 1), p.model->param_defaults, D1, D2,
                            D11, D22);
    if (k > 0) {
      Eigen::Matrix2d M;
      M << prevD22[0] + D11[0], prevD22[1] + D11[1], prevD22[2] + D11[2], prevD22[3] + D11[3];
      const Eigen::Vector2d r(prevD2[0] + D1[0], prevD2[1] + D1[1]);
      const Eigen::Vector2d dx = M.fullPivLu().solve(r);
      expected[2 * k] -= dx[0];
      expected[2 * k + 1] -= dx[1];
    }
    std::copy(D2, D2 + 2, prevD2);
    std::copy(D22, D22 + 4, prevD22);
  }
  std::vector<double> one_thread;
  for (int threads : {1, 2, 3}) {
    pardel::Options opt;  // the seed's method at an absolute tolerance
    opt.method = pardel::Method::jacobi_newton;
    opt.tol = 1e-10;
    opt.threads = threads;
    opt.max_iterations = 1;
    pardel::Trajectory tr = guess;
    const auto s = pardel::solve(p, opt, tr);
    ASSERT_EQ(s.termination, pardel::Termination::max_iterations) << s.brief_report();
    ASSERT_EQ(s.iterations, 1);
    for (std::size_t i = 0; i < expected.size(); ++i)
      ASSERT_NEAR(tr.q[i], expected[i], 1e-12 * (1 + std::fabs(expected[i]))) << "component " << i << ", " << threads
                                                                               << " threads";
    if (threads == 1)
      one_thread = tr.q;
    else
      EXPECT_EQ(tr.q, one_thread) << threads << " threads";
  }
}
#endif

}  // namespace
