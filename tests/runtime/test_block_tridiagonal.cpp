/**
 * @file test_block_tridiagonal.cpp
 * The block-tridiagonal Hessian solvers (runtime/src/block_tridiagonal.hpp): block LDL^T and
 * block cyclic reduction against a dense Eigen solve on random symmetric positive definite
 * systems, detection of indefiniteness, the indefinite factorization (solves and inertia against
 * a dense eigendecomposition, a singular matrix refused), restriction to free components, and
 * fixed-size versus dynamic block sizes giving the same answer.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "block_tridiagonal.hpp"

namespace {

using pardel::detail::BlockTridiagonal;
using pardel::detail::Context;

/** A context whose interval arrays hold random symmetric second derivatives (D12 arbitrary). */
Context random_context(int N, int d, double diag_boost, unsigned seed) {
  Context ctx;
  ctx.N = N;
  ctx.dim = d;
  ctx.threads = 1;
  const std::size_t dd = static_cast<std::size_t>(d) * d;
  ctx.D11.assign(N * dd, 0);
  ctx.D12.assign(N * dd, 0);
  ctx.D22.assign(N * dd, 0);
  ctx.is_free.assign(static_cast<std::size_t>(N + 1) * d, 1);
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < N; ++k) {
    Eigen::MatrixXd A = Eigen::MatrixXd::NullaryExpr(d, d, [&] { return u(gen); });
    Eigen::MatrixXd B = Eigen::MatrixXd::NullaryExpr(d, d, [&] { return u(gen); });
    Eigen::MatrixXd C = Eigen::MatrixXd::NullaryExpr(d, d, [&] { return u(gen); });
    A = A * A.transpose() + diag_boost * Eigen::MatrixXd::Identity(d, d);
    B = B * B.transpose() + diag_boost * Eigen::MatrixXd::Identity(d, d);
    for (int i = 0; i < d; ++i)
      for (int j = 0; j < d; ++j) {
        ctx.D11[k * dd + i * d + j] = A(i, j);
        ctx.D22[k * dd + i * d + j] = B(i, j);
        ctx.D12[k * dd + i * d + j] = C(i, j);
      }
  }
  return ctx;
}

/** The dense Hessian over nodes 1..N-1 with fixed components replaced by identity rows. */
Eigen::MatrixXd dense_hessian(const Context& ctx) {
  const int d = ctx.dim, n = ctx.N - 1;
  const std::size_t dd = static_cast<std::size_t>(d) * d;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n * d, n * d);
  for (int k = 1; k < ctx.N; ++k)
    for (int i = 0; i < d; ++i)
      for (int j = 0; j < d; ++j) {
        H((k - 1) * d + i, (k - 1) * d + j) = ctx.D22[(k - 1) * dd + i * d + j] + ctx.D11[k * dd + i * d + j];
        if (k < ctx.N - 1) {
          H((k - 1) * d + i, k * d + j) = ctx.D12[k * dd + i * d + j];
          H(k * d + j, (k - 1) * d + i) = ctx.D12[k * dd + i * d + j];
        }
      }
  for (int k = 1; k < ctx.N; ++k)
    for (int i = 0; i < d; ++i)
      if (!ctx.is_free[k * d + i]) {
        H.row((k - 1) * d + i).setZero();
        H.col((k - 1) * d + i).setZero();
        H((k - 1) * d + i, (k - 1) * d + i) = 1;
      }
  return H;
}

/** A right-hand side over nodes 1..N-1, zero on fixed components. */
Eigen::VectorXd right_hand_side(const Context& ctx) {
  const int d = ctx.dim, N = ctx.N;
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced((N - 1) * d, -1, 2);
  for (int k = 1; k < N; ++k)
    for (int i = 0; i < d; ++i)
      if (!ctx.is_free[k * d + i]) b[(k - 1) * d + i] = 0;
  return b;
}

template <int D>
void check_solvers(int N, int d, unsigned seed, bool with_fixed) {
  Context ctx = random_context(N, d, 3.0 * d, seed);
  if (with_fixed) {
    ctx.is_free[3 * d + 0] = 0;
    ctx.is_free[(N / 2) * d + d - 1] = 0;
  }
  Eigen::MatrixXd H = dense_hessian(ctx);
  if (H.llt().info() != Eigen::Success) GTEST_SKIP() << "random matrix not p.d.";
  const int n = (N - 1) * d;
  const Eigen::VectorXd b = right_hand_side(ctx);
  const Eigen::VectorXd exact = H.ldlt().solve(b);

  BlockTridiagonal<D> T;
  T.resize(N, d);
  T.assemble(ctx, 0.0);
  ASSERT_TRUE(T.factor_ldlt());
  Eigen::VectorXd x(n);
  T.solve_ldlt(b.data(), x.data());
  EXPECT_LT((x - exact).norm(), 1e-10 * exact.norm());
  Eigen::VectorXd y(n);
  ASSERT_TRUE(T.solve_cyclic_reduction(b.data(), y.data(), 1));
  EXPECT_LT((y - exact).norm(), 1e-10 * exact.norm());
  EXPECT_NEAR(T.quadratic_form(exact.data()), exact.dot(H * exact), 1e-9 * std::fabs(exact.dot(H * exact)));
}

TEST(BlockTridiagonal, FixedSizeBlocksMatchDenseSolve) {
  for (int N : {2, 3, 4, 7, 16, 33}) {
    check_solvers<2>(N, 2, 10u + N, false);
    check_solvers<2>(N, 2, 20u + N, N > 5);
  }
  check_solvers<1>(50, 1, 3u, false);
  check_solvers<4>(21, 4, 4u, true);
}

TEST(BlockTridiagonal, TwoByTwoPivotsAtAnyScale) {
  // Blocks of size 2 form S^-1 C by the adjugate; where det S overflows (entries 1e155) or
  // underflows (1e-160) they take it from the Cholesky factor: the solve is the dense one's,
  // scaled, at every scale.
  for (double s : {1.0, 1e155, 1e-160}) {
    Context ctx = random_context(12, 2, 6.0, 5u);
    const Eigen::MatrixXd H = dense_hessian(ctx);
    const Eigen::VectorXd b = right_hand_side(ctx);
    const Eigen::VectorXd exact = H.ldlt().solve(b) / s;
    for (std::vector<double>* v : {&ctx.D11, &ctx.D12, &ctx.D22})
      for (double& x : *v) x *= s;
    BlockTridiagonal<2> T;
    T.resize(ctx.N, 2);
    T.assemble(ctx, 0.0);
    ASSERT_TRUE(T.factor_ldlt()) << "scale " << s;
    Eigen::VectorXd x(exact.size());
    T.solve_ldlt(b.data(), x.data());
    EXPECT_LT((x - exact).norm(), 1e-12 * exact.norm()) << "scale " << s;
  }
}

TEST(BlockTridiagonal, TwoByTwoPivotsFailWhereTheGeneralOnesDo) {
  // An indefinite Hessian: the first pivot that is not positive definite is the same block for
  // the 2 x 2 path and for dynamic blocks.
  int indefinite = 0;
  for (unsigned seed : {31u, 32u, 33u, 34u, 35u, 36u}) {
    Context ctx = random_context(40, 2, 0.0, seed);
    if (dense_hessian(ctx).llt().info() == Eigen::Success) continue;
    ++indefinite;
    BlockTridiagonal<2> fixed;
    BlockTridiagonal<Eigen::Dynamic> dynamic;
    fixed.resize(ctx.N, 2);
    dynamic.resize(ctx.N, 2);
    fixed.assemble(ctx, 0.0);
    dynamic.assemble(ctx, 0.0);
    EXPECT_FALSE(fixed.factor_ldlt());
    EXPECT_FALSE(dynamic.factor_ldlt());
    EXPECT_EQ(fixed.failed_block(), dynamic.failed_block()) << "seed " << seed;
  }
  EXPECT_GE(indefinite, 3);
}

TEST(BlockTridiagonal, DynamicBlocksMatchDenseSolve) {
  for (int N : {5, 18}) {
    check_solvers<Eigen::Dynamic>(N, 5, 7u + N, false);
    check_solvers<Eigen::Dynamic>(N, 3, 9u + N, true);
  }
}

TEST(BlockTridiagonal, IndefiniteIsDetectedAndShiftRestoresDefiniteness) {
  // The 1-D Laplacian minus a multiple of the identity beyond its smallest eigenvalue.
  const int N = 30;
  Context ctx = random_context(N, 1, 0.0, 1u);
  for (int k = 0; k < N; ++k) {
    ctx.D11[k] = 1.0 - 0.05;
    ctx.D22[k] = 1.0 - 0.05;
    ctx.D12[k] = -1.0;
  }
  BlockTridiagonal<1> T;
  T.resize(N, 1);
  T.assemble(ctx, 0.0);
  EXPECT_FALSE(T.factor_ldlt());
  EXPECT_GE(T.failed_block(), 0);
  std::vector<double> b(N - 1, 1.0), x(N - 1);
  EXPECT_FALSE(T.solve_cyclic_reduction(b.data(), x.data(), 1));
  T.assemble(ctx, 0.2);  // lambda_min = 2 - 2 cos(pi/30) - 0.1 > -0.2
  EXPECT_TRUE(T.factor_ldlt());
  EXPECT_TRUE(T.solve_cyclic_reduction(b.data(), x.data(), 1));
}

template <int D>
void check_indefinite(int N, int d, unsigned seed, bool with_fixed) {
  // Random blocks shifted down so that H has eigenvalues of both signs.
  Context ctx = random_context(N, d, 0.0, seed);
  const std::size_t dd = static_cast<std::size_t>(d) * d;
  for (int k = 0; k < N; ++k)
    for (int i = 0; i < d; ++i) ctx.D11[k * dd + i * d + i] -= 1.5;
  if (with_fixed) ctx.is_free[2 * d] = 0;
  const Eigen::MatrixXd H = dense_hessian(ctx);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H).eigenvalues();
  long negative = 0, positive = 0;
  for (int i = 0; i < ev.size(); ++i) (ev[i] < 0 ? negative : positive) += 1;
  ASSERT_GT(negative, 0);
  ASSERT_GT(positive, 0);
  ASSERT_GT(ev.cwiseAbs().minCoeff(), 1e-6) << "the random matrix is nearly singular";
  const int n = (N - 1) * d;
  const Eigen::VectorXd b = right_hand_side(ctx);
  const Eigen::VectorXd exact = H.fullPivLu().solve(b);

  BlockTridiagonal<D> T;
  T.resize(N, d);
  T.assemble(ctx, 0.0);
  EXPECT_FALSE(T.factor_ldlt());
  T.assemble(ctx, 0.0);
  typename BlockTridiagonal<D>::Inertia in;
  ASSERT_TRUE(T.factor_indefinite(&in));
  EXPECT_EQ(in.negative, negative);
  EXPECT_EQ(in.positive, positive);
  EXPECT_EQ(in.zero, 0);
  Eigen::VectorXd x(n);
  T.solve_ldlt(b.data(), x.data());
  const double cond = ev.cwiseAbs().maxCoeff() / ev.cwiseAbs().minCoeff();
  EXPECT_LT((x - exact).norm(), 1e-13 * cond * exact.norm()) << "condition " << cond;
  // A positive definite factorization afterwards solves with its own pivots again.
  T.assemble(ctx, 10.0 * d);
  ASSERT_TRUE(T.factor_ldlt());
  const Eigen::MatrixXd shifted = dense_hessian(ctx) + 10.0 * d * [&] {
    Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
    for (int k = 1; k < N; ++k)
      for (int i = 0; i < d; ++i)
        if (!ctx.is_free[k * d + i]) I((k - 1) * d + i, (k - 1) * d + i) = 0;
    return I;
  }();
  T.solve_ldlt(b.data(), x.data());
  EXPECT_LT((x - shifted.ldlt().solve(b)).norm(), 1e-10 * x.norm());
}

TEST(BlockTridiagonal, IndefiniteFactorizationSolvesAndCountsTheInertia) {
  for (int N : {3, 8, 25}) {
    check_indefinite<2>(N, 2, 30u + N, false);
    check_indefinite<2>(N, 2, 40u + N, N > 5);
  }
  check_indefinite<1>(40, 1, 5u, false);
  check_indefinite<4>(12, 4, 6u, true);
  check_indefinite<Eigen::Dynamic>(10, 3, 8u, true);
}

TEST(BlockTridiagonal, IndefiniteFactorizationRefusesASingularMatrix) {
  // The 1-D Laplacian shifted by its smallest eigenvalue 2 - 2 cos(pi/N): exactly singular.
  const int N = 20;
  Context ctx = random_context(N, 1, 0.0, 2u);
  const double shift = 1 - std::cos(3.14159265358979323846 / N);
  for (int k = 0; k < N; ++k) {
    ctx.D11[k] = 1.0 - shift;
    ctx.D22[k] = 1.0 - shift;
    ctx.D12[k] = -1.0;
  }
  BlockTridiagonal<1> T;
  T.resize(N, 1);
  T.assemble(ctx, 0.0);
  typename BlockTridiagonal<1>::Inertia in;
  EXPECT_FALSE(T.factor_indefinite(&in));
  EXPECT_EQ(in.zero, 1);
  EXPECT_EQ(in.positive, N - 2);
}

}  // namespace

/** The inertia of H against a dense eigendecomposition of it (eigenvalues within 1e-9 of its
 *  largest count as zero: those of the matrices below are 0 or at least 0.3 of it). */
template <int D>
void expect_dense_inertia(const Context& ctx) {
  const Eigen::MatrixXd H = dense_hessian(ctx);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(H).eigenvalues();
  const double zero = 1e-9 * ev.cwiseAbs().maxCoeff();
  long positive = 0, negative = 0, zeros = 0;
  for (Eigen::Index i = 0; i < ev.size(); ++i) (ev(i) > zero ? positive : ev(i) < -zero ? negative : zeros)++;
  BlockTridiagonal<D> T;
  T.resize(ctx.N, ctx.dim);
  T.assemble(ctx, 0.0);
  const auto in = T.inertia();
  EXPECT_EQ(in.positive, positive) << "N = " << ctx.N << ", d = " << ctx.dim;
  EXPECT_EQ(in.negative, negative) << "N = " << ctx.N << ", d = " << ctx.dim;
  EXPECT_EQ(in.zero, zeros) << "N = " << ctx.N << ", d = " << ctx.dim;
}

TEST(BlockTridiagonal, ZeroPivotsOfARegularMatrixAreNotZeroEigenvalues) {
  // Every diagonal entry zero (the midpoint rule of x'' = -w^2 x at h w = 2): the elimination's
  // pivots are 0, yet H = 3 tridiag(-1, 0, -1) has the eigenvalues -6 cos(k pi / N), zero only
  // for N even (k = N/2). Its inertia counted pivot by pivot was every eigenvalue zero.
  for (int N : {3, 4, 5, 6, 9, 10, 33}) {
    Context ctx = random_context(N, 1, 0.0, 3u);
    for (int k = 0; k < N; ++k) {
      ctx.D11[k] = 0.0;
      ctx.D22[k] = 0.0;
      ctx.D12[k] = -3.0;
    }
    expect_dense_inertia<1>(ctx);
    expect_dense_inertia<Eigen::Dynamic>(ctx);
  }
  // Two coordinates, one of them with zero diagonal blocks and coupled to the other.
  for (int N : {4, 7}) {
    Context ctx = random_context(N, 2, 0.0, 4u);
    for (int k = 0; k < N; ++k) {
      double* A = ctx.D11.data() + 4 * k;
      double* B = ctx.D22.data() + 4 * k;
      double* C = ctx.D12.data() + 4 * k;
      A[0] = 0, A[1] = 0.5, A[2] = 0.5, A[3] = 2;
      B[0] = 0, B[1] = 0, B[2] = 0, B[3] = 2;
      C[0] = -3, C[1] = 0, C[2] = 0, C[3] = -1;
    }
    expect_dense_inertia<2>(ctx);
  }
}
