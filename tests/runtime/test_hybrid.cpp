/**
 * @file test_hybrid.cpp
 * The hybrid method (Jacobi-Newton until the Hessian is positive definite, then Newton): the same
 * solution as Newton on Bratu and, when bundled, on the fuel-optimal example; and no convergence
 * claimed beyond the first conjugate point of the harmonic oscillator.
 */
#include <gtest/gtest.h>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

TEST(Hybrid, BratuAgreesWithNewton) {
  pardel::Problem p;
  p.model = &hand::bratu;
  p.discretization = &hand::bratu.discretizations[0];
  p.params = {3.0};
  p.N = 100;
  p.q0 = {0.0};
  p.qN = {0.0};
  pardel::Options opt;
  opt.method = pardel::Method::hybrid;
  opt.threads = 1;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_LT(s.iterations, 100);  // Newton takes over after a few sweeps
  opt.method = pardel::Method::newton;
  auto ref = pardel::linear_guess(p);
  ASSERT_TRUE(pardel::solve(p, opt, ref).converged());
  for (int k = 0; k <= p.N; ++k) EXPECT_NEAR(traj.node(k)[0], ref.node(k)[0], 1e-9);
}

TEST(Hybrid, NoConvergenceBeyondTheConjugatePoint) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.params = {1.0};
  p.T = 4.0;
  p.N = 40;
  p.q0 = {1.0};
  p.qN = {1.0};
  pardel::Options opt;
  opt.method = pardel::Method::hybrid;
  opt.threads = 1;
  opt.max_iterations = 20000;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  EXPECT_FALSE(s.converged()) << s.brief_report();
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
TEST(Hybrid, FuelOptimalExample) {
  pardel::Problem p;
  p.model = pardel::find_model("fuel_nav");
  if (!p.model) GTEST_SKIP() << "fuel_nav is not bundled";
  p.discretization = pardel::find_discretization(*p.model, "trapezoid");
  p.T = 30;
  p.N = 200;
  p.q0 = {0, 0};
  p.qN = {6, 5};
  pardel::Options opt;
  opt.method = pardel::Method::hybrid;
  opt.max_iterations = 200000;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_LE(s.residual, 1e-10);
  EXPECT_NEAR(s.action, 5.59683215, 5e-9);
}
#endif

}  // namespace
