/**
 * @file test_cyclic_reduction.cpp
 * The single-source block cyclic reduction (runtime/src/cyclic_reduction.hpp), through its host
 * path: solutions against Eigen's dense Cholesky solve on random symmetric positive definite
 * block-tridiagonal systems of every row count from 1 to 40 and larger ones, for fixed and
 * run-time block sizes; the same bits for one and two threads; positive definiteness decided as a
 * dense Cholesky factorization decides it, across the smallest eigenvalue; and the storage's
 * levels laid end to end within values().
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "cyclic_reduction.hpp"

namespace {

namespace cr = pardel::cyclic_reduction;

/** A random symmetric block-tridiagonal system: n diagonal blocks of d x d (row-major), n - 1
 *  couplings, with `boost` times the identity added to the diagonal. */
struct System {
  int n = 0, d = 0;
  std::vector<double> S, U, b;
  Eigen::MatrixXd dense() const {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n * d, n * d);
    for (int i = 0; i < n; ++i)
      for (int a = 0; a < d; ++a)
        for (int c = 0; c < d; ++c) {
          H(i * d + a, i * d + c) = S[(i * d + a) * d + c];
          if (i + 1 < n) {
            H(i * d + a, (i + 1) * d + c) = U[(i * d + a) * d + c];
            H((i + 1) * d + c, i * d + a) = U[(i * d + a) * d + c];
          }
        }
    return H;
  }
};

System random_system(int n, int d, double boost, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  System s;
  s.n = n;
  s.d = d;
  s.S.assign(static_cast<std::size_t>(n * d * d), 0);
  s.U.assign(static_cast<std::size_t>(n * d * d), 0);
  s.b.resize(static_cast<std::size_t>(n * d));
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < d; ++a)
      for (int c = 0; c <= a; ++c) {
        const double v = u(rng);
        s.S[(i * d + a) * d + c] = v;
        s.S[(i * d + c) * d + a] = v;
      }
    for (int a = 0; a < d; ++a) s.S[(i * d + a) * d + a] += boost;
    if (i + 1 < n)
      for (int k = 0; k < d * d; ++k) s.U[i * d * d + k] = u(rng);
  }
  for (double& v : s.b) v = u(rng);
  return s;
}

/** Level 0 of the storage filled from `s`; cyclic reduction over it; x of level 0. */
template <int D>
bool solve(const System& s, int threads, std::vector<double>& x) {
  std::vector<double> store(static_cast<std::size_t>(cr::values(s.n, s.d)), 0.0);
  const cr::Level L0 = cr::level(store.data(), s.n, s.d, 0);
  std::copy(s.S.begin(), s.S.end(), L0.S);
  std::copy(s.U.begin(), s.U.end(), L0.U);
  std::copy(s.b.begin(), s.b.end(), L0.b);
  const bool ok = cr::solve_on_host<D>(store.data(), s.n, s.d, threads, 1);
  x.assign(L0.x, L0.x + s.n * s.d);
  return ok;
}

template <int D>
void check_against_dense(int n, int d, unsigned seed) {
  const System s = random_system(n, d, 3.0 * d, seed);
  const Eigen::MatrixXd H = s.dense();
  const Eigen::LLT<Eigen::MatrixXd> llt(H);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const Eigen::VectorXd exact = llt.solve(Eigen::Map<const Eigen::VectorXd>(s.b.data(), n * d));
  std::vector<double> x;
  ASSERT_TRUE(solve<D>(s, 1, x)) << "n = " << n << ", d = " << d;
  const Eigen::VectorXd got = Eigen::Map<const Eigen::VectorXd>(x.data(), n * d);
  EXPECT_LT((got - exact).norm(), 1e-12 * exact.norm()) << "n = " << n << ", d = " << d;
}

TEST(CyclicReduction, MatchesADenseSolveForEveryRowCount) {
  for (int n = 1; n <= 40; ++n) {
    check_against_dense<1>(n, 1, 100u + n);
    check_against_dense<2>(n, 2, 200u + n);
    check_against_dense<-1>(n, 3, 300u + n);  // a size known at run time only
    check_against_dense<4>(n, 4, 400u + n);
  }
  check_against_dense<2>(1023, 2, 7u);
  check_against_dense<2>(1024, 2, 8u);
  check_against_dense<-1>(777, 5, 9u);
}

TEST(CyclicReduction, TheSameBitsForAnyThreadCount) {
  const System s = random_system(5001, 2, 6.0, 11u);
  std::vector<double> one, two;
  ASSERT_TRUE(solve<2>(s, 1, one));
  ASSERT_TRUE(solve<2>(s, 2, two));
  EXPECT_EQ(one, two);
}

TEST(CyclicReduction, DecidesPositiveDefinitenessAsADenseCholesky) {
  // Shifts of one random system around its smallest eigenvalue: the reduction succeeds exactly
  // where the dense Cholesky factorization does, away from the eigenvalue's round-off.
  for (int d : {1, 2, 3}) {
    for (int n : {1, 2, 5, 16, 37}) {
      const System base = random_system(n, d, 0.0, 500u + 10u * n + d);
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(base.dense());
      const double lambda_min = eig.eigenvalues().minCoeff();
      for (double margin : {-1e-3, -0.3, 1e-3, 0.3}) {
        System s = base;
        const double shift = -lambda_min + margin;
        for (int i = 0; i < n; ++i)
          for (int a = 0; a < d; ++a) s.S[(i * d + a) * d + a] += shift;
        std::vector<double> x;
        const bool ok = d == 1 ? solve<1>(s, 1, x) : d == 2 ? solve<2>(s, 1, x) : solve<-1>(s, 1, x);
        EXPECT_EQ(ok, margin > 0) << "d = " << d << ", n = " << n << ", margin " << margin;
        EXPECT_EQ(ok, Eigen::LLT<Eigen::MatrixXd>(s.dense()).info() == Eigen::Success);
      }
    }
  }
}

TEST(CyclicReduction, LevelsLieEndToEndInTheStorage) {
  for (long n : {1L, 2L, 3L, 8L, 9L, 1000L}) {
    for (int d : {1, 2, 6}) {
      std::vector<double> store(static_cast<std::size_t>(cr::values(n, d)));
      const int levels = cr::level_count(n);
      double* expected = store.data();
      long rows = n;
      for (int l = 0; l < levels; ++l) {
        const cr::Level L = cr::level(store.data(), n, d, l);
        EXPECT_EQ(L.n, rows);
        EXPECT_EQ(L.S, expected);
        EXPECT_EQ(L.x + L.n * d, expected + L.n * (3L * d * d + 2L * d));
        expected += L.n * (3L * d * d + 2L * d);
        rows /= 2;
      }
      EXPECT_EQ(cr::level(store.data(), n, d, levels - 1).n, 1);
      EXPECT_EQ(expected, store.data() + store.size());
    }
  }
}

}  // namespace
