/**
 * @file test_momenta.cpp
 * pardel::boundary_momenta: at the solved harmonic oscillator x'' = -w^2 x, x(0) = 0, x(T) = 1,
 * the discrete end momenta approach the continuous x'(0) = w / sin(wT) and x'(T) = w cos(wT) / sin(wT)
 * at second order for both discretizations; at an arbitrary trajectory they are the hand-derived
 * -D1 Ld(q0, q1) and D2 Ld(q_{N-1}, q_N); invalid input gives empty momenta.
 */
#include <gtest/gtest.h>

#include <cmath>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

constexpr double kOmega = 2.0;
constexpr double kT = 1.3;

pardel::Problem oscillator(int N, int disc) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[disc];
  p.params = {kOmega};
  p.T = kT;
  p.N = N;
  p.q0 = {0.0};
  p.qN = {1.0};
  return p;
}

/** The largest error of the two end momenta against the continuous solution's velocities. */
double momentum_error(int N, int disc) {
  const pardel::Problem problem = oscillator(N, disc);
  pardel::Trajectory tr = pardel::linear_guess(problem);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.threads = 1;
  const pardel::Summary summary = pardel::solve(problem, options, tr);
  EXPECT_TRUE(summary.converged()) << summary.message;
  const pardel::BoundaryMomenta m = pardel::boundary_momenta(problem, tr);
  EXPECT_EQ(m.p0.size(), 1u);
  EXPECT_EQ(m.pN.size(), 1u);
  if (m.p0.size() != 1 || m.pN.size() != 1) return 1e300;
  const double v0 = kOmega / std::sin(kOmega * kT);
  const double vT = kOmega * std::cos(kOmega * kT) / std::sin(kOmega * kT);
  return std::max(std::abs(m.p0[0] - v0), std::abs(m.pN[0] - vT));
}

TEST(Momenta, SecondOrderConvergenceToTheContinuousVelocities) {
  for (int disc = 0; disc < 2; ++disc) {
    const double e1 = momentum_error(20, disc), e2 = momentum_error(40, disc), e3 = momentum_error(80, disc);
    EXPECT_LT(e1, 0.1) << "discretization " << disc;
    EXPECT_GT(e1 / e2, 3.5) << "discretization " << disc;
    EXPECT_LT(e1 / e2, 4.5) << "discretization " << disc;
    EXPECT_GT(e2 / e3, 3.5) << "discretization " << disc;
    EXPECT_LT(e2 / e3, 4.5) << "discretization " << disc;
  }
}

TEST(Momenta, AreTheEndDerivativesOfTheDiscreteLagrangian) {
  const pardel::Problem problem = oscillator(4, 0);
  pardel::Trajectory tr = pardel::linear_guess(problem);
  const double x[] = {0.0, 0.7, -0.2, 0.4, 1.0};
  for (int k = 0; k <= 4; ++k) tr.q[static_cast<std::size_t>(k)] = x[k];
  const double h = kT / 4, w2 = kOmega * kOmega;
  const pardel::BoundaryMomenta m = pardel::boundary_momenta(problem, tr);
  ASSERT_EQ(m.p0.size(), 1u);
  ASSERT_EQ(m.pN.size(), 1u);
  // Trapezoid: Ld = (x1-x0)^2/(2h) - h w^2 (x0^2 + x1^2)/4.
  EXPECT_DOUBLE_EQ(m.p0[0], (x[1] - x[0]) / h + h * w2 * x[0] / 2);
  EXPECT_DOUBLE_EQ(m.pN[0], (x[4] - x[3]) / h - h * w2 * x[4] / 2);
}

TEST(Momenta, EmptyForInvalidInput) {
  const pardel::Problem problem = oscillator(4, 0);
  pardel::Trajectory tr = pardel::linear_guess(oscillator(5, 0));  // another grid
  const pardel::BoundaryMomenta m = pardel::boundary_momenta(problem, tr);
  EXPECT_TRUE(m.p0.empty());
  EXPECT_TRUE(m.pN.empty());
}

}  // namespace
