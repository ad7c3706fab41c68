/**
 * @file stationary.cpp
 * Newton's method on the DEL equations r(q) = 0 globalized on the residual instead of the action
 * (method "stationary-newton", and the automatic method's second attempt for a model without a
 * declared cost): it converges to a DEL solution whether that is a minimum or a saddle of the
 * discrete action, e.g. a mechanical motion past a conjugate point, along which the action is
 * unbounded below and the minimizing Newton of trust_region.hpp cannot stop.
 *
 * Each iteration factors the Hessian H of the action (the Jacobian of r, symmetric and possibly
 * indefinite) by block LDL^T with eigen-split pivots and takes the Newton direction p = -H^-1 r.
 * For the merit phi = |r|^2 / 2 its slope is r.H p = -|r|^2 < 0, so p descends whatever the
 * inertia of H, and a backtracking (Armijo) line search on phi globalizes it. Where H is singular
 * to working precision it is shifted, H + mu K (K the kinetic metric tridiag(-1, 2, -1) per
 * component), mu growing from 1e-10 of H's diagonal, as long as the shifted direction still
 * descends (slope -|r|^2 - mu r.K p < 0). One process only.
 */
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "block_tridiagonal.hpp"
#include "engine.hpp"
#include "trust_region.hpp"

namespace pardel::detail {
namespace {

/** Pivot eigenvalues below this fraction of their block's size count as zero. */
constexpr double kZeroPivot = 1e-12;
/** Armijo's fraction of the predicted decrease of the merit. */
constexpr double kArmijo = 1e-4;
/** Backtracking halvings before the iteration reports a stall. */
constexpr int kMaxHalvings = 40;

template <int D>
class StationaryNewton : public Method_ {
 public:
  void reset(Context& ctx) override {
    H_.resize(ctx.N, ctx.dim, ctx.capacity(static_cast<std::size_t>(std::max(ctx.N - 1, 0))));
    dz_ = static_cast<std::size_t>(ctx.dim);
    n_ = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * dz_;
    for (std::vector<double>* v : {&rhs_, &p_}) assign_within(*v, n_, ctx.capacity(n_), 0.0);
    ensure_interval_arrays(ctx, Evaluated::full);
    trial_.size_like(ctx);
  }

  int evaluate(Context& ctx) override {
    if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
    const int bad = compute_residual(ctx);
    ctx.action = sum_action(ctx);
    ctx.action_known = true;
    return bad;
  }

  StepOutcome iterate(Context& ctx, long iteration) override {
    for (std::size_t i = 0; i < n_; ++i) rhs_[i] = -ctx.res[dz_ + i];
    const double phi0 = merit(ctx);
    double slope = 0;
    if (!direction(ctx, phi0, &slope)) {
      return failure(Termination::stalled,
                     "stationary-newton stalled in iteration " + std::to_string(iteration) +
                         ": the Hessian of the action is singular to working precision here and no shift of it "
                         "gives a direction that reduces the DEL residual (a solution that is not isolated, or a "
                         "degenerate Lagrangian)");
    }
    const double r0 = ctx.residual;
    const double F0 = ctx.action;
    double alpha = 1;
    for (int halving = 0; halving <= kMaxHalvings; ++halving, alpha *= 0.5) {
      trial_point(ctx, alpha);
      trial_.swap_with(ctx);
      eval_full(ctx, ctx.q_next);
      const int bad = compute_residual(ctx);
      if (bad < 0) {
        const double phi = merit(ctx);
        if (std::isfinite(phi) && phi <= phi0 + kArmijo * alpha * slope) {
          ctx.action = sum_action(ctx);
          ctx.action_known = true;
          StepOutcome done;
          done.next_evaluated = true;
          return done;
        }
      }
      trial_.swap_with(ctx);  // back to the evaluation at q
      ctx.residual = r0;
      ctx.action = F0;
    }
    char buf[640];
    std::snprintf(buf, sizeof buf,
                  "stationary-newton stalled in iteration %ld: no step along the Newton direction, down to %.2g of it, "
                  "reduces the DEL residual %.3g (round-off level %.3g): the residual has a local minimum here, where "
                  "the Hessian of the action is nearly singular (a fold of the boundary-value problem), so no DEL "
                  "solution is near this iterate; a guess closer to the wanted motion may reach one",
                  iteration, alpha, r0, ctx.residual_floor);
    return failure(Termination::stalled, buf);
  }

 private:
  static StepOutcome failure(Termination why, std::string message) {
    StepOutcome out;
    out.failure = why;
    out.message = std::move(message);
    return out;
  }

  /** |r|^2 / 2 over the unknowns (fixed components hold zero residuals). */
  double merit(const Context& ctx) const {
    double s = 0;
    for (std::size_t i = 0; i < n_; ++i) s += ctx.res[dz_ + i] * ctx.res[dz_ + i];
    return 0.5 * s;
  }

  /** The Newton direction into p_ (shifted where H is singular) and the merit's slope along it;
   *  false when no shift up to H's scale gives a descent direction. */
  bool direction(const Context& ctx, double phi0, double* slope) {
    double scale = BlockTridiagonal<D>::max_abs_diagonal(ctx);
    if (!(scale > 0) || !std::isfinite(scale)) scale = 1;
    for (double mu = 0; mu <= scale; mu = mu > 0 ? mu * 100 : 1e-10 * scale) {
      H_.assemble(ctx, mu, true);
      if (!H_.factor_indefinite(kZeroPivot)) continue;
      H_.solve_ldlt(rhs_.data(), p_.data());
      // slope = r.H p with (H + mu K) p = -r: -|r|^2 - mu r.K p.
      *slope = -2 * phi0 - mu * metric_product(ctx);
      bool finite = true;
      for (std::size_t i = 0; i < n_ && finite; ++i) finite = std::isfinite(p_[i]);
      if (finite && *slope < 0) return true;
    }
    return false;
  }

  /** r.K p with r = -rhs_, K = tridiag(-1, 2, -1) per component on the free components. */
  double metric_product(const Context& ctx) const {
    double s = 0;
    for (std::size_t i = 0; i < n_; ++i) {
      if (!ctx.is_free[dz_ + i]) continue;
      double kp = 2 * p_[i];
      if (i >= dz_ && ctx.is_free[i]) kp -= p_[i - dz_];
      if (i + dz_ < n_ && ctx.is_free[2 * dz_ + i]) kp -= p_[i + dz_];
      s -= rhs_[i] * kp;
    }
    return s;
  }

  /** ctx.q_next = ctx.q + alpha p on the unknowns, the end nodes copied. */
  void trial_point(Context& ctx, double alpha) const {
    const std::size_t last = static_cast<std::size_t>(ctx.N) * dz_;
    for (std::size_t i = 0; i < dz_; ++i) {
      ctx.q_next[i] = ctx.q[i];
      ctx.q_next[last + i] = ctx.q[last + i];
    }
    for (std::size_t i = 0; i < n_; ++i) ctx.q_next[dz_ + i] = ctx.q[dz_ + i] + alpha * p_[i];
  }

  BlockTridiagonal<D> H_;
  std::vector<double> rhs_, p_;
  TrialEvaluation trial_;
  std::size_t dz_ = 0, n_ = 0;
};

}  // namespace

std::unique_ptr<Method_> make_stationary_newton(const Options& options, int dim) {
  (void)options;
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<StationaryNewton<decltype(D)::value>>();
  });
}

}  // namespace pardel::detail
