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
#include <cstdio>
#include <limits>
#include <utility>

#include "block_tridiagonal.hpp"
#include "engine.hpp"

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
    Ld_ = ctx.Ld;
    D1_ = ctx.D1;
    D2_ = ctx.D2;
    D11_ = ctx.D11;
    D12_ = ctx.D12;
    D22_ = ctx.D22;
    res_ = ctx.res;
    mu_ = 0;
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
    if (mu_ > 0 && mu_ < mu_min) mu_ = mu_min;
    for (int attempt = 0; attempt < 200; ++attempt) {
      H_.assemble(ctx, mu_, difference_);
      bool ok;
      if (cyclic_) {
        ok = H_.solve_cyclic_reduction(rhs_.data(), dx_.data(), ctx.threads);
      } else {
        ok = H_.factor_ldlt();
        if (ok) H_.solve_ldlt(rhs_.data(), dx_.data());
      }
      if (!ok) {
        raise(mu_min);
        if (mu_ > 1e30 * scale) break;
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
      const double pred = -(gdx + 0.5 * (H_.quadratic_form(dx_.data()) - mu_ * dx2));
      // Trial point.
      for (std::size_t i = 0; i < dz; ++i) {
        ctx.q_next[i] = ctx.q[i];
        ctx.q_next[static_cast<std::size_t>(N) * dz + i] = ctx.q[static_cast<std::size_t>(N) * dz + i];
      }
      for (std::size_t i = 0; i < n; ++i) ctx.q_next[dz + i] = ctx.q[dz + i] + dx_[i];
      swap_arrays(ctx);
      eval_full(ctx, ctx.q_next);
      const int bad = compute_residual(ctx);
      const double Fn = sum_action(ctx);
      const double ared = F - Fn;
      const double roundoff = 1e-13 * (1 + std::fabs(F));
      bool accept = false;
      double rho = 0;
      if (bad < 0 && std::isfinite(Fn)) {
        if (pred > roundoff) {
          rho = ared / pred;
          accept = rho >= 1e-4;
        } else {
          accept = ctx.residual < r0 && ared > -roundoff;
          rho = accept ? 1 : 0;
        }
      }
      if (accept) {
        ctx.action = Fn;
        ctx.action_known = true;
        // Nielsen's update: shrink the shift smoothly with the quality of the model.
        const double t = 2 * std::min(rho, 1.0) - 1;
        mu_ *= std::max(1.0 / 3.0, 1 - t * t * t);
        if (mu_ < mu_min) mu_ = 0;
        nu_ = 2;
        StepOutcome done;
        done.next_evaluated = true;
        return done;
      }
      swap_arrays(ctx);  // restore the evaluation at q
      ctx.residual = r0;
      raise(mu_min);
      if (mu_ > 1e30 * scale) break;
    }
    StepOutcome out;
    char buf[320];
    // With the shift at its limit the step is a vanishing multiple of the negative gradient; an
    // action that is unbounded below would decrease along it, so failing here means that the
    // gradient (the DEL residual) is at the round-off level of the action.
    out.failure = Termination::stalled;
    std::snprintf(buf, sizeof buf,
                  "newton stalled in iteration %ld: no decrease of the action even along vanishing gradient steps; "
                  "the DEL residual %.3g is at the round-off level of this problem (estimate %.3g) and the "
                  "tolerance cannot be reached in double precision",
                  iteration, r0, ctx.residual_floor);
    out.message = buf;
    return out;
  }

  std::vector<double> save_state() const override { return {mu_, nu_}; }
  bool load_state(const std::vector<double>& state) override {
    if (state.size() != 2 || !(state[0] >= 0) || !(state[1] >= 2) || !std::isfinite(state[0]) || !std::isfinite(state[1]))
      return false;
    mu_ = state[0];
    nu_ = state[1];
    return true;
  }

 private:
  void raise(double mu_min) {
    mu_ = mu_ == 0 ? mu_min : std::max(nu_ * mu_, mu_min);
    nu_ = std::min(2 * nu_, 64.0);
  }

  void swap_arrays(Context& ctx) {
    std::swap(ctx.Ld, Ld_);
    std::swap(ctx.D1, D1_);
    std::swap(ctx.D2, D2_);
    std::swap(ctx.D11, D11_);
    std::swap(ctx.D12, D12_);
    std::swap(ctx.D22, D22_);
    std::swap(ctx.res, res_);
  }

  bool cyclic_;
  bool difference_;
  BlockTridiagonal<D> H_;
  std::vector<double> rhs_, dx_;
  std::vector<double> Ld_, D1_, D2_, D11_, D12_, D22_, res_;
  double mu_ = 0, nu_ = 2;
};

}  // namespace

std::unique_ptr<Method_> make_newton(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<Newton<decltype(D)::value>>(options);
  });
}

}  // namespace pardel::detail
