/**
 * @file block_tridiagonal.hpp
 * The Hessian of the discrete action over the unknown nodes 1..N-1 (seed eq. blocktridiagonal):
 * diagonal blocks D_k = D22(k-1) + D11(k) (+ mu I), off-diagonal blocks C_k = D12(k), restricted
 * to free components (a fixed component gets an identity row and column and a zero right-hand
 * side). Two factorizations, templated on the block size D (Eigen::Dynamic for other sizes):
 *  - block LDL^T (block Thomas), O(N) sequential; pivots S_k = D_k - C_{k-1}^T S_{k-1}^{-1} C_{k-1}
 *    are Cholesky-factored, so success certifies positive definiteness (Sylvester's law);
 *  - block cyclic reduction, O(N) work in O(log N) parallel levels; its pivots are those of an
 *    odd-even permutation of H, so success certifies positive definiteness just the same;
 *  - for an indefinite H, the same block elimination with each pivot that is not clearly
 *    positive definite inverted through its symmetric eigendecomposition (inertia(),
 *    factor_indefinite()), under the zero rule of inertia.hpp, which every inertia count shares.
 * All storage is allocated by resize(), reserve_cyclic_reduction() and the first
 * factor_indefinite() at a size; factorizations and solves do not allocate otherwise.
 */
#ifndef PARDEL_RUNTIME_BLOCK_TRIDIAGONAL_HPP
#define PARDEL_RUNTIME_BLOCK_TRIDIAGONAL_HPP

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "constants.hpp"
#include "cyclic_reduction.hpp"
#include "engine.hpp"
#include "inertia.hpp"

namespace pardel::detail {

template <int D>
class BlockTridiagonal {
 public:
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  using RowMap = Eigen::Map<const Eigen::Matrix<double, D, D, (D == 1 ? Eigen::ColMajor : Eigen::RowMajor)>>;
  using VecMap = Eigen::Map<const Vec>;

  /** Allocates for n = N-1 unknown blocks of size d, in storage for at least `capacity` blocks
   *  (a later resize up to it reuses the storage). The cyclic-reduction levels are allocated by
   *  reserve_cyclic_reduction(), or on the first solve_cyclic_reduction(). */
  void resize(int N, int d, std::size_t capacity = 0) {
    d_ = d;
    n_ = N - 1;
    const std::size_t n = static_cast<std::size_t>(std::max(n_, 0));
    assign_within(diag_, n, capacity, Mat::Zero(d, d));
    assign_within(off_, n, capacity, Mat::Zero(d, d));
    assign_within(W_, n, capacity, Mat::Zero(d, d));
    if (D == Eigen::Dynamic) {
      emplace_factorizations(llt_, n, d);
      factor_.clear();
    } else {
      llt_.clear();
      assign_within(factor_, n, capacity, Mat::Zero(d, d));
    }
    cyclic_.clear();
  }

  /** Allocates the levels of block cyclic reduction for the current size (cyclic_reduction.hpp's
   *  storage, about 2 n (3 d^2 + 2 d) doubles). */
  void reserve_cyclic_reduction() {
    if (n_ < 1) return;
    const std::size_t values = static_cast<std::size_t>(cyclic_reduction::values(n_, d_));
    if (cyclic_.size() != values) cyclic_.assign(values, 0.0);
  }

  int blocks() const { return n_; }
  Mat& diag(int i) { return diag_[static_cast<std::size_t>(i)]; }
  Mat& off(int i) { return off_[static_cast<std::size_t>(i)]; }
  const Mat& diag(int i) const { return diag_[static_cast<std::size_t>(i)]; }
  const Mat& off(int i) const { return off_[static_cast<std::size_t>(i)]; }

  /**
   * Fills the blocks from the full-kernel arrays of ctx, shifted on free components by mu I, or with
   * `difference` by mu K, K = tridiag(-1, 2, -1) per component (the metric sum_k |dq_{k+1} - dq_k|^2
   * with the fixed ends and fixed components as zeros).
   */
  void assemble(const Context& ctx, double mu, bool difference = false) {
    const std::size_t dd = static_cast<std::size_t>(d_) * d_;
#pragma omp parallel for if (ctx.parallel(n_)) num_threads(ctx.threads) schedule(static)
    for (int i = 0; i < n_; ++i) {
      const std::size_t k = static_cast<std::size_t>(i) + 1;
      node_blocks(ctx.D22.data() + (k - 1) * dd, ctx.D11.data() + k * dd, ctx.D12.data() + k * dd,
                  ctx.is_free.data() + k * d_, i + 2 == ctx.N, mu, difference, d_, &diag_[static_cast<std::size_t>(i)],
                  off_[static_cast<std::size_t>(i)]);
    }
  }

  /**
   * The blocks of one unknown node k (in 1..N-1; `last`: k = N-1) from its derivative arrays:
   * with `Dk`, D_k = D22(k-1) + D11(k) (`D22_prev`, `D11`), and C_k = D12(k) (`D12`; zero at the
   * last node); a fixed component (free[a] = 0, `free` the node's flags followed by the next
   * node's) gets an identity row and column in D_k and a zero row in C_k, a fixed component of the
   * next node a zero column in C_k; the shift mu adds mu I to D_k, or with `difference` the
   * second-difference matrix mu (2 I on D_k, -I on C_k between free components). Every topology
   * assembles its blocks through it (one process: assemble(); ranks: their owned nodes).
   */
  static void node_blocks(const double* D22_prev, const double* D11, const double* D12, const unsigned char* free,
                          bool last, double mu, bool difference, int d, Mat* Dk, Mat& Ck) {
    if (Dk) {
      *Dk = RowMap(D22_prev, d, d);
      *Dk += RowMap(D11, d, d);
    }
    if (!last)
      Ck = RowMap(D12, d, d);
    else
      Ck.setZero();
    const unsigned char* f = free;
    const unsigned char* fn = free + d;
    for (int a = 0; a < d; ++a) {
      if (!f[a]) {
        if (Dk) {
          Dk->row(a).setZero();
          Dk->col(a).setZero();
          (*Dk)(a, a) = 1;
        }
        Ck.row(a).setZero();
      } else if (difference) {
        if (Dk) (*Dk)(a, a) += 2 * mu;
        if (!last && fn[a]) Ck(a, a) -= mu;
      } else if (Dk) {
        (*Dk)(a, a) += mu;
      }
      if (!fn[a]) Ck.col(a).setZero();
    }
  }

  /** Block LDL^T with Cholesky pivots; false (and failed_block() = index) if a pivot is not p.d.
   *  Fixed block sizes use an unrolled in-place Cholesky, other sizes Eigen::LLT. */
  bool factor_ldlt() {
    failed_ = -1;
    indefinite_ = false;
    if constexpr (D == 2) return factor_ldlt_2x2();
    for (int i = 0; i < n_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      if (i == 0) {
        W_[ii] = diag_[ii];
      } else {
        W_[ii].noalias() = diag_[ii] - off_[ii - 1].transpose() * W_[ii - 1];
      }
      if constexpr (D == Eigen::Dynamic) {
        llt_[ii].compute(W_[ii]);
        if (llt_[ii].info() != Eigen::Success || !finite_positive_diag(llt_[ii])) {
          failed_ = i;
          return false;
        }
        W_[ii] = llt_[ii].solve(off_[ii]);  // S_i^{-1} C_i
      } else {
        Mat& L = factor_[ii];
        L = W_[ii];
        if (!cholesky_in_place(L)) {
          failed_ = i;
          return false;
        }
        W_[ii] = off_[ii];
        cholesky_solve_columns(L, W_[ii]);  // S_i^{-1} C_i
      }
    }
    return true;
  }

  /** factor_ldlt() for 2 x 2 blocks, where the recurrence's chain of dependent operations sets the
   *  time: S_i^{-1} C_i by the adjugate, adj(S_i) C_i / det S_i, so that S_{i+1} = D_{i+1} -
   *  C_i^T S_i^{-1} C_i waits for one division per node; each pivot's Cholesky factor (for the
   *  solves and the definiteness rule), whose success decides positive definiteness as for other
   *  sizes, is computed beside that chain. Where the determinant is not a positive finite number
   *  with a finite inverse (over- or underflow) S_i^{-1} C_i comes from the Cholesky factor. */
  bool factor_ldlt_2x2() {
    double w00 = 0, w01 = 0, w10 = 0, w11 = 0;  // S_{i-1}^{-1} C_{i-1}
    for (int i = 0; i < n_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      const Mat& Dk = diag_[ii];
      double s00 = Dk(0, 0), s10 = Dk(1, 0), s11 = Dk(1, 1);
      if (i > 0) {
        const Mat& Cp = off_[ii - 1];
        s00 -= Cp(0, 0) * w00 + Cp(1, 0) * w10;
        s10 -= Cp(0, 1) * w00 + Cp(1, 1) * w10;
        s11 -= Cp(0, 1) * w01 + Cp(1, 1) * w11;
      }
      Mat& L = factor_[ii];
      L << s00, s10, s10, s11;
      if (!cholesky_in_place(L)) {
        failed_ = i;
        return false;
      }
      const Mat& C = off_[ii];
      Mat& W = W_[ii];
      const double det = s00 * s11 - s10 * s10, inv = 1 / det;
      if (det > 0 && std::isfinite(inv) && inv > 0) {
        w00 = (s11 * C(0, 0) - s10 * C(1, 0)) * inv;
        w10 = (s00 * C(1, 0) - s10 * C(0, 0)) * inv;
        w01 = (s11 * C(0, 1) - s10 * C(1, 1)) * inv;
        w11 = (s00 * C(1, 1) - s10 * C(0, 1)) * inv;
        W << w00, w01, w10, w11;
      } else {
        W = C;
        cholesky_solve_columns(L, W);
        w00 = W(0, 0), w01 = W(0, 1), w10 = W(1, 0), w11 = W(1, 1);
      }
    }
    return true;
  }

  /** After factor_ldlt (or factor_indefinite) of H at ctx.q: into delta (the unknowns of nodes
   *  1..N-1), the Newton correction -H^-1 r from ctx's DEL residual r, zero on fixed components. */
  void newton_correction(const Context& ctx, std::vector<double>& delta) {
    const std::size_t dz = static_cast<std::size_t>(d_), n = static_cast<std::size_t>(std::max(n_, 0)) * dz;
    delta.resize(n);
    for (std::size_t i = 0; i < n; ++i) delta[i] = ctx.is_free[dz + i] ? -ctx.res[dz + i] : 0.0;
    solve_ldlt(delta.data(), delta.data());
  }

  /** Solves H x = b after factor_ldlt (or factor_indefinite); b and x in node layout of nodes 1..N-1 (dim each). x may
   *  be b; the forward substitution's intermediate is kept in x. */
  void solve_ldlt(const double* b, double* x) {
    const double* bs[1] = {b};
    double* xs[1] = {x};
    solve_columns<1>(bs, xs);
  }
  /** Two right-hand sides in one pass over the factorization. */
  void solve_ldlt(const double* b0, const double* b1, double* x0, double* x1) {
    const double* bs[2] = {b0, b1};
    double* xs[2] = {x0, x1};
    solve_columns<2>(bs, xs);
  }

  /** Block cyclic reduction (factor and solve together, cyclic_reduction.hpp's host path over
   *  `threads`); false if a pivot is not p.d. */
  bool solve_cyclic_reduction(const double* b, double* x, int threads) {
    failed_ = -1;
    if (n_ <= 0) return true;
    reserve_cyclic_reduction();
    const int d = d_;
    const std::size_t dz = static_cast<std::size_t>(d), dd = dz * dz;
    const cyclic_reduction::Level L0 = cyclic_reduction::level(cyclic_.data(), n_, d, 0);
    for (int i = 0; i < n_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      for (int a = 0; a < d; ++a) {
        for (int c = 0; c < d; ++c) {
          L0.S[ii * dd + static_cast<std::size_t>(a * d + c)] = diag_[ii](a, c);
          L0.U[ii * dd + static_cast<std::size_t>(a * d + c)] = i + 1 < n_ ? off_[ii](a, c) : 0.0;
        }
        L0.b[ii * dz + static_cast<std::size_t>(a)] = b[ii * dz + static_cast<std::size_t>(a)];
      }
    }
    int failed_level = -1;
    if (!cyclic_reduction::solve_on_host<D>(cyclic_.data(), n_, d, threads, kParallelMin, &failed_level)) {
      if (failed_level == cyclic_reduction::level_count(n_) - 1) failed_ = 0;
      return false;
    }
    std::copy(L0.x, L0.x + static_cast<std::size_t>(n_) * dz, x);
    return true;
  }

  /** x^T H x (unshifted blocks as assembled), summed in a fixed order; x in node layout 1..N-1. */
  double quadratic_form(const double* x) const {
    const int d = d_;
    double s = 0;
    for (int i = 0; i < n_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      const VecMap xi(x + ii * d, d);
      s += xi.dot(diag_[ii] * xi);
      if (i + 1 < n_) s += 2 * xi.dot(off_[ii] * VecMap(x + (ii + 1) * d, d));
    }
    return s;
  }

  /** Gershgorin's bound on the largest |eigenvalue| of H as assembled. */
  double gershgorin_bound() const {
    double bound = 0;
    for (int i = 0; i < n_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      bound = std::max(bound, gershgorin_rows(diag_[ii], i + 1 < n_ ? &off_[ii] : nullptr,
                                              i > 0 ? &off_[ii - 1] : nullptr));
    }
    return bound;
  }

  /** The largest absolute row sum over the rows of one block row: its diagonal block, the
   *  coupling to the next block (if any) and the previous block's coupling to it, transposed
   *  (if any). */
  static double gershgorin_rows(const Mat& diag, const Mat* next, const Mat* previous) {
    double bound = 0;
    for (Eigen::Index a = 0; a < diag.rows(); ++a) {
      double row = diag.row(a).cwiseAbs().sum();
      if (next) row += next->row(a).cwiseAbs().sum();
      if (previous) row += previous->col(a).cwiseAbs().sum();
      bound = std::max(bound, row);
    }
    return bound;
  }
  /** The same rows of J H J: J, Jn, Jp the scalings of the block, the next and the previous one. */
  static double gershgorin_rows(const Mat& diag, const Mat* next, const Mat* previous, const double* J,
                                const double* Jn, const double* Jp) {
    double bound = 0;
    const Eigen::Index d = diag.rows();
    for (Eigen::Index a = 0; a < d; ++a) {
      double row = 0;
      for (Eigen::Index b = 0; b < d; ++b) {
        row += std::fabs(diag(a, b)) * J[b];
        if (next) row += std::fabs((*next)(a, b)) * Jn[b];
        if (previous) row += std::fabs((*previous)(b, a)) * Jp[b];
      }
      bound = std::max(bound, row * J[a]);
    }
    return bound;
  }

  using Inertia = detail::Inertia;

  /**
   * The inertia of H as assembled, by block elimination (inertia.hpp: the sum of the inertias of
   * the pivots S_i = D_i - C_{i-1}^T S_{i-1}^+ C_{i-1}, each under the zero rule there, judged in
   * the Jacobi-scaled H~ = J H J). A pivot whose Cholesky factor shows every scaled eigenvalue
   * above the rule's threshold is taken as it is; any other is split by the eigendecomposition of
   * its scaled form, and its eigenvalues that count as zero are left out of the elimination (a
   * pseudo-inverse). Overwrites the LDL^T factorization (factor_ldlt() must be called again).
   * Haynsworth's sum holds for invertible pivots: where a pivot counts as zero, H may still be
   * regular (H = [[0, -3], [-3, 0]] has the pivots 0 and 0 and the eigenvalues 3 and -3), so such
   * a count is decided by the counts of H~ + sigma I and H~ - sigma I, sigma ten times the rule's
   * threshold: an eigenvalue farther than sigma from zero keeps its sign in both, one within it
   * is positive in the first and negative in the second, so the positive count of the second,
   * the negative count of the first and the rest as zero are H's. Where a pivot of either counts
   * as zero too, the first count stands.
   */
  Inertia inertia() {
    const Inertia in = eliminate(false);
    if (in.zero == 0) return in;
    const double sigma = 10 * zero_threshold(jacobi_scaling());
    const std::vector<double> J = scaling_;
    const std::vector<Mat> unshifted = diag_;
    Inertia at[2];
    for (int side = 0; side < 2; ++side) {
      for (int i = 0; i < n_; ++i)
        for (int a = 0; a < d_; ++a) {
          const double j = J[static_cast<std::size_t>(i) * static_cast<std::size_t>(d_) + static_cast<std::size_t>(a)];
          diag_[static_cast<std::size_t>(i)](a, a) += (side == 0 ? sigma : -sigma) / (j * j);
        }
      at[side] = eliminate(false);
      diag_ = unshifted;
    }
    if (at[0].zero != 0 || at[1].zero != 0) return in;
    Inertia decided;
    decided.positive = at[1].positive;
    decided.negative = at[0].negative;
    decided.zero = in.positive + in.negative + in.zero - decided.positive - decided.negative;
    return decided;
  }

  /**
   * Block LDL^T of H as assembled when it may be indefinite: the elimination of inertia(), each
   * pivot's (pseudo-)inverse kept, so that solve_ldlt() solves with it. False where a pivot has an
   * eigenvalue that counts as zero (H singular to working precision) or is not finite. Allocates
   * the inverses on its first call at a size (the stationary-point Newton only).
   */
  bool factor_indefinite(Inertia* inertia_out = nullptr) {
    assign_within(inverse_, static_cast<std::size_t>(std::max(n_, 0)), diag_.capacity(), Mat::Zero(d_, d_));
    const Inertia in = eliminate(true);
    if (inertia_out) *inertia_out = in;
    indefinite_ = in.zero == 0;
    return indefinite_;
  }

  /**
   * After a successful factor_ldlt(): whether its pivots are positive definite under the zero rule
   * as the elimination of inertia() judges them (every pivot's Cholesky factor shows its scaled
   * eigenvalues above the threshold), so that inertia() would count no zero and no negative
   * eigenvalue. False leaves the decision to inertia(). Reads the factorization; changes nothing.
   * Where `gershgorin` is given and the answer is true: gershgorin_bound() into it (the same pass).
   */
  bool ldlt_definite_by_rule(double* gershgorin = nullptr) const {
    // One pass: each pivot's bound 1 / ||(J L)^-1||_F^2 from below on its scaled eigenvalues (the
    // least of them kept), Gershgorin's bound of J H J that sets the rule's threshold, and that
    // of H (J block by block from the diagonal: no array of n d, which costs its page faults).
    double scaled = 0, unscaled = 0, worst = 0;  // worst: the largest ||(J L)^-1||_F^2
    const bool finite = scaled_blocks([&](std::size_t i, const double* J, const double* Jn, const double* Jp) {
      const Mat* next = i + 1 < static_cast<std::size_t>(n_) ? &off_[i] : nullptr;
      const Mat* previous = i > 0 ? &off_[i - 1] : nullptr;
      scaled = std::max(scaled, gershgorin_rows(diag_[i], next, previous, J, Jn, Jp));
      if (gershgorin) unscaled = std::max(unscaled, gershgorin_rows(diag_[i], next, previous));
      const double f = pivot_scaled_inverse_norm2(i, J);
      worst = std::max(worst, f);
      return std::isfinite(f);
    });
    if (!finite) return false;
    if (gershgorin) *gershgorin = unscaled;
    return worst * zero_threshold(scaled) < 1;
  }

  int failed_block() const { return failed_; }
  /** Cholesky factorization of pivot i after a successful factor_ldlt(). */
  const Eigen::LLT<Mat>& pivot(int i) const {
    if constexpr (D == Eigen::Dynamic) {
      return llt_[static_cast<std::size_t>(i)];
    } else {
      Mat L = factor_[static_cast<std::size_t>(i)].template triangularView<Eigen::Lower>();
      for (int a = 0; a < D; ++a) L(a, a) = 1 / L(a, a);
      pivot_scratch_.compute(L * L.transpose());
      return pivot_scratch_;
    }
  }

  /** Whether every entry of the assembled blocks is finite (the second derivatives at the fixed
   *  ends and components do not enter them). */
  bool all_finite() const {
    for (const std::vector<Mat>* blocks : {&diag_, &off_})
      for (const Mat& m : *blocks)
        if (!m.allFinite()) return false;
    return true;
  }

  /** The largest |diagonal entry| of the unshifted Hessian as assemble(ctx, 0) builds it (1 on fixed
   *  components), straight from the interval arrays. */
  static double max_abs_diagonal(const Context& ctx) {
    const int d = ctx.dim;
    const std::size_t dz = static_cast<std::size_t>(d), dd = dz * dz;
    double m = 0;
    for (int k = 1; k < ctx.N; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      const unsigned char* f = ctx.is_free.data() + kk * dz;
      for (int a = 0; a < d; ++a) {
        const std::size_t aa = static_cast<std::size_t>(a) * (dz + 1);
        m = std::max(m, f[a] ? std::fabs(ctx.D22[(kk - 1) * dd + aa] + ctx.D11[kk * dd + aa]) : 1.0);
      }
    }
    return m;
  }

 private:
  /** The elimination of inertia(); with `keep`, each pivot's (pseudo-)inverse in inverse_. */
  Inertia eliminate(bool keep) {
    Inertia in;
    indefinite_ = false;
    const double tiny = zero_threshold(jacobi_scaling());
    Mat P = Mat::Zero(d_, d_);
    for (int i = 0; i < n_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      Mat S = diag_[ii];
      if (i > 0) S.noalias() -= off_[ii - 1].transpose() * W_[ii - 1];
      const double* J = scaling_.data() + ii * static_cast<std::size_t>(d_);
      if constexpr (D != Eigen::Dynamic) {
        Mat& L = factor_[ii];
        L = S;
        if (cholesky_in_place(L) && pivot_scaled_inverse_norm2(ii, J) * tiny < 1) {
          in.positive += d_;
          W_[ii] = off_[ii];
          cholesky_solve_columns(L, W_[ii]);
          if (keep) {
            inverse_[ii].setIdentity(d_, d_);
            cholesky_solve_columns(L, inverse_[ii]);
          }
          continue;
        }
      } else {
        Eigen::LLT<Mat>& llt = llt_[ii];
        llt.compute(S);
        if (llt.info() == Eigen::Success && finite_positive_diag(llt) && pivot_scaled_inverse_norm2(ii, J) * tiny < 1) {
          in.positive += d_;
          W_[ii] = llt.solve(off_[ii]);
          if (keep) inverse_[ii] = llt.solve(Mat::Identity(d_, d_));
          continue;
        }
      }
      split_pivot(S, J, tiny, in, P);
      W_[ii].noalias() = P * off_[ii];
      if (keep) inverse_[ii] = P;
    }
    return in;
  }

  /** Fills scaling_ with J = |H_aa|^{-1/2} per row (1 where the diagonal entry is zero or not
   *  finite) and returns Gershgorin's bound of J H J. */
  double jacobi_scaling() {
    const std::size_t d = static_cast<std::size_t>(d_), n = static_cast<std::size_t>(std::max(n_, 0));
    assign_within(scaling_, n * d, diag_.capacity() * d, 1.0);
    for (std::size_t i = 0; i < n; ++i) block_scaling(i, scaling_.data() + i * d);
    return scaled_gershgorin_bound();
  }
  /** ||(J L)^-1||_F^2 of pivot i's Cholesky factor L (factor_ldlt's or eliminate's) and J its
   *  block's scaling (inertia.hpp's scaled_inverse_norm2: the pivot's scaled eigenvalues are at
   *  least its inverse; not finite where L is not). For the fixed sizes from the stored factor,
   *  whose diagonal holds 1 / L_aa, by products only: (J L)^-1 = L^-1 J^-1, whose column a is
   *  L^-1's over J_a. */
  double pivot_scaled_inverse_norm2(std::size_t i, const double* J) const {
    if constexpr (D == Eigen::Dynamic) {
      return scaled_inverse_norm2(Mat(llt_[i].matrixL()), J);
    } else {
      const Mat& F = factor_[i];  // strictly lower: L; diagonal: 1 / L_aa
      double f = 0;
      for (int c = 0; c < D; ++c) {
        double x[D];
        x[c] = F(c, c);
        double column = x[c] * x[c];
        for (int r = c + 1; r < D; ++r) {
          double t = 0;
          for (int k = c; k < r; ++k) t += F(r, k) * x[k];
          x[r] = -t * F(r, r);
          column += x[r] * x[r];
        }
        f += column / (J[c] * J[c]);
      }
      return f;
    }
  }
  /** J of block i's rows: |H_aa|^{-1/2} (jacobi_scale). */
  void block_scaling(std::size_t i, double* J) const {
    for (int a = 0; a < d_; ++a) J[a] = jacobi_scale(diag_[i](a, a));
  }
  /** visit(i, J, Jn, Jp) for each block i in order, with the scalings of block i, i + 1 and i - 1
   *  (J block by block from the diagonal, no array: Jn and Jp are unused at the ends), until a
   *  visit returns false; whether none did. */
  template <class Visit>
  bool scaled_blocks(Visit&& visit) const {
    const std::size_t n = static_cast<std::size_t>(std::max(n_, 0));
    Vec Jp = Vec::Ones(d_), J = Jp, Jn = Jp;  // blocks i - 1, i, i + 1
    if (n > 0) block_scaling(0, J.data());
    for (std::size_t i = 0; i < n; ++i) {
      if (i + 1 < n) block_scaling(i + 1, Jn.data());
      if (!visit(i, J.data(), Jn.data(), Jp.data())) return false;
      Jp.swap(J);
      J.swap(Jn);
    }
    return true;
  }
  /** Gershgorin's bound of J H J (J block by block from the diagonal, in one pass). */
  double scaled_gershgorin_bound() const {
    double bound = 0;
    scaled_blocks([&](std::size_t i, const double* J, const double* Jn, const double* Jp) {
      bound = std::max(bound, gershgorin_rows(diag_[i], i + 1 < static_cast<std::size_t>(n_) ? &off_[i] : nullptr,
                                              i > 0 ? &off_[i - 1] : nullptr, J, Jn, Jp));
      return true;
    });
    return bound;
  }

  /** n factorizations of size d, each constructed in place: a copy of an Eigen::LLT built with
   *  LLT(Index) would read its uninitialized status (undefined behaviour, reported by UBSan). */
  static void emplace_factorizations(std::vector<Eigen::LLT<Mat>>& v, std::size_t n, int d) {
    v.clear();
    v.reserve(n);
    for (std::size_t i = 0; i < n; ++i) v.emplace_back(d);
  }

  /** Block forward and back substitution for C columns at once (one read of the factorization). */
  template <int C>
  void solve_columns(const double* const (&b)[C], double* const (&x)[C]) {
    const int d = d_;
    using VecMapMut = Eigen::Map<Vec>;
    for (int i = 0; i < n_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      for (int c = 0; c < C; ++c) {
        VecMapMut yi(x[c] + ii * d, d);
        if (b[c] != x[c]) yi = VecMap(b[c] + ii * d, d);
        if (i > 0) yi.noalias() -= W_[ii - 1].transpose() * VecMap(x[c] + (ii - 1) * d, d);
      }
    }
    for (int i = n_ - 1; i >= 0; --i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      for (int c = 0; c < C; ++c) {
        VecMapMut xi(x[c] + ii * d, d);
        if (indefinite_)
          xi = inverse_[ii] * xi;  // a temporary: Eigen evaluates the product before assigning
        else if constexpr (D == Eigen::Dynamic)
          llt_[ii].solveInPlace(xi);
        else
          cholesky_solve(factor_[ii], xi.data());
        if (i < n_ - 1) xi.noalias() -= W_[ii] * VecMap(x[c] + (ii + 1) * d, d);
      }
    }
  }

  /** In-place Cholesky A = L L^T of a fixed-size block: the strict lower triangle of A becomes that
   *  of L and the diagonal holds 1 / L(j, j) (the solves multiply by it); false unless every pivot
   *  is positive and finite. */
  static bool cholesky_in_place(Mat& A) {
    for (int j = 0; j < D; ++j) {
      double s = A(j, j);
      for (int k = 0; k < j; ++k) s -= A(j, k) * A(j, k);
      if (!(s > 0) || !std::isfinite(s)) return false;
      const double inv = 1 / std::sqrt(s);
      A(j, j) = inv;
      for (int i = j + 1; i < D; ++i) {
        double t = A(i, j);
        for (int k = 0; k < j; ++k) t -= A(i, k) * A(j, k);
        A(i, j) = t * inv;
      }
    }
    return true;
  }
  /** x <- (L L^T)^{-1} x for the factor of cholesky_in_place (inverse diagonal). */
  static void cholesky_solve(const Mat& L, double* x) {
    for (int i = 0; i < D; ++i) {
      double t = x[i];
      for (int k = 0; k < i; ++k) t -= L(i, k) * x[k];
      x[i] = t * L(i, i);
    }
    for (int i = D - 1; i >= 0; --i) {
      double t = x[i];
      for (int k = i + 1; k < D; ++k) t -= L(k, i) * x[k];
      x[i] = t * L(i, i);
    }
  }
  /** B <- (L L^T)^{-1} B, column by column. */
  static void cholesky_solve_columns(const Mat& L, Mat& B) {
    for (int c = 0; c < D; ++c) {
      Vec col = B.col(c);
      cholesky_solve(L, col.data());
      B.col(c) = col;
    }
  }

  static bool finite_positive_diag(const Eigen::LLT<Mat>& llt) {
    const auto& L = llt.matrixLLT();
    for (int a = 0; a < L.rows(); ++a)
      if (!(L(a, a) > 0) || !std::isfinite(L(a, a))) return false;
    return true;
  }

  int n_ = 0, d_ = 0, failed_ = -1;
  std::vector<Mat> diag_, off_, W_;
  std::vector<Eigen::LLT<Mat>> llt_;  ///< pivots' factorizations (dynamic block size)
  std::vector<Mat> factor_;           ///< pivots' Cholesky factors (fixed block sizes)
  std::vector<Mat> inverse_;          ///< pivots' (pseudo-)inverses after factor_indefinite()
  std::vector<double> scaling_;       ///< the inertia's Jacobi scaling |H_aa|^{-1/2}, n*d
  bool indefinite_ = false;           ///< the last factorization was factor_indefinite()
  mutable Eigen::LLT<Mat> pivot_scratch_;
  std::vector<double> cyclic_;        ///< block cyclic reduction's levels (cyclic_reduction.hpp)
};

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_BLOCK_TRIDIAGONAL_HPP
