/**
 * @file newton.cpp
 * Newton's method on the whole DEL system (beyond the seed), globalized as Levenberg-Marquardt
 * on the discrete action that these problems minimize: the Hessian is shifted by mu I until its
 * block factorization certifies positive definiteness, and a step is accepted by the ratio of
 * actual to predicted decrease of the action (or, once both are at round-off level, by a
 * decrease of the residual). Linear solves by block LDL^T or block cyclic reduction.
 */
#include <algorithm>
#include <cmath>

#include "block_tridiagonal.hpp"
#include "engine.hpp"
#include "levenberg_marquardt.hpp"

namespace pardel::detail {
namespace {

template <int D>
class Newton : public Method_ {
 public:
  explicit Newton(const Options& o)
      : cyclic_(o.linear_solver == LinearSolver::cyclic_reduction),
        difference_(o.newton_shift == NewtonShift::difference) {}

  void reset(Context& ctx) override {
    H_.resize(ctx.N, ctx.dim);
    if (cyclic_) H_.reserve_cyclic_reduction();
    const std::size_t n = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * ctx.dim;
    rhs_.assign(n, 0.0);
    dx_.assign(n, 0.0);
    ensure_interval_arrays(ctx, Evaluated::full);
    trial_.size_like(ctx);
    shift_.restart();
  }

  int evaluate(Context& ctx) override {
    if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
    const int bad = compute_residual(ctx);
    ctx.action = sum_action(ctx);
    ctx.action_known = true;
    return bad;
  }

  StepOutcome iterate(Context& ctx, long iteration) override {
    const int d = ctx.dim, N = ctx.N;
    const std::size_t dz = static_cast<std::size_t>(d);
    const std::size_t n = rhs_.size();
    const double F = ctx.action, r0 = ctx.residual;
    for (std::size_t i = 0; i < n; ++i) rhs_[i] = -ctx.res[dz + i];
    // Scale of the shift: the largest diagonal entry of the unshifted Hessian.
    double scale = BlockTridiagonal<D>::max_abs_diagonal(ctx);
    if (!(scale > 0) || !std::isfinite(scale)) scale = 1;
    const double mu_min = 1e-10 * scale;
    shift_.clamp(mu_min);
    for (int attempt = 0; attempt < 200; ++attempt) {
      H_.assemble(ctx, shift_.mu(), difference_);
      bool ok;
      if (cyclic_) {
        ok = H_.solve_cyclic_reduction(rhs_.data(), dx_.data(), ctx.threads);
      } else {
        ok = H_.factor_ldlt();
        if (ok) H_.solve_ldlt(rhs_.data(), dx_.data());
      }
      if (!ok) {
        shift_.raise(mu_min);
        if (shift_.exhausted(scale)) break;
        continue;
      }
      // Quadratic model of the action with the unshifted Hessian: m(dx) = g.dx + dx.H.dx/2.
      double gdx = 0, dx2 = 0;  // dx2 = dx.M.dx for the shift's metric M
      for (std::size_t i = 0; i < n; ++i) gdx -= rhs_[i] * dx_[i];
      if (difference_) {
        for (std::size_t i = 0; i < n; ++i) {
          const double step = dx_[i] - (i >= dz ? dx_[i - dz] : 0.0);
          dx2 += step * step;
        }
        for (std::size_t i = n - dz; i < n; ++i) dx2 += dx_[i] * dx_[i];
      } else {
        for (std::size_t i = 0; i < n; ++i) dx2 += dx_[i] * dx_[i];
      }
      const double pred = -(gdx + 0.5 * (H_.quadratic_form(dx_.data()) - shift_.mu() * dx2));
      // Trial point.
      for (std::size_t i = 0; i < dz; ++i) {
        ctx.q_next[i] = ctx.q[i];
        ctx.q_next[static_cast<std::size_t>(N) * dz + i] = ctx.q[static_cast<std::size_t>(N) * dz + i];
      }
      for (std::size_t i = 0; i < n; ++i) ctx.q_next[dz + i] = ctx.q[dz + i] + dx_[i];
      trial_.swap_with(ctx);
      eval_full(ctx, ctx.q_next);
      const int bad = compute_residual(ctx);
      const double Fn = sum_action(ctx);
      if (shift_.accept(F, Fn, pred, bad < 0, ctx.residual, r0, mu_min)) {
        ctx.action = Fn;
        ctx.action_known = true;
        StepOutcome done;
        done.next_evaluated = true;
        return done;
      }
      trial_.swap_with(ctx);  // restore the evaluation at q
      ctx.residual = r0;
      shift_.raise(mu_min);
      if (shift_.exhausted(scale)) break;
    }
    return newton_stalled(iteration, r0, ctx.residual_floor);
  }

  std::vector<double> save_state() const override { return shift_.save(); }
  bool load_state(const std::vector<double>& state) override { return shift_.load(state); }

 private:
  bool cyclic_;
  bool difference_;
  BlockTridiagonal<D> H_;
  std::vector<double> rhs_, dx_;
  TrialEvaluation trial_;
  LevenbergMarquardtShift shift_;
};

}  // namespace

std::unique_ptr<Method_> make_newton(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<Newton<decltype(D)::value>>(options);
  });
}

}  // namespace pardel::detail
