/**
 * @file test_appendix_identities.cpp
 * The seed's appendix, checked numerically for gamma = 1, 2, 3 from the definitions of A(h), B(h),
 * C(h), D and E: A(-h) = D A(h) D = A(h)^{-1}, B(-h) = -D B(h) D, C(h) = A(h) D B(h),
 * C(h) = -D C(-h) D, the LU factors of C(h) (and the gamma = 3 example), det C(h) =
 * h^{gamma^2} prod a!/(gamma+a)!, positive definiteness of C(h), det B(h) = (-1)^{gamma(gamma-1)/2}
 * det C(h), E^2 = I and E A(h) E = A(h)^T. Then the leading term of the trapezoid(alpha) family's
 * Hessian (eq. trapezoidal) against the hand-written and, when bundled, the generated spline kernels.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

using Eigen::MatrixXd;

double fact(int n) { return n < 0 ? INFINITY : std::tgamma(n + 1.0); }

MatrixXd A(int g, double h) {
  MatrixXd m = MatrixXd::Zero(g, g);
  for (int a = 0; a < g; ++a)
    for (int b = a; b < g; ++b) m(a, b) = std::pow(h, b - a) / fact(b - a);
  return m;
}
MatrixXd B(int g, double h) {
  MatrixXd m(g, g);
  for (int a = 0; a < g; ++a)
    for (int b = 0; b < g; ++b) m(a, b) = std::pow(h, 2 * g - a - b - 1) / fact(2 * g - a - b - 1);
  return m;
}
MatrixXd C(int g, double h) {
  MatrixXd m(g, g);
  for (int a = 0; a < g; ++a)
    for (int b = 0; b < g; ++b)
      m(a, b) = std::pow(h, 2 * g - a - b - 1) / ((2 * g - a - b - 1) * fact(g - a - 1) * fact(g - b - 1));
  return m;
}
MatrixXd D(int g) {
  MatrixXd m = MatrixXd::Zero(g, g);
  for (int a = 0; a < g; ++a) m(a, a) = (g - a - 1) % 2 == 0 ? 1 : -1;
  return m;
}
MatrixXd E(int g) {
  MatrixXd m = MatrixXd::Zero(g, g);
  for (int a = 0; a < g; ++a) m(a, g - a - 1) = 1;
  return m;
}
MatrixXd L(int g, double h) {
  MatrixXd m = MatrixXd::Zero(g, g);
  for (int a = 0; a < g; ++a)
    for (int b = 0; b <= a; ++b)
      m(a, b) = std::pow(h, b - a) * fact(a) * fact(2 * g - b - 1) * fact(g - b - 1) * fact(2 * g - a - b - 2) /
                (fact(b) * fact(a - b) * fact(2 * g - a - 1) * fact(g - a - 1) * fact(2 * g - 2 * b - 2));
  return m;
}
MatrixXd U(int g, double h) {
  MatrixXd m = MatrixXd::Zero(g, g);
  for (int a = 0; a < g; ++a)
    for (int b = a; b < g; ++b)
      m(a, b) = std::pow(h, 2 * g - a - b - 1) * fact(a) * fact(b) * fact(2 * g - 2 * a - 1) * fact(2 * g - a - b - 2) /
                (fact(b - a) * fact(2 * g - a - 1) * fact(2 * g - b - 1) * fact(g - a - 1) * fact(g - b - 1));
  return m;
}

void expect_close(const MatrixXd& x, const MatrixXd& y, const char* what, int g) {
  ASSERT_EQ(x.rows(), y.rows());
  EXPECT_LE((x - y).cwiseAbs().maxCoeff(), 1e-12 * (1 + y.cwiseAbs().maxCoeff())) << what << ", gamma = " << g
                                                                                 << "\n" << x << "\nvs\n" << y;
}

TEST(AppendixIdentities, LemmaAB) {
  for (int g = 1; g <= 3; ++g)
    for (double h : {0.7, 1.3}) {
      expect_close(A(g, -h), D(g) * A(g, h) * D(g), "A(-h) = D A(h) D", g);
      expect_close(A(g, -h), A(g, h).inverse(), "A(-h) = A(h)^-1", g);
      expect_close(B(g, -h), -D(g) * B(g, h) * D(g), "B(-h) = -D B(h) D", g);
      expect_close(E(g) * E(g), MatrixXd::Identity(g, g), "E^2 = I", g);
      expect_close(E(g) * A(g, h) * E(g), A(g, h).transpose(), "E A E = A^T", g);
    }
}

TEST(AppendixIdentities, LemmaC) {
  for (int g = 1; g <= 3; ++g)
    for (double h : {0.7, 1.3}) {
      expect_close(C(g, h), A(g, h) * D(g) * B(g, h), "C = A D B", g);
      expect_close(C(g, h), -D(g) * C(g, -h) * D(g), "C(h) = -D C(-h) D", g);
      expect_close(L(g, h) * U(g, h), C(g, h), "C = L U", g);
      for (int a = 0; a < g; ++a) EXPECT_DOUBLE_EQ(L(g, h)(a, a), 1.0);
      double prod = 1;
      for (int a = 0; a < g; ++a) prod *= fact(a) / fact(g + a);
      const double detC = std::pow(h, g * g) * prod;
      EXPECT_NEAR(C(g, h).determinant(), detC, 1e-12 * std::fabs(detC));
      EXPECT_NEAR(U(g, h).diagonal().prod(), detC, 1e-12 * std::fabs(detC));
      EXPECT_EQ(C(g, h).llt().info(), Eigen::Success) << "C(h) positive definite, gamma = " << g;
      EXPECT_NE(C(g, -h).llt().info(), Eigen::Success);
      EXPECT_EQ((-C(g, -h)).llt().info(), Eigen::Success) << "C(-h) negative definite, gamma = " << g;
      const double sign = (g * (g - 1) / 2) % 2 == 0 ? 1 : -1;
      EXPECT_NEAR(B(g, h).determinant(), sign * detC, 1e-12 * std::fabs(detC));
    }
}

TEST(AppendixIdentities, GammaThreeExampleFactors) {
  const double h = 0.9;
  MatrixXd Lx(3, 3), Ux(3, 3);
  Lx << 1, 0, 0, 5 / (2 * h), 1, 0, 10 / (3 * h * h), 4 / h, 1;
  Ux << std::pow(h, 5) / 20, std::pow(h, 4) / 8, std::pow(h, 3) / 6, 0, std::pow(h, 3) / 48, h * h / 12, 0, 0, h / 9;
  expect_close(L(3, h), Lx, "L(h) of the example", 3);
  expect_close(U(3, h), Ux, "U(h) of the example", 3);
  MatrixXd Cx(3, 3);
  Cx << std::pow(h, 5) / 20, std::pow(h, 4) / 8, std::pow(h, 3) / 6, std::pow(h, 4) / 8, std::pow(h, 3) / 3, h * h / 2,
      std::pow(h, 3) / 6, h * h / 2, h;
  expect_close(C(3, h), Cx, "C(h) of the example", 3);
}

/** The 4x4 matrix of eq. trapezoidal in the order (q0, v0, q1, v1). */
MatrixXd trapezoidal_leading(double a, double h) {
  const double s = 9 * a * a;
  MatrixXd m(4, 4);
  m << 4 * s / (h * h * h), 2 * s / (h * h), -4 * s / (h * h * h), 2 * s / (h * h),  //
      2 * s / (h * h), (s + 1) / h, -2 * s / (h * h), (s - 1) / h,                  //
      -4 * s / (h * h * h), -2 * s / (h * h), 4 * s / (h * h * h), -2 * s / (h * h), //
      2 * s / (h * h), (s - 1) / h, -2 * s / (h * h), (s + 1) / h;
  return m;
}

/** The kernel's Hessian of Ld in the order (q0 coords, q0 derivs, q1 coords, q1 derivs). */
MatrixXd kernel_hessian(const pardel_discretization& d, int dim, double h, const double* p) {
  std::vector<double> q0(dim), q1(dim), D1(dim), D2(dim), D11(dim * dim), D12(dim * dim), D22(dim * dim);
  for (int i = 0; i < dim; ++i) {
    q0[i] = 0.1 * (i + 1);
    q1[i] = -0.2 * i + 0.3;
  }
  double Ld;
  d.full(h, 0.0, h, q0.data(), q1.data(), p, &Ld, D1.data(), D2.data(), D11.data(), D12.data(), D22.data());
  MatrixXd H(2 * dim, 2 * dim);
  for (int i = 0; i < dim; ++i)
    for (int j = 0; j < dim; ++j) {
      H(i, j) = D11[i * dim + j];
      H(i, dim + j) = D12[i * dim + j];
      H(dim + j, i) = D12[i * dim + j];
      H(dim + i, dim + j) = D22[i * dim + j];
    }
  return H;
}

TEST(AppendixIdentities, TrapezoidHessianLeadingTermHandKernel) {
  // L = q''^2 / 2 has W = 1 and no higher-order terms: eq. trapezoidal holds exactly.
  for (double alpha : {1.0, 0.5, 2.0})
    for (double h : {0.1, 0.01}) {
      const double p[1] = {alpha};
      expect_close(kernel_hessian(hand::spline.discretizations[0], 2, h, p), trapezoidal_leading(alpha, h),
                   "hand trapezoid(alpha) Hessian", 2);
    }
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
TEST(AppendixIdentities, TrapezoidHessianLeadingTermGeneratedSpline) {
  const pardel_model* m = pardel::find_model("spline");
  if (!m) GTEST_SKIP() << "spline is not bundled";
  const pardel_discretization* d = pardel::find_discretization(*m, "trapezoid(alpha=1)");
  ASSERT_NE(d, nullptr);
  ASSERT_EQ(m->dim, 4);
  for (double h : {0.1, 0.01, 0.001}) {
    // Coordinates (x, y) with W = I_2: entry ((n,a,i), (m,b,j)) = M(2n+a, 2m+b) delta_ij, where n, m
    // are the nodes, a, b the derivative orders and i, j the coordinates (index 4n + 2a + i).
    const MatrixXd M = trapezoidal_leading(1.0, h);
    MatrixXd expected = MatrixXd::Zero(8, 8);
    for (int r = 0; r < 8; ++r)
      for (int c = 0; c < 8; ++c)
        if (r % 2 == c % 2) expected(r, c) = M(r / 2, c / 2);
    expect_close(kernel_hessian(*d, 4, h, m->param_defaults), expected, "generated spline trapezoid(alpha=1)", 2);
  }
}
#endif

}  // namespace
