/**
 * @file test_certificate.cpp
 * The convergence certificate against closed forms: for the harmonic oscillator's trapezoid DEL
 * the Hessian is a + (1/h) tridiag(-1, 0, -1) with a = 2/h - h w^2, so its eigenvalues are
 * a - (2/h) cos(j pi / N) and the Jacobi spectral radius is 2 cos(pi/N) / (2 - h^2 w^2).
 * Also the interval hypotheses of the seed's positive-definiteness theorem (free particle: hold; harmonic:
 * H^Ld_k indefinite; spline trapezoid(alpha=1): hold), knots restricting the Hessian, and the report.
 * At orders 3 and 4 (bundled min_jerk, min_snap), where 1 - rho falls like N^(-2 order), the
 * radius against the dense generalized eigenproblem H x = lambda D x (1 - rho = lambda_min), and
 * a radius within round-off of 1 reported as such. And the certificate and a solve's point
 * assessment counting the inertia of a nearly singular Hessian alike, against its dense eigenvalues.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <string>

#include "block_tridiagonal.hpp"
#include "engine.hpp"
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

TEST(Certificate, HarmonicOneMinusRhoWithoutCancellation) {
  const int N = 400;
  const auto p = harmonic_problem(1.0, 2.0, N);
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  const double h = 2.0 / N;
  // 1 - 2 cos(pi/N) / (2 - h^2) without cancellation: (4 sin^2(pi/2N) - h^2) / (2 - h^2)
  const double s = std::sin(M_PI / (2 * N)), gap = (4 * s * s - h * h) / (2 - h * h);
  EXPECT_TRUE(c.spectral_radius_converged);
  EXPECT_TRUE(c.spectral_radius_resolved);
  EXPECT_NEAR(c.jacobi_one_minus_rho, gap, 1e-9 * gap);
  EXPECT_LT(c.jacobi_one_minus_rho_roundoff, 1e-13);
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
/** A bundled model between end states with nonzero jets, N intervals over [0, T]. */
pardel::Problem bundled_problem(const char* name, double T, int N) {
  pardel::Problem p;
  p.model = pardel::find_model(name);
  p.discretization = &p.model->discretizations[0];
  p.T = T;
  p.N = N;
  const auto dim = static_cast<std::size_t>(p.model->dim);
  for (std::size_t i = 0; i < dim; ++i) {
    p.q0.push_back(std::sin(1.0 + static_cast<double>(i)));
    p.qN.push_back(std::cos(0.5 * static_cast<double>(i)));
  }
  return p;
}

/** 1 - rho from the dense Hessian at the linear guess: the smallest eigenvalue of H x = lambda D x,
 *  D its block diagonal, both scaled by diag(H)^(-1/2) (a similarity of J). */
double dense_one_minus_rho(const pardel::Problem& p) {
  pardel::detail::Context ctx;
  std::string error;
  EXPECT_TRUE(pardel::detail::context_at(p, pardel::linear_guess(p), 1, ctx, &error)) << error;
  pardel::detail::eval_full(ctx, ctx.q);
  pardel::detail::BlockTridiagonal<Eigen::Dynamic> B;
  B.resize(ctx.N, ctx.dim);
  B.assemble(ctx, 0.0);
  const int n = B.blocks(), d = ctx.dim, m = n * d;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m, m), D = Eigen::MatrixXd::Zero(m, m);
  for (int i = 0; i < n; ++i) {
    H.block(i * d, i * d, d, d) = B.diag(i);
    D.block(i * d, i * d, d, d) = B.diag(i);
    if (i + 1 < n) {
      H.block(i * d, (i + 1) * d, d, d) = B.off(i);
      H.block((i + 1) * d, i * d, d, d) = B.off(i).transpose();
    }
  }
  const Eigen::VectorXd s = H.diagonal().cwiseAbs().cwiseSqrt().cwiseInverse();
  H = s.asDiagonal() * H * s.asDiagonal();
  D = s.asDiagonal() * D * s.asDiagonal();
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> es(H, D, Eigen::EigenvaluesOnly);
  EXPECT_EQ(es.info(), Eigen::Success);
  // The spectrum of J is symmetric: the largest eigenvalue is 1 + rho.
  const Eigen::VectorXd& ev = es.eigenvalues();
  EXPECT_NEAR(ev[m - 1] - 1, 1 - ev[0], 1e-8);
  return ev[0];
}

// 1 - rho ~ N^(-2 order): 2.7e-9 (min_jerk, N = 50), 4.3e-11 (N = 100), 1.8e-12 (min_snap,
// N = 50). Formed as 1 - (a Lanczos estimate of rho), it was 4.2e-8, 5.1e-8 and 2.1e-8.
TEST(Certificate, HighOrderRadiusMatchesTheDenseEigenproblem) {
  struct Case {
    const char* model;
    int N;
  };
  for (const Case& k : {Case{"min_jerk", 50}, Case{"min_jerk", 100}, Case{"min_snap", 50}}) {
    const auto p = bundled_problem(k.model, 2.0, k.N);
    const double truth = dense_one_minus_rho(p);
    const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
    ASSERT_TRUE(c.error.empty()) << c.error;
    std::printf("%s N = %d: 1 - rho dense %.6e, certificate %.6e (round-off level %.1e), 1 - radius %.6e\n",
                k.model, k.N, truth, c.jacobi_one_minus_rho, c.jacobi_one_minus_rho_roundoff,
                1 - c.jacobi_spectral_radius);
    EXPECT_TRUE(c.hessian_positive_definite) << k.model << " N = " << k.N;
    EXPECT_EQ(c.inertia_zero, 0) << k.model << " N = " << k.N;
    EXPECT_TRUE(c.spectral_radius_converged) << k.model << " N = " << k.N;
    EXPECT_TRUE(c.spectral_radius_resolved) << k.model << " N = " << k.N;
    EXPECT_NEAR(1 - c.jacobi_spectral_radius, truth, 1e-3 * truth) << k.model << " N = " << k.N;
    EXPECT_NEAR(c.jacobi_one_minus_rho, truth, 1e-3 * truth) << k.model << " N = " << k.N;
    EXPECT_NEAR(c.expected_iterations, std::log(1e-10 / c.residual) / std::log1p(-truth),
                2e-3 * c.expected_iterations);
  }
}

// min_snap at N = 400: 1 - rho ~ 1e-19, far below the round-off level (about 1e-14; H is not
// even positive definite in double precision): the certificate says that rho is 1 to within
// round-off and gives a lower bound on the sweeps.
TEST(Certificate, RadiusWithinRoundOffOfOneIsReportedAsSuch) {
  const auto p = bundled_problem("min_snap", 2.0, 400);
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  ASSERT_TRUE(c.error.empty()) << c.error;
  EXPECT_FALSE(c.spectral_radius_resolved);
  EXPECT_GT(c.jacobi_one_minus_rho_roundoff, 0);
  EXPECT_LE(std::fabs(c.jacobi_one_minus_rho), c.jacobi_one_minus_rho_roundoff);
  EXPECT_GT(c.expected_iterations, 1e12);
  EXPECT_NE(c.report().find("not determined in double precision"), std::string::npos) << c.report();
  EXPECT_NE(c.report().find("at least"), std::string::npos);
}
#endif

TEST(Certificate, KnotOffTheGridIsAnError) {
  pardel::Problem p = harmonic_problem(1.0, 1.0, 10);
  p.knots = {{0.33, {0.1}}};
  const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
  EXPECT_NE(c.error.find("knot 0"), std::string::npos) << c.error;
  EXPECT_NE(c.error.find("nearest nodes: 3"), std::string::npos) << c.error;
  EXPECT_NE(c.report().find("not computed"), std::string::npos);
}

// ---- Two harmonic oscillators x, y (trapezoid, decoupled), frequencies p[0], p[1]: the Hessian's
// blocks are diagonal, so its pivots are diag(x pivot, y pivot), and a y frequency next to its
// conjugate point makes one y pivot tiny beside the x pivot of the same block.
void pair_full(double h, double, double, const double* q0, const double* q1, const double* p, double* Ld, double* D1,
               double* D2, double* D11, double* D12, double* D22) {
  *Ld = 0;
  for (int a = 0; a < 2; ++a) {
    const double w2 = p[a] * p[a], dx = q1[a] - q0[a];
    *Ld += dx * dx / (2 * h) - h * w2 * (q0[a] * q0[a] + q1[a] * q1[a]) / 4;
    D1[a] = -dx / h - h * w2 * q0[a] / 2;
    D2[a] = dx / h - h * w2 * q1[a] / 2;
  }
  for (int k = 0; k < 4; ++k) D11[k] = D12[k] = D22[k] = 0;
  for (int a = 0; a < 2; ++a) {
    D11[3 * a] = D22[3 * a] = 1 / h - h * p[a] * p[a] / 2;
    D12[3 * a] = -1 / h;
  }
}
void pair_sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p, double* D1,
                double* D2, double* D11, double* D22) {
  double Ld, D12[4];
  pair_full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, D12, D22);
}
void pair_grad(double h, double t0, double t1, const double* q0, const double* q1, const double* p, double* Ld,
               double* D1, double* D2) {
  double D11[4], D12[4], D22[4];
  pair_full(h, t0, t1, q0, q1, p, Ld, D1, D2, D11, D12, D22);
}
double pair_action(double h, double t0, double t1, const double* q0, const double* q1, const double* p) {
  double Ld, D1[2], D2[2];
  pair_grad(h, t0, t1, q0, q1, p, &Ld, D1, D2);
  return Ld;
}
const char* const pair_coords[] = {"x", "y"};
const char* const pair_params[] = {"omega_x", "omega_y"};
const double pair_defaults[] = {1.0, 1.0};
const pardel_discretization pair_discs[] = {{"trapezoid", 2, pair_full, pair_sweep, pair_grad, pair_action}};
const pardel_model pair_model = {PARDEL_KERNEL_ABI_VERSION, "test_oscillator_pair", "tests/runtime/test_certificate.cpp",
                                 1, 2, 2, pair_coords, 2, pair_params, pair_defaults, 0, nullptr, 1, pair_discs, nullptr,
                                 PARDEL_COST_ACTION};

// The certificate (pardel check) and a solve's point assessment count the inertia of a Hessian
// whose smallest eigenvalue is near zero alike, and as the dense eigenvalues say. y's Hessian is
// a - (1/h) tridiag(1, 0, 1), a = 2/h - h w_y^2, with the eigenvalues a - (2/h) cos(j pi / N); w_y
// puts the smallest at lambda (positive, negative or zero). At lambda = +-4e-12 the last y pivot
// is about 1e-11 of the x pivot of its block: a rule relative to each pivot (the certificate's
// former one, 1e-10 of the block) calls it zero, while the eigenvalue is far above what rounding
// makes of the dense matrix, whose signs are therefore the truth; at lambda = 0 the dense
// eigenvalue is rounding and the truth is a zero.
TEST(Certificate, CertificateAndAssessmentCountTheInertiaOfANearlySingularHessianAlike) {
  const int N = 10;
  const double T = 1, h = T / N, b = 1 / h;
  const int n = N - 1;
  for (const double lambda : {4e-12, -4e-12, 0.0}) {
    char trace[64];
    std::snprintf(trace, sizeof trace, "lambda = %g", lambda);
    SCOPED_TRACE(trace);
    const double wy2 = (2 / h * (1 - std::cos(M_PI / N)) - lambda) / h;
    pardel::Problem p;
    p.model = &pair_model;
    p.discretization = &pair_discs[0];
    p.params = {1.0, std::sqrt(wy2)};
    p.T = T;
    p.N = N;
    p.q0 = {1.0, 0.0};
    p.qN = {0.5, 0.0};
    // The dense Hessian over the unknown nodes, node by node (x, y), from the closed form.
    const double a[2] = {2 / h - h * p.params[0] * p.params[0], 2 / h - h * wy2};
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2 * n, 2 * n);
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < 2; ++c) {
        H(2 * k + c, 2 * k + c) = a[c];
        if (k + 1 < n) H(2 * k + c, 2 * k + 2 + c) = H(2 * k + 2 + c, 2 * k + c) = -b;
      }
    const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H, Eigen::EigenvaluesOnly).eigenvalues();
    const double size = ev.cwiseAbs().maxCoeff(), rounding = 100 * 2.2e-16 * size;
    long truth_pos = 0, truth_neg = 0, truth_zero = 0;
    for (Eigen::Index i = 0; i < ev.size(); ++i) {
      if (lambda == 0 && std::fabs(ev[i]) <= rounding) {
        ++truth_zero;
        continue;
      }
      ASSERT_GT(std::fabs(ev[i]), rounding) << "the sign of every eigenvalue is determined";
      (ev[i] > 0 ? truth_pos : truth_neg) += 1;
    }
    ASSERT_EQ(truth_zero, lambda == 0 ? 1 : 0);
    ASSERT_EQ(truth_neg, lambda < 0 ? 1 : 0);
    if (lambda != 0) {
      // The premise: the last y pivot, against the x pivot of its block (long double recursions).
      long double px = a[0], py = a[1];
      for (int k = 1; k < n; ++k) {
        px = a[0] - static_cast<long double>(b) * b / px;
        py = a[1] - static_cast<long double>(b) * b / py;
      }
      ASSERT_LT(std::fabs(static_cast<double>(py)), 1e-10 * std::fabs(static_cast<double>(px)));
    }

    const auto c = pardel::certify(p, pardel::linear_guess(p), 1);
    ASSERT_TRUE(c.error.empty()) << c.error;
    EXPECT_EQ(c.inertia_positive, truth_pos);
    EXPECT_EQ(c.inertia_negative, truth_neg);
    EXPECT_EQ(c.inertia_zero, truth_zero);
    EXPECT_EQ(c.hessian_positive_definite, truth_neg == 0 && truth_zero == 0);

    // A solve: y = 0 holds from the start; Newton solves x. At a saddle, the stationary-point Newton.
    pardel::Options o;
    if (lambda < 0) o.method = pardel::Method::stationary_newton;
    pardel::Trajectory tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, o, tr);
    ASSERT_EQ(s.termination, pardel::Termination::converged) << s.message;
    EXPECT_EQ(s.point.positive, truth_pos) << s.point.note;
    EXPECT_EQ(s.point.negative, truth_neg) << s.point.note;
    EXPECT_EQ(s.point.zero, truth_zero) << s.point.note;
    EXPECT_EQ(s.point.kind, truth_neg > 0    ? pardel::PointKind::saddle
                            : truth_zero > 0 ? pardel::PointKind::degenerate
                                             : pardel::PointKind::minimum)
        << s.point.note;
    // The same at the returned trajectory, assessed alone.
    const pardel::PointAssessment alone = pardel::assess_point(p, tr, 1);
    EXPECT_EQ(alone.positive, truth_pos) << alone.note;
    EXPECT_EQ(alone.negative, truth_neg) << alone.note;
    EXPECT_EQ(alone.zero, truth_zero) << alone.note;
  }
}

}  // namespace
