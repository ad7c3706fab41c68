/**
 * @file extended_node_system.hpp
 * Internal: the node system of one process in extended precision — the DEL residual and the
 * block-tridiagonal Hessian from the discretization's full_extended kernel, factored by block
 * elimination. Iterative refinement corrects with it where the double Hessian is too
 * ill-conditioned (iterative_refinement.cpp); the point assessment counts its inertia and finds its
 * smallest eigenvalues with it where the double one cannot tell them (extended_assessment.cpp).
 * Every source that includes it is compiled with the same PARDEL_EXTENDED_FLOAT128 setting
 * (runtime/CMakeLists.txt).
 */
#ifndef PARDEL_RUNTIME_EXTENDED_NODE_SYSTEM_HPP
#define PARDEL_RUNTIME_EXTENDED_NODE_SYSTEM_HPP

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#if defined(PARDEL_EXTENDED_FLOAT128)
#include <boost/multiprecision/eigen.hpp>
#include <boost/multiprecision/float128.hpp>
#endif
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "engine.hpp"
#include "inertia.hpp"

namespace pardel::detail {

#if defined(PARDEL_EXTENDED_FLOAT128)
using Extended = boost::multiprecision::float128;  // 113-bit significand: a double-double pair exactly
#else
using Extended = long double;
#endif
using XMat = Eigen::Matrix<Extended, Eigen::Dynamic, Eigen::Dynamic>;
using XVec = Eigen::Matrix<Extended, Eigen::Dynamic, 1>;

/**
 * The node system at q in extended precision: the DEL residual and the block-tridiagonal Hessian
 * from the discretization's full_extended kernel (each entry a double-double pair, read exactly),
 * factored by block elimination with Eigen's partial-pivoting LU of each pivot block. The Hessian
 * of an order-gamma model has a condition number of about N^(2 gamma); rounded to double it gives
 * corrections of the wrong size once that passes 1/eps, in extended precision not before about
 * 1/eps_extended. Fixed components are identity rows, as in BlockTridiagonal::assemble.
 */
class ExtendedNodeSystem {
 public:
  /** Evaluates residual and Hessian at q; false if a value is not finite. */
  bool evaluate(const Context& ctx, const std::vector<double>& q) {
    const int d = ctx.dim, N = ctx.N, n = N - 1;
    const std::size_t dz = static_cast<std::size_t>(d), dd = dz * dz;
    const std::size_t stride = 2 + 4 * dz + 6 * dd;  // pairs: Ld, D1, D2, D11, D12, D22
    pairs_.resize(static_cast<std::size_t>(N) * stride);
    const pardel_extended_full_kernel kern = ctx.disc->full_extended;
    const double* p = ctx.p();
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static)
    for (int k = 0; k < N; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      double* out = pairs_.data() + kk * stride;
      double* D1 = out + 2;
      kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q.data() + kk * dz, q.data() + (kk + 1) * dz, p, out, D1,
           D1 + 2 * dz, D1 + 4 * dz, D1 + 4 * dz + 2 * dd, D1 + 4 * dz + 4 * dd);
    }
    for (double v : pairs_)
      if (!std::isfinite(v)) return false;
    // Entry e of the pair array that starts at `at` in interval k.
    auto entry = [&](int k, std::size_t at, std::size_t e) {
      const double* v = pairs_.data() + static_cast<std::size_t>(k) * stride + at + 2 * e;
      return Extended(v[0]) + Extended(v[1]);
    };
    const std::size_t D1 = 2, D2 = 2 + 2 * dz, D11 = 2 + 4 * dz, D12 = D11 + 2 * dd, D22 = D12 + 2 * dd;
    diag_.assign(static_cast<std::size_t>(n), XMat::Zero(d, d));
    off_.assign(static_cast<std::size_t>(n), XMat::Zero(d, d));
    rhs_.assign(static_cast<std::size_t>(n), XVec::Zero(d));
    residual_ = 0;
    for (int i = 0; i < n; ++i) {
      const int k = i + 1;
      const std::size_t ii = static_cast<std::size_t>(i);
      const unsigned char* f = ctx.is_free.data() + static_cast<std::size_t>(k) * dz;
      const unsigned char* fn = ctx.is_free.data() + static_cast<std::size_t>(k + 1) * dz;
      for (int a = 0; a < d; ++a) {
        const std::size_t az = static_cast<std::size_t>(a);
        if (f[a]) {
          rhs_[ii](a) = -(entry(k - 1, D2, az) + entry(k, D1, az));
          residual_ = std::max(residual_, std::fabs(static_cast<double>(rhs_[ii](a))));
        }
        for (int b = 0; b < d; ++b) {
          const std::size_t ab = az * dz + static_cast<std::size_t>(b);
          diag_[ii](a, b) = f[a] && f[b] ? entry(k - 1, D22, ab) + entry(k, D11, ab) : Extended(a == b ? 1 : 0);
          if (k < N - 1 && f[a] && fn[b]) off_[ii](a, b) = entry(k, D12, ab);
        }
      }
    }
    return true;
  }

  /** Block elimination; false if a pivot block is singular in extended precision. With `inertia`,
   *  also the inertia of the Hessian, the sum of its pivots' (Haynsworth), each pivot's counted
   *  under the zero rule of inertia.hpp (zero_threshold below). */
  bool factor(Inertia* inertia = nullptr) {
    const std::size_t n = diag_.size();
    lu_.resize(n);
    gain_.resize(n);
    Inertia in;
    const long double tiny = inertia ? zero_threshold() : 0.0L;
    for (std::size_t i = 0; i < n; ++i) {
      XMat W = diag_[i];
      if (i > 0) W -= off_[i - 1].transpose() * gain_[i - 1];
      if (inertia && !count_pivot(i, W, tiny, in)) return false;
      lu_[i].compute(W);
      if (!(lu_[i].matrixLU().diagonal().cwiseAbs().minCoeff() > 0)) return false;
      gain_[i] = lu_[i].solve(off_[i]);
    }
    if (inertia) *inertia = in;
    return true;
  }

  /** The largest free component of the DEL residual at the evaluated q, rounded to double. */
  double residual_norm() const { return residual_; }

  /** Gershgorin's bound of the Hessian (its largest absolute row sum), rounded to double. */
  double gershgorin_bound() const {
    Extended bound = 0;
    for (std::size_t i = 0; i < diag_.size(); ++i)
      for (Eigen::Index a = 0; a < diag_[i].rows(); ++a) {
        Extended row = diag_[i].row(a).cwiseAbs().sum();
        if (i + 1 < diag_.size()) row += off_[i].row(a).cwiseAbs().sum();
        if (i > 0) row += off_[i - 1].col(a).cwiseAbs().sum();
        bound = std::max(bound, row);
      }
    return static_cast<double>(bound);
  }

  /** The correction -H^-1 r (node layout 1..N-1, rounded to double) into delta. */
  void solve(std::vector<double>& delta) const {
    const std::size_t d = diag_.empty() ? 0 : static_cast<std::size_t>(diag_[0].rows());
    substitute([this](std::size_t i) { return rhs_[i]; }, delta.data() + d);
  }

  /** x = H^-1 b over the free unknowns' layout (nodes 1..N-1, d each; b read as doubles, x
   *  rounded to double): the operator whose largest eigenvalues the Lanczos iteration finds. */
  void solve(const double* b, double* x) const {
    const Eigen::Index d = diag_.empty() ? 0 : diag_[0].rows();
    substitute(
        [b, d](std::size_t i) {
          XVec v(d);
          for (Eigen::Index a = 0; a < d; ++a) v(a) = Extended(b[i * static_cast<std::size_t>(d) + a]);
          return v;
        },
        x);
  }

 private:
  /** Forward and back substitution through the factors with the right-hand side rhs(i) of pivot
   *  i, the solution rounded into out (n d doubles). */
  template <class Rhs>
  void substitute(Rhs&& rhs, double* out) const {
    const std::size_t n = diag_.size();
    std::vector<XVec> y(n);
    for (std::size_t i = 0; i < n; ++i) {
      XVec b = rhs(i);
      if (i > 0) b -= off_[i - 1].transpose() * y[i - 1];
      y[i] = lu_[i].solve(b);
    }
    for (std::size_t i = n; i-- > 0;) {
      if (i + 1 < n) y[i] -= gain_[i] * y[i + 1];
      for (Eigen::Index a = 0; a < y[i].size(); ++a)
        out[i * static_cast<std::size_t>(y[i].size()) + static_cast<std::size_t>(a)] = static_cast<double>(y[i](a));
    }
  }

  /** The zero rule's threshold (inertia.hpp) for the pivots' eigenvalues, which are counted in
   *  long double (Eigen's eigensolver does not take Boost's float128): kZeroPivot, about 4500 unit
   *  roundoffs of double, scaled to as many of long double, times the largest of 1 and Gershgorin's
   *  bound of the Jacobi-scaled Hessian. Sets scaling_. */
  long double zero_threshold() {
    using std::abs;
    using std::sqrt;
    const std::size_t n = diag_.size();
    scaling_.assign(n, XVec());
    for (std::size_t i = 0; i < n; ++i) {
      scaling_[i].resize(diag_[i].rows());
      for (Eigen::Index a = 0; a < diag_[i].rows(); ++a) {
        const Extended h = abs(diag_[i](a, a));
        scaling_[i](a) = h > 0 ? Extended(1) / sqrt(h) : Extended(1);
      }
    }
    Extended bound = 0;
    for (std::size_t i = 0; i < n; ++i)
      for (Eigen::Index a = 0; a < diag_[i].rows(); ++a) {
        Extended row = 0;
        for (Eigen::Index b = 0; b < diag_[i].cols(); ++b) {
          row += abs(diag_[i](a, b)) * scaling_[i](b);
          if (i + 1 < n) row += abs(off_[i](a, b)) * scaling_[i + 1](b);
          if (i > 0) row += abs(off_[i - 1](b, a)) * scaling_[i - 1](b);
        }
        bound = std::max(bound, row * scaling_[i](a));
      }
    const long double ratio =
        std::numeric_limits<long double>::epsilon() / static_cast<long double>(std::numeric_limits<double>::epsilon());
    return static_cast<long double>(kZeroPivot) * ratio * std::max(1.0L, static_cast<long double>(bound));
  }

  /** Counts the eigenvalues of pivot i's Jacobi-scaled symmetric part (formed in extended
   *  precision, its entries then rounded to long double) into `in`; false where the
   *  eigendecomposition fails or a value is not finite. */
  bool count_pivot(std::size_t i, const XMat& W, long double tiny, Inertia& in) const {
    using LMat = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
    const Eigen::Index d = W.rows();
    LMat S(d, d);
    for (Eigen::Index a = 0; a < d; ++a)
      for (Eigen::Index b = 0; b < d; ++b)
        S(a, b) = static_cast<long double>((W(a, b) + W(b, a)) / 2 * scaling_[i](a) * scaling_[i](b));
    if (!S.allFinite()) return false;
    Eigen::SelfAdjointEigenSolver<LMat> eig(S, Eigen::EigenvaluesOnly);
    if (eig.info() != Eigen::Success) return false;
    for (Eigen::Index a = 0; a < d; ++a) {
      const long double v = eig.eigenvalues()(a);
      if (v > tiny)
        ++in.positive;
      else if (v < -tiny)
        ++in.negative;
      else
        ++in.zero;
    }
    return true;
  }

  std::vector<double> pairs_;
  std::vector<XMat> diag_, off_, gain_;  // gain_[i] = W_i^-1 off_[i]
  std::vector<XVec> rhs_;  // -r
  std::vector<XVec> scaling_;  // the Jacobi scaling of each node's diagonal block
  std::vector<Eigen::PartialPivLU<XMat>> lu_;
  double residual_ = 0;
};

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_EXTENDED_NODE_SYSTEM_HPP
