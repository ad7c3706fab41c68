/**
 * @file local_space.hpp
 * Internal: all unknowns of one process as the Newton methods see them (the trust-region Newton of
 * newton.cpp and the stationary Newton of stationary.cpp): the whole block-tridiagonal Hessian
 * (block LDL^T with Cholesky pivots, block cyclic reduction, or the indefinite elimination), the
 * kinetic or identity metric, trial points and evaluations.
 */
#ifndef PARDEL_RUNTIME_LOCAL_SPACE_HPP
#define PARDEL_RUNTIME_LOCAL_SPACE_HPP

#include <algorithm>
#include <cmath>

#include "assessment.hpp"
#include "block_tridiagonal.hpp"
#include "constants.hpp"
#include "engine.hpp"

namespace pardel::detail {

/** All unknowns of one process: nodes 1..N-1 of the context, in node layout. */
template <int D>
class LocalSpace {
 public:
  explicit LocalSpace(const Options& o)
      : cyclic_(o.linear_solver == LinearSolver::cyclic_reduction),
        difference_(o.newton_shift == NewtonShift::difference) {}

  void resize(Context& ctx) {
    H_.resize(ctx.N, ctx.dim, ctx.capacity(static_cast<std::size_t>(std::max(ctx.N - 1, 0))));
    if (cyclic_) H_.reserve_cyclic_reduction();
    dz_ = static_cast<std::size_t>(ctx.dim);
    n_ = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * dz_;
    N_ = ctx.N;
  }
  std::size_t size() const { return n_; }
  std::size_t offset() const { return dz_; }
  bool is_free(const Context& ctx, std::size_t i) const { return ctx.is_free[dz_ + i] != 0; }
  int first_node() const { return 1; }
  int intervals() const { return N_; }
  double sum(double v) const { return v; }
  double max(double v) const { return v; }
  double max_abs_diagonal(const Context& ctx) const { return BlockTridiagonal<D>::max_abs_diagonal(ctx); }

  bool factor(const Context& ctx, double lambda, const double* b, double* x) {
    H_.assemble(ctx, lambda, difference_);
    if (cyclic_) return H_.solve_cyclic_reduction(b, x, ctx.threads);
    if (!H_.factor_ldlt()) return false;
    H_.solve_ldlt(b, x);
    return true;
  }
  /** H + lambda M factored by the indefinite block elimination (eigen-split pivots), x = its inverse
   *  times b; false where it is singular to working precision (stationary.cpp). */
  bool factor_indefinite(const Context& ctx, double lambda, const double* b, double* x) {
    H_.assemble(ctx, lambda, difference_);
    if (!H_.factor_indefinite()) return false;
    H_.solve_ldlt(b, x);
    return true;
  }
  void solve(const Context& ctx, const double* in, double* out) {
    if (cyclic_)
      H_.solve_cyclic_reduction(in, out, ctx.threads);
    else
      H_.solve_ldlt(in, out);
  }
  double quadratic_form(const double* x) const { return H_.quadratic_form(x); }
  /** Of the unshifted Hessian (reassembled: a failed factorization leaves it partly overwritten). */
  long negative_eigenvalues(const Context& ctx) {
    H_.assemble(ctx, 0.0, difference_);
    return H_.inertia().negative;
  }

  /** y = M x on the free components (x is zero on fixed ones). */
  void apply_metric(const Context& ctx, const double* x, double* y) const {
    if (!difference_) {
      std::copy(x, x + n_, y);
      return;
    }
    for (std::size_t i = 0; i < n_; ++i) {
      double v = 2 * x[i];
      if (i >= dz_) v -= x[i - dz_];
      if (i + dz_ < n_) v -= x[i + dz_];
      y[i] = ctx.is_free[dz_ + i] ? v : 0.0;
    }
  }
  double metric_norm(const double* x) const {
    double s = 0;
    if (difference_) {
      for (std::size_t i = 0; i < n_; ++i) {
        const double step = x[i] - (i >= dz_ ? x[i - dz_] : 0.0);
        s += step * step;
      }
      for (std::size_t i = n_ >= dz_ ? n_ - dz_ : 0; i < n_; ++i) s += x[i] * x[i];
    } else {
      for (std::size_t i = 0; i < n_; ++i) s += x[i] * x[i];
    }
    return std::sqrt(s);
  }

  void trial_point(Context& ctx, const double* step) const {
    const std::size_t last = static_cast<std::size_t>(N_) * dz_;
    for (std::size_t i = 0; i < dz_; ++i) {
      ctx.q_next[i] = ctx.q[i];
      ctx.q_next[last + i] = ctx.q[last + i];
    }
    for (std::size_t i = 0; i < n_; ++i) ctx.q_next[dz_ + i] = ctx.q[dz_ + i] + step[i];
  }
  int evaluate(Context& ctx, const std::vector<double>& q) const {
    eval_full(ctx, q);
    return compute_residual(ctx, q);
  }
  double action(const Context& ctx) const { return sum_action(ctx); }
  bool newton_correction(Context& ctx, std::vector<double>& delta) {
    if (cyclic_) return false;  // cyclic reduction keeps no factorization to solve with again
    H_.newton_correction(ctx, delta);
    return true;
  }
  bool assess_factored(Context& ctx, PointAssessment& out, double* const* work) {
    if (cyclic_) return false;  // cyclic reduction keeps no factorization to solve with again
    assess_positive_definite(ctx, H_, out, work, &eigenvectors_);
    return true;
  }
  /** A coarse level settled with H factored at lambda = 0 at its answer or the iterate before:
   *  its eigenvector estimates start the next level's, and the final assessment's (LevelEigenvectors).
   *  First-order models only: the node blocks of higher orders hold derivatives, whose Hessian
   *  entries scale with other powers of h, so that their lowest modes change order between levels
   *  (a start along one of them settles on the wrong eigenvalue). The level next to the final one
   *  (ctx.reserve_N at most kAutoRatio times its N) is skipped where a coarser level's are held:
   *  from those the final level's runs still settle in a step (their error O(h^2) 16 times the
   *  skipped level's, far below the runs' 1e-4), and the skipped level's runs would cost a quarter
   *  of the final assessment's. */
  void level_settled(Context& ctx, double* const* work) {
    if (cyclic_ || ctx.model->order != 1) return;
    if (eigenvectors_.held() && static_cast<long>(ctx.N) * kAutoRatio >= ctx.reserve_N) return;
    eigenvectors_.settle_level(ctx, [this](const double* b, double* x) { H_.solve_ldlt(b, x); }, work);
  }

 private:
  bool cyclic_, difference_;
  BlockTridiagonal<D> H_;
  LevelEigenvectors eigenvectors_;  ///< of the last settled coarse level
  std::size_t dz_ = 0, n_ = 0;
  int N_ = 0;
};

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_LOCAL_SPACE_HPP
