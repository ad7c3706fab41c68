/**
 * @file ipopt_peer_test.cpp
 * Tests of the IPOPT peer against exact discrete solutions: a hand-written trapezoid harmonic
 * oscillator (1-D and 2-D with a knot), whose DEL equations are the linear recurrence
 * q_{k+1} - 2 q_k + q_{k-1} + (omega h)^2 q_k = 0 with the closed-form solution
 * q_k = A sin(k theta) + B cos(k theta), cos(theta) = 1 - (omega h)^2 / 2; the seed's
 * fuel-optimal example with the generated kernels; and rejection of bad input.
 */
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "ipopt_peer.hpp"

namespace {

// Trapezoid discrete Lagrangian of L = |q'|^2/2 - sum_i omega_i^2 q_i^2 / 2 with params omega_i,
// written by hand (independent of the code generator). DIM coordinates, order 1.
template <int DIM>
struct Harmonic {
  static void grad(double h, double, double, const double* q0, const double* q1, const double* p, double* Ld,
                   double* D1, double* D2) {
    double s = 0;
    for (int i = 0; i < DIM; ++i) {
      const double v = (q1[i] - q0[i]) / h, w2 = p[i] * p[i];
      s += 0.5 * h * v * v - 0.25 * h * w2 * (q0[i] * q0[i] + q1[i] * q1[i]);
      D1[i] = -v - 0.5 * h * w2 * q0[i];
      D2[i] = v - 0.5 * h * w2 * q1[i];
    }
    *Ld = s;
  }
  static void full(double h, double t0, double t1, const double* q0, const double* q1, const double* p, double* Ld,
                   double* D1, double* D2, double* D11, double* D12, double* D22) {
    grad(h, t0, t1, q0, q1, p, Ld, D1, D2);
    for (int i = 0; i < DIM * DIM; ++i) D11[i] = D12[i] = D22[i] = 0;
    for (int i = 0; i < DIM; ++i) {
      D11[i * DIM + i] = D22[i * DIM + i] = 1 / h - 0.5 * h * p[i] * p[i];
      D12[i * DIM + i] = -1 / h;
    }
  }
  static void sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p, double* D1,
                    double* D2, double* D11, double* D22) {
    double Ld, D12[DIM * DIM];
    full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, D12, D22);
  }
  static double action(double h, double t0, double t1, const double* q0, const double* q1, const double* p) {
    double Ld, D1[DIM], D2[DIM];
    grad(h, t0, t1, q0, q1, p, &Ld, D1, D2);
    return Ld;
  }
};

const char* const kCoords[] = {"x", "y"};
const char* const kParams[] = {"omega_x", "omega_y"};
const double kDefaults[] = {1.0, 2.0};
const pardel_discretization kDisc1[] = {
    {"trapezoid", 2, &Harmonic<1>::full, &Harmonic<1>::sweep, &Harmonic<1>::grad, &Harmonic<1>::action}};
const pardel_discretization kDisc2[] = {
    {"trapezoid", 2, &Harmonic<2>::full, &Harmonic<2>::sweep, &Harmonic<2>::grad, &Harmonic<2>::action}};
const pardel_model kHarmonic1 = {PARDEL_KERNEL_ABI_VERSION, "harmonic1", "", 1, 1, 1, kCoords, 1, kParams,
                                 kDefaults, 0, nullptr, 1, kDisc1};
const pardel_model kHarmonic2 = {PARDEL_KERNEL_ABI_VERSION, "harmonic2", "", 1, 2, 2, kCoords, 2, kParams,
                                 kDefaults, 0, nullptr, 1, kDisc2};

double theta_of(double omega, double h) { return std::acos(1 - 0.5 * omega * omega * h * h); }

TEST(IpoptPeer, HarmonicOscillatorMatchesExactDiscreteSolution) {
  pardel::Problem problem;
  problem.model = &kHarmonic1;
  problem.T = 2.0;  // omega T = 2 < pi: before the first conjugate point, the action is convex
  problem.N = 50;
  problem.q0 = {0.0};
  problem.qN = {1.0};
  pardel::Trajectory tr = pardel::peer::straight_line(problem);
  const pardel::peer::IpoptResult r = pardel::peer::solve_ipopt(problem, {}, tr);
  ASSERT_TRUE(r.ran) << r.message;
  EXPECT_EQ(r.status, "Solve_Succeeded");
  EXPECT_TRUE(r.converged) << r.brief_report();
  EXPECT_LE(r.residual, 1e-10);
  EXPECT_EQ(r.variables, 49);
  EXPECT_EQ(r.hessian_nonzeros, 49 + 48);
  // A quadratic objective with the exact Hessian: Newton's step is exact, a few iterations suffice.
  EXPECT_LE(r.iterations, 5);
  const double th = theta_of(1.0, problem.T / problem.N);
  double max_err = 0;
  for (int k = 0; k <= problem.N; ++k)
    max_err = std::max(max_err, std::fabs(tr.node(k)[0] - std::sin(k * th) / std::sin(problem.N * th)));
  EXPECT_LT(max_err, 1e-9);
  EXPECT_NEAR(r.action, pardel::peer::action_of(problem, tr), 1e-14);
}

TEST(IpoptPeer, KnotsPinCoordinatesAndSplitTheProblem) {
  pardel::Problem problem;
  problem.model = &kHarmonic2;
  problem.T = 1.0;
  problem.N = 40;
  problem.q0 = {0.0, 1.0};
  problem.qN = {1.0, -0.5};
  const int K = 10;
  problem.knots.push_back({problem.T * K / problem.N, {2.0, 0.25}});
  pardel::Trajectory tr = pardel::peer::straight_line(problem);
  pardel::peer::IpoptOptions options;
  options.threads = 2;
  const pardel::peer::IpoptResult r = pardel::peer::solve_ipopt(problem, options, tr);
  ASSERT_TRUE(r.ran) << r.message;
  EXPECT_TRUE(r.converged) << r.brief_report();
  EXPECT_EQ(r.variables, 2 * 39 - 2);
  const double h = problem.T / problem.N;
  const int N = problem.N;
  for (int i = 0; i < 2; ++i) {
    const double th = theta_of(kDefaults[i], h);
    const double a = problem.q0[i], b = problem.knots[0].q[i], c = problem.qN[i];
    for (int k = 0; k <= N; ++k) {
      const double exact = k <= K ? (a * std::sin((K - k) * th) + b * std::sin(k * th)) / std::sin(K * th)
                                  : (b * std::sin((N - k) * th) + c * std::sin((k - K) * th)) / std::sin((N - K) * th);
      EXPECT_NEAR(tr.node(k)[i], exact, 1e-9) << "coordinate " << i << " node " << k;
    }
  }
}

TEST(IpoptPeer, ResidualOfStraightLineIsRecomputedIndependently) {
  pardel::Problem problem;
  problem.model = &kHarmonic1;
  problem.T = 1.0;
  problem.N = 4;
  problem.q0 = {0.0};
  problem.qN = {1.0};
  const pardel::Trajectory tr = pardel::peer::straight_line(problem);
  // q_k = k/4, h = 1/4, omega = 1: residual_k = -(second difference)/h - h q_k = -q_k / 4.
  EXPECT_NEAR(pardel::peer::del_residual(problem, tr), 0.75 / 4, 1e-15);
}

TEST(IpoptPeer, FuelNavigationReachesTheSeedExampleAction) {
  // The seed's fuel-optimal example with the generated kernels: T = 30, (0,0) -> (6,5), N = 200.
  pardel::Problem problem;
  problem.model = pardel::find_model("fuel_nav");
  if (!problem.model) GTEST_SKIP() << "fuel_nav is not bundled in this build";
  problem.T = 30;
  problem.N = 200;
  problem.q0 = {0.0, 0.0};
  problem.qN = {6.0, 5.0};
  pardel::Trajectory tr = pardel::peer::straight_line(problem);
  const pardel::peer::IpoptResult r = pardel::peer::solve_ipopt(problem, {}, tr);
  ASSERT_TRUE(r.ran) << r.message;
  EXPECT_EQ(r.status, "Solve_Succeeded");
  EXPECT_TRUE(r.converged) << r.brief_report();
  EXPECT_NEAR(r.action, 5.59683215, 5e-9);
  // The residual is recomputed independently of IPOPT's own convergence test.
  EXPECT_NEAR(pardel::peer::del_residual(problem, tr), r.residual, 1e-15);
}

TEST(IpoptPeer, RejectsBadInputWithMessageNamingTheKey) {
  pardel::Problem problem;
  problem.model = &kHarmonic1;
  problem.N = 1;
  problem.q0 = {0.0};
  problem.qN = {1.0};
  pardel::Trajectory tr = pardel::peer::straight_line(problem);
  pardel::peer::IpoptResult r = pardel::peer::solve_ipopt(problem, {}, tr);
  EXPECT_FALSE(r.ran);
  EXPECT_NE(r.message.find("problem.N"), std::string::npos) << r.message;

  problem.N = 10;
  problem.qN = {1.0, 2.0};
  tr = pardel::peer::straight_line(problem);
  r = pardel::peer::solve_ipopt(problem, {}, tr);
  EXPECT_FALSE(r.ran);
  EXPECT_NE(r.message.find("qN"), std::string::npos) << r.message;

  problem.qN = {1.0};
  problem.knots.push_back({0.123, {0.5}});
  tr = pardel::peer::straight_line(problem);
  r = pardel::peer::solve_ipopt(problem, {}, tr);
  EXPECT_FALSE(r.ran);
  EXPECT_NE(r.message.find("knots[0].t"), std::string::npos) << r.message;

  problem.knots.clear();
  pardel::peer::IpoptOptions options;
  options.tol = -1;
  r = pardel::peer::solve_ipopt(problem, options, tr);
  EXPECT_FALSE(r.ran);
  EXPECT_NE(r.message.find("tol"), std::string::npos) << r.message;

  tr.q.pop_back();
  r = pardel::peer::solve_ipopt(problem, {}, tr);
  EXPECT_FALSE(r.ran);
  EXPECT_NE(r.message.find("trajectory"), std::string::npos) << r.message;
}

}  // namespace
