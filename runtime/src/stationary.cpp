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
 * to working precision it is shifted, H + mu M (M the metric of Options::newton_shift, by default
 * the kinetic tridiag(-1, 2, -1) per component), mu growing from 1e-10 of H's diagonal, as long as
 * the shifted direction still descends (slope -|r|^2 - mu r.M p < 0). One process only: the
 * Hessian, metric and trial points are those of the one-process Newton (local_space.hpp).
 */
#include <cmath>
#include <cstdio>

#include "constants.hpp"
#include "local_space.hpp"
#include "trust_region.hpp"

namespace pardel::detail {
namespace {


template <int D>
class StationaryNewton : public Method_ {
 public:
  explicit StationaryNewton(const Options& options) : space_(options) {}

  void reset(Context& ctx) override {
    space_.resize(ctx);
    const std::size_t n = space_.size();
    for (std::vector<double>* v : {&rhs_, &p_, &w_}) assign_within(*v, n, ctx.capacity(n), 0.0);
    ensure_interval_arrays(ctx, Evaluated::full);
    trial_.begin_level();
  }

  int evaluate(Context& ctx) override {
    if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
    const int bad = compute_residual(ctx);
    ctx.action = space_.action(ctx);
    ctx.action_known = true;
    return bad;
  }

  StepOutcome iterate(Context& ctx, long iteration) override {
    const std::size_t o = space_.offset();
    for (std::size_t i = 0; i < rhs_.size(); ++i) rhs_[i] = -ctx.res[o + i];
    const double phi0 = merit(ctx);
    const std::string unsolved = unsolved_component(ctx);  // at q, before a trial's evaluation
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
    double alpha = 1;  // p_ holds alpha times the Newton direction
    for (int halving = 0; halving <= kMaxHalvings; ++halving) {
      space_.trial_point(ctx, p_.data());
      trial_.before_trial(ctx);
      if (space_.evaluate(ctx, ctx.q_next) < 0) {
        const double phi = merit(ctx);
        if (std::isfinite(phi) && phi <= phi0 + kArmijo * alpha * slope) {
          ctx.action = space_.action(ctx);
          ctx.action_known = true;
          StepOutcome done;
          done.next_evaluated = true;
          return done;
        }
      }
      trial_.refused(ctx, [&] { space_.evaluate(ctx, ctx.q); });  // back to the evaluation at q
      ctx.residual = r0;
      ctx.action = F0;
      alpha *= 0.5;
      for (double& v : p_) v *= 0.5;
    }
    char buf[640];
    if (at_round_off(r0, ctx.residual_floor) && !unsolved.empty()) {  // as newton_stalled
      std::snprintf(buf, sizeof buf,
                    "stationary-newton stalled in iteration %ld: no step along the Newton direction, down to %.2g of "
                    "it, reduces the DEL residual %.3g, which is at the round-off level of the largest DEL terms "
                    "(estimate %.3g) but %s",
                    iteration, 2 * alpha, r0, ctx.residual_floor,
                    unsolved_component_note(unsolved, "the residual's norm").c_str());
    } else if (at_round_off(r0, ctx.residual_floor)) {  // as the trust region's stall (newton_stalled)
      std::snprintf(buf, sizeof buf,
                    "stationary-newton stalled in iteration %ld: no step along the Newton direction, down to %.2g of "
                    "it, reduces the DEL residual %.3g, which is at the round-off level of this problem (estimate "
                    "%.3g): the tolerance cannot be reached in double precision",
                    iteration, 2 * alpha, r0, ctx.residual_floor);
    } else {
      std::snprintf(buf, sizeof buf,
                    "stationary-newton stalled in iteration %ld: no step along the Newton direction, down to %.2g of "
                    "it, reduces the DEL residual %.3g (round-off level %.3g): the residual has a local minimum here, "
                    "where the Hessian of the action is nearly singular (a fold of the boundary-value problem), so no "
                    "DEL solution is near this iterate; a guess closer to the wanted motion may reach one",
                    iteration, 2 * alpha, r0, ctx.residual_floor);
    }
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
    const std::size_t o = space_.offset();
    double s = 0;
    for (std::size_t i = 0; i < rhs_.size(); ++i) s += ctx.res[o + i] * ctx.res[o + i];
    return 0.5 * s;
  }

  /** The Newton direction into p_ (shifted where H is singular) and the merit's slope along it;
   *  false when no shift up to H's scale gives a descent direction. */
  bool direction(const Context& ctx, double phi0, double* slope) {
    double scale = space_.max_abs_diagonal(ctx);
    if (!(scale > 0) || !std::isfinite(scale)) scale = 1;
    for (double mu = 0; mu <= scale; mu = mu > 0 ? mu * 100 : 1e-10 * scale) {
      if (!space_.factor_indefinite(ctx, mu, rhs_.data(), p_.data())) continue;
      // slope = r.H p with (H + mu M) p = -r: -|r|^2 - mu r.M p, and r = -rhs_.
      double rMp = 0;
      if (mu > 0) {
        space_.apply_metric(ctx, p_.data(), w_.data());
        for (std::size_t i = 0; i < w_.size(); ++i) rMp -= rhs_[i] * w_[i];
      }
      *slope = -2 * phi0 - mu * rMp;
      bool finite = true;
      for (std::size_t i = 0; i < p_.size() && finite; ++i) finite = std::isfinite(p_[i]);
      if (finite && *slope < 0) return true;
    }
    return false;
  }

  LocalSpace<D> space_;
  std::vector<double> rhs_, p_, w_;
  TrialEvaluation trial_;
};

}  // namespace

std::unique_ptr<Method_> make_stationary_newton(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<StationaryNewton<decltype(D)::value>>(options);
  });
}

}  // namespace pardel::detail
