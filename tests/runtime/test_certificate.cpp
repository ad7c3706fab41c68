/**
 * @file test_certificate.cpp
 * The convergence certificate against closed forms: for the harmonic oscillator's trapezoid DEL
 * the Hessian is a + (1/h) tridiag(-1, 0, -1) with a = 2/h - h w^2, so its eigenvalues are
 * a - (2/h) cos(j pi / N) and the Jacobi spectral radius is 2 cos(pi/N) / (2 - h^2 w^2).
 * Also the interval hypotheses of prp:discrete_positive_def (free particle: hold; harmonic:
 * H^Ld_k indefinite; spline trapezoid(alpha=1): hold), knots restricting the Hessian, and the report.
 */
#include <gtest/gtest.h>

#include <cmath>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

pardel::Problem harmonic_problem(double omega, double T, int N) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.params = {omega};
  p.T = T;
  p.N = N;
  p.q0 = {1.0};
  p.qN = {0.5};
  return p;
}

long negatives_exact(double omega, double T, int N) {
  const double h = T / N, a = 2 / h - h * omega * omega;
  long neg = 0;
  for (int j = 1; j < N; ++j)
    if (a - 2 / h * std::cos(j * M_PI / N) < 0) ++neg;
  return neg;
}

TEST(Certificate, HarmonicBeforeConjugatePoint) {
  const auto p = harmonic_problem(1.0, 2.0, 40);
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  ASSERT_TRUE(c.error.empty()) << c.error;
  EXPECT_EQ(c.inertia_positive, 39);
  EXPECT_EQ(c.inertia_negative, 0);
  EXPECT_EQ(c.inertia_zero, 0);
  EXPECT_TRUE(c.hessian_positive_definite);
  // The interval Hessians of the harmonic trapezoid have the eigenvalue -h w^2 / 2 < 0.
  EXPECT_FALSE(c.all_intervals_psd);
  EXPECT_FALSE(c.theorem_holds);
  // Restricted to free components, the end intervals keep only 1/h - h w^2 / 2 > 0.
  EXPECT_EQ(c.intervals_violating, 38);
  ASSERT_FALSE(c.violations.empty());
  EXPECT_NEAR(c.violations[5].min_eig_hessian, -0.05 / 2, 1e-12);
  const double h = 2.0 / 40, rho = 2 * std::cos(M_PI / 40) / (2 - h * h);
  EXPECT_TRUE(c.spectral_radius_converged);
  EXPECT_NEAR(c.jacobi_spectral_radius, rho, 1e-9);
  EXPECT_NEAR(c.expected_iterations, std::log(1e-10 / c.residual) / std::log(rho), 1e-6 * c.expected_iterations);
  EXPECT_NE(c.report().find("positive definite"), std::string::npos);
}

TEST(Certificate, HarmonicBeyondConjugatePointIsIndefinite) {
  for (double T : {4.0, 7.0}) {
    const auto p = harmonic_problem(1.0, T, 50);
    const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
    EXPECT_EQ(c.inertia_negative, negatives_exact(1.0, T, 50)) << "T = " << T;
    EXPECT_GT(c.inertia_negative, 0);
    EXPECT_EQ(c.inertia_positive + c.inertia_negative + c.inertia_zero, 49);
    EXPECT_FALSE(c.hessian_positive_definite);
    EXPECT_GT(c.jacobi_spectral_radius, 1.0);
    EXPECT_TRUE(std::isinf(c.expected_iterations));
    EXPECT_NE(c.report().find("NOT positive definite"), std::string::npos);
  }
}

TEST(Certificate, FreeParticleSatisfiesTheTheorem) {
  const auto p = harmonic_problem(0.0, 1.0, 20);
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  EXPECT_TRUE(c.all_intervals_psd);
  EXPECT_TRUE(c.all_A_pd);
  EXPECT_TRUE(c.all_B_pd);
  EXPECT_TRUE(c.theorem_holds);
  EXPECT_TRUE(c.violations.empty());
  EXPECT_TRUE(c.hessian_positive_definite);
  EXPECT_NEAR(c.jacobi_spectral_radius, std::cos(M_PI / 20), 1e-10);
}

TEST(Certificate, SplineTrapezoidAlphaOneSatisfiesTheTheorem) {
  pardel::Problem p;
  p.model = &hand::spline;
  p.discretization = &hand::spline.discretizations[0];
  p.params = {1.0};
  p.N = 30;
  p.q0 = {0, 1};
  p.qN = {1, 0};
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  EXPECT_TRUE(c.all_intervals_psd);
  EXPECT_TRUE(c.all_A_pd);
  EXPECT_TRUE(c.theorem_holds);
  EXPECT_TRUE(c.hessian_positive_definite);
  EXPECT_EQ(c.inertia_positive, 2 * 29);
  EXPECT_LT(c.jacobi_spectral_radius, 1.0);
}

TEST(Certificate, KnotsRestrictTheHessian) {
  pardel::Problem p;
  p.model = &hand::spline;
  p.discretization = &hand::spline.discretizations[0];
  p.params = {1.0};
  p.N = 30;
  p.q0 = {0, 1};
  p.qN = {1, 0};
  p.knots = {{1.0 / 3, {0.5}}, {2.0 / 3, {-0.5}}};
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  ASSERT_TRUE(c.error.empty()) << c.error;
  EXPECT_EQ(c.free_components, 2 * 29 - 2);
  EXPECT_EQ(c.inertia_positive, 2 * 29 - 2);
  EXPECT_TRUE(c.hessian_positive_definite);
}

TEST(Certificate, KnotOffTheGridIsAnError) {
  pardel::Problem p = harmonic_problem(1.0, 1.0, 10);
  p.knots = {{0.33, {0.1}}};
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  EXPECT_NE(c.error.find("knot 0"), std::string::npos) << c.error;
  EXPECT_NE(c.error.find("nearest nodes: 3"), std::string::npos) << c.error;
  EXPECT_NE(c.report().find("not computed"), std::string::npos);
}

}  // namespace
