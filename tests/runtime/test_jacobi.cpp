/**
 * @file test_jacobi.cpp
 * The nonlinear block Jacobi method (seed eq. pDEL): Bratu solved to 1e-10 and agreeing with
 * Newton's solution, its measured contraction rate against the certificate's spectral radius
 * (asymptotic rate within 10% of log rho), and bit-identical results for 1 and 2 threads.
 */
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

pardel::Problem bratu_problem(double lambda, int N) {
  pardel::Problem p;
  p.model = &hand::bratu;
  p.discretization = &hand::bratu.discretizations[0];
  p.params = {lambda};
  p.N = N;
  p.q0 = {0.0};
  p.qN = {0.0};
  return p;
}

/** Residual ratio per sweep between sweeps a and b (the first 1000 sweeps are all recorded). */
double measured_rate(const std::vector<double>& r, int a, int b) {
  return std::pow(r[static_cast<std::size_t>(b)] / r[static_cast<std::size_t>(a)], 1.0 / (b - a));
}

TEST(Jacobi, BratuConvergesToNewtonSolution) {
  const auto p = bratu_problem(2.0, 30);
  pardel::Options opt;  // an absolute tolerance
  opt.tol = 1e-10;
  opt.method = pardel::Method::jacobi;
  opt.threads = 1;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_LE(pardel::residual_norm(p, traj), 1e-10);
  pardel::Options nopt;
  nopt.method = pardel::Method::newton;
  auto ref = pardel::linear_guess(p);
  ASSERT_TRUE(pardel::solve(p, nopt, ref).converged());
  for (int k = 0; k <= p.N; ++k) EXPECT_NEAR(traj.node(k)[0], ref.node(k)[0], 1e-9);
}

TEST(Jacobi, ContractionRateMatchesCertificate) {
  for (auto method : {pardel::Method::jacobi, pardel::Method::jacobi_newton}) {
    const auto p = bratu_problem(2.0, 24);
    // Solution first (Newton), then the certificate there.
    pardel::Options nopt;
    nopt.method = pardel::Method::newton;
    nopt.tol = 1e-13;
    auto sol = pardel::linear_guess(p);
    ASSERT_TRUE(pardel::solve(p, nopt, sol).converged());
    const auto c = pardel::certify(p, sol, 1);
    ASSERT_TRUE(c.hessian_positive_definite);
    ASSERT_TRUE(c.spectral_radius_converged);
    // Measure from a linear guess down to near round-off.
    std::vector<double> history;
    pardel::Options opt;  // an absolute tolerance
    opt.method = method;
    opt.threads = 1;
    opt.tol = 1e-11;
    opt.on_iteration = [&](const pardel::IterationRecord& r) {
      history.push_back(r.residual);
      return true;
    };
    auto traj = pardel::linear_guess(p);
    const auto s = pardel::solve(p, opt, traj);
    ASSERT_TRUE(s.converged()) << s.brief_report();
    ASSERT_GT(history.size(), 900u);
    ASSERT_GT(history[900], 1e3 * opt.tol);  // still far from round-off
    const double rate = measured_rate(history, 600, 900);
    EXPECT_NEAR(std::log(rate) / std::log(c.jacobi_spectral_radius), 1.0, 0.1)
        << pardel::to_string(method) << ": measured " << rate << ", certificate " << c.jacobi_spectral_radius;
  }
}

TEST(Jacobi, BitIdenticalForOneAndTwoThreads) {
  const auto p = bratu_problem(1.0, 2500);
  pardel::Options opt;  // an absolute tolerance
  opt.tol = 1e-10;
  opt.method = pardel::Method::jacobi;
  opt.max_iterations = 20;
  opt.threads = 1;
  auto a = pardel::linear_guess(p);
  const auto sa = pardel::solve(p, opt, a);
  opt.threads = 2;
  auto b = pardel::linear_guess(p);
  const auto sb = pardel::solve(p, opt, b);
  EXPECT_EQ(sa.residual, sb.residual);
  EXPECT_EQ(a.q, b.q);
}

}  // namespace
