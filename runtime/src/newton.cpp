/**
 * @file newton.cpp
 * Newton's method on the whole DEL system (beyond the seed), globalized by a trust region on the
 * discrete action that these problems minimize. Each step solves the trust-region subproblem
 *   min g.s + s.H.s/2  subject to  |s|_M <= Delta
 * exactly (Moré-Sorensen): the shift lambda of H + lambda M is found by Newton's method on the
 * secular equation with O(N) block LDL^T factorizations, whose success certifies H + lambda M
 * positive definite; when H is indefinite and the secular equation has no root (the hard case,
 * e.g. at a saddle) the step follows negative curvature to the boundary. The metric M is the
 * kinetic form tridiag(-1, 2, -1) per component (Options::newton_shift = difference, the default)
 * or the identity.
 *
 * Acceptance does not creep along flat curved valleys. The full Newton step of a positive definite
 * Hessian is tried first, whatever the radius. It is accepted when the action falls by a fraction
 * of the predicted decrease, or when it cuts the best residual of the level by 10 %; refused near
 * a solution (residual below 1e-3 of the DEL terms' scale), it is taken anyway under a watchdog
 * (Chamberlain's): up to four further Newton steps must bring the action below the reference
 * point's by a fraction of its predicted decrease, or the iteration returns to the reference point
 * and solves the subproblem within a radius below the refused step. Otherwise the trust-region
 * step is judged by the ratio of actual to predicted decrease; at the round-off level of the
 * action a decrease of the residual decides.
 */
#include <algorithm>
#include <cmath>
#include <limits>

#include "block_tridiagonal.hpp"
#include "engine.hpp"
#include "levenberg_marquardt.hpp"

namespace pardel::detail {
namespace {

/** How often in one level the method refuses to stop at a saddle before it reports it. */
constexpr int kMaxEscapes = 5;
/** Newton steps the watchdog takes past a refused one before it returns to the reference point. */
constexpr int kWatchdogSteps = 4;
/** The watchdog arms only near a solution: residual below this fraction of the DEL terms' scale. */
constexpr double kWatchdogResidual = 1e-3;

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
    p_.assign(n, 0.0);
    u_.assign(n, 0.0);
    w_.assign(n, 0.0);
    ensure_interval_arrays(ctx, Evaluated::full);
    trial_.size_like(ctx);
    delta_ = 0;
    lambda_ = 0;
    assembled_lambda_ = -1;
    best_residual_ = std::numeric_limits<double>::infinity();
    escapes_ = 0;
    escape_ = false;
    watchdog_.active = watchdog_.failed = false;
    watchdog_.q.reserve(ctx.q.size());
  }

  int evaluate(Context& ctx) override {
    if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
    const int bad = compute_residual(ctx);
    ctx.action = sum_action(ctx);
    ctx.action_known = true;
    return bad;
  }

  /** At the tolerance: stop at a minimum or a degenerate point, but leave a saddle along negative
   *  curvature (up to kMaxEscapes times in a level; then the saddle is reported as found). */
  bool accept_stop(Context& ctx) override {
    if (!factor(ctx, 0)) {
      assembled_lambda_ = -1;  // inertia() overwrites the factorization
      if (H_.inertia(kZeroPivot).negative > 0 && escapes_ < kMaxEscapes) {
        ++escapes_;
        escape_ = true;
        delta_ = std::max(delta_, 0.1 * std::max(1.0, metric_norm_of_iterate(ctx)));
        return false;
      }
    }
    return true;
  }

  StepOutcome iterate(Context& ctx, long iteration) override {
    const int d = ctx.dim, N = ctx.N;
    const std::size_t dz = static_cast<std::size_t>(d);
    const std::size_t n = rhs_.size();
    const double F = ctx.action, r0 = ctx.residual;
    for (std::size_t i = 0; i < n; ++i) rhs_[i] = -ctx.res[dz + i];
    best_residual_ = std::min(best_residual_, r0);
    double scale = BlockTridiagonal<D>::max_abs_diagonal(ctx);
    if (!(scale > 0) || !std::isfinite(scale)) scale = 1;
    const bool escaping = escape_;
    escape_ = false;
    try_newton_ = !watchdog_.failed;
    watchdog_.failed = false;
    if (watchdog_.active && (watchdog_.steps >= kWatchdogSteps || !factor(ctx, 0))) return revert(ctx);
    bool nonfinite_trials = false;
    int nonfinite_node = -1;
    for (int attempt = 0; attempt < 60; ++attempt) {
      Step step;
      if (!trust_region_step(ctx, scale, escaping, &step)) break;
      try_newton_ = false;
      // Predicted decrease of the action with the unshifted Hessian: -(g.s + s.H.s/2).
      double gs = 0;
      for (std::size_t i = 0; i < n; ++i) gs -= rhs_[i] * p_[i];
      const double sHs = H_.quadratic_form(p_.data()) - assembled_lambda_ * step.norm * step.norm;
      const double pred = -(gs + 0.5 * sHs);
      for (std::size_t i = 0; i < dz; ++i) {
        ctx.q_next[i] = ctx.q[i];
        ctx.q_next[static_cast<std::size_t>(N) * dz + i] = ctx.q[static_cast<std::size_t>(N) * dz + i];
      }
      for (std::size_t i = 0; i < n; ++i) ctx.q_next[dz + i] = ctx.q[dz + i] + p_[i];
      trial_.swap_with(ctx);
      eval_full(ctx, ctx.q_next);
      const int bad = compute_residual(ctx);
      const double Fn = sum_action(ctx), rn = ctx.residual;
      const bool finite = bad < 0 && std::isfinite(Fn);
      Verdict v = judge(F, Fn, pred, finite, rn, r0, step.newton);
      if (step.newton && finite && watchdog_.active) {
        // Watchdog: Newton steps are taken as they come until the action falls below the
        // reference point's by a fraction of what was predicted there, or the budget is spent.
        ++watchdog_.steps;
        if (Fn < watchdog_.F - 1e-4 * watchdog_.pred) {
          watchdog_.active = false;
          v.accepted = true;
        } else if (watchdog_.steps < kWatchdogSteps) {
          v.accepted = true;
        }
      } else if (step.newton && finite && !v.accepted && !watchdog_.active && r0 <= kWatchdogResidual * ctx.residual_scale) {
        // A full Newton step that the action refuses (a curved valley): taken anyway, with the
        // present point kept as the reference to return to.
        watchdog_.active = true;
        watchdog_.steps = 0;
        watchdog_.F = F;
        watchdog_.pred = pred;
        watchdog_.norm = step.norm;
        watchdog_.q = ctx.q;
        v.accepted = true;
        v.rho = 1;
      }
      if (v.accepted) {
        if (v.rho < 0.25 && !v.by_residual) {
          delta_ = 0.5 * step.norm;
        } else if (v.rho > 0.75 && step.norm >= 0.9 * delta_) {
          delta_ = std::max(delta_, 2 * step.norm);
        } else if (v.by_residual || step.newton) {
          delta_ = std::max(delta_, step.norm);
        }
        ctx.action = Fn;
        ctx.action_known = true;
        StepOutcome done;
        done.next_evaluated = true;
        return done;
      }
      trial_.swap_with(ctx);  // restore the evaluation at q
      ctx.residual = r0;
      if (!finite) {
        nonfinite_trials = true;
        nonfinite_node = bad;
      } else {
        nonfinite_trials = false;
      }
      if (step.newton && step.norm > delta_) continue;  // the full step beyond the radius: now within it
      delta_ = 0.25 * std::min(delta_, step.norm);
      if (!(delta_ > 1e-15 * std::max(1.0, metric_norm_of_iterate(ctx)))) break;
    }
    if (nonfinite_trials) {
      // Every step, down to a vanishing one, reaches a point where the model is not finite.
      StepOutcome out;
      out.failure = Termination::non_finite;
      out.message = "newton: in iteration " + std::to_string(iteration) +
                    " every trial step, down to a vanishing radius, gives a non-finite DEL residual or action" +
                    (nonfinite_node >= 0 ? " (node " + std::to_string(nonfinite_node) + ")" : std::string()) +
                    "; the last finite iterate is returned";
      return out;
    }
    return newton_stalled(iteration, r0, ctx.residual_floor);
  }

  /** {radius, shift, best residual, escapes, then the watchdog: active,
   *  failed, steps, F, pred, norm and (active) its reference point}. */
  std::vector<double> save_state() const override {
    std::vector<double> s{delta_, lambda_, best_residual_, static_cast<double>(escapes_)};
    s.insert(s.end(), {watchdog_.active ? 1.0 : 0.0, watchdog_.failed ? 1.0 : 0.0, static_cast<double>(watchdog_.steps),
                       watchdog_.F, watchdog_.pred, watchdog_.norm});
    if (watchdog_.active) s.insert(s.end(), watchdog_.q.begin(), watchdog_.q.end());
    return s;
  }
  bool load_state(const std::vector<double>& s) override {
    constexpr std::size_t head = 4 + 6;
    if (s.size() < head) return false;
    if (!(s[0] >= 0) || !std::isfinite(s[0]) || !(s[1] >= 0) || !std::isfinite(s[1]) || !(s[3] >= 0) ||
        s[3] > kMaxEscapes || std::isnan(s[2]))
      return false;
    const std::size_t w = 4;
    const bool active = s[w] == 1;
    if ((s[w] != 0 && s[w] != 1) || (s[w + 1] != 0 && s[w + 1] != 1) || !(s[w + 2] >= 0 && s[w + 2] <= kWatchdogSteps))
      return false;
    if (s.size() != head + (active ? watchdog_.q.capacity() : 0)) return false;
    delta_ = s[0];
    lambda_ = s[1];
    best_residual_ = s[2];
    escapes_ = static_cast<int>(s[3]);
    watchdog_.active = active;
    watchdog_.failed = s[w + 1] == 1;
    watchdog_.steps = static_cast<int>(s[w + 2]);
    watchdog_.F = s[w + 3];
    watchdog_.pred = s[w + 4];
    watchdog_.norm = s[w + 5];
    watchdog_.q.assign(s.begin() + static_cast<std::ptrdiff_t>(head), s.end());
    return true;
  }

 private:
  /** Pivot eigenvalues below this fraction of their block's size count as zero (inertia). */
  static constexpr double kZeroPivot = 1e-12;

  struct Step {
    double norm = 0;      ///< |s|_M
    bool newton = false;  ///< the full Newton step of a positive definite Hessian
  };
  struct Verdict {
    bool accepted = false, by_residual = false;
    double rho = 0;
  };

  /** Assembles H + lambda M and factors it; false if it is not positive definite. */
  bool factor(const Context& ctx, double lambda) {
    H_.assemble(ctx, lambda, difference_);
    assembled_lambda_ = lambda;
    if (cyclic_) return H_.solve_cyclic_reduction(rhs_.data(), p_.data(), ctx.threads);
    return H_.factor_ldlt();
  }
  /** p = (H + lambda M)^{-1} rhs after a successful factor(). */
  void solve_step(const Context& ctx) {
    if (!cyclic_) H_.solve_ldlt(rhs_.data(), p_.data());
    (void)ctx;
  }
  /** out = (H + lambda M)^{-1} in after a successful factor() (cyclic reduction refactors). */
  void solve_other(const Context& ctx, const std::vector<double>& in, std::vector<double>& out) {
    if (cyclic_)
      H_.solve_cyclic_reduction(in.data(), out.data(), ctx.threads);
    else
      H_.solve_ldlt(in.data(), out.data());
  }

  /** y = M x on the free components (x is zero on fixed ones). */
  void apply_metric(const Context& ctx, const std::vector<double>& x, std::vector<double>& y) const {
    const std::size_t n = x.size(), dz = static_cast<std::size_t>(ctx.dim);
    if (!difference_) {
      y = x;
      return;
    }
    for (std::size_t i = 0; i < n; ++i) {
      double v = 2 * x[i];
      if (i >= dz) v -= x[i - dz];
      if (i + dz < n) v -= x[i + dz];
      y[i] = ctx.is_free[dz + i] ? v : 0.0;
    }
  }
  double metric_norm(const std::vector<double>& x, std::size_t dz) const {
    double s = 0;
    const std::size_t n = x.size();
    if (difference_) {
      for (std::size_t i = 0; i < n; ++i) {
        const double step = x[i] - (i >= dz ? x[i - dz] : 0.0);
        s += step * step;
      }
      for (std::size_t i = n >= dz ? n - dz : 0; i < n; ++i) s += x[i] * x[i];
    } else {
      for (double v : x) s += v * v;
    }
    return std::sqrt(s);
  }
  /** |q|_M of the interior nodes' free components: the scale of an escape step. */
  double metric_norm_of_iterate(const Context& ctx) {
    const std::size_t dz = static_cast<std::size_t>(ctx.dim);
    for (std::size_t i = 0; i < u_.size(); ++i) u_[i] = ctx.is_free[dz + i] ? ctx.q[dz + i] : 0.0;
    return metric_norm(u_, dz);
  }

  /**
   * The trust-region step into p_ (and its M-norm), Moré-Sorensen on the secular equation
   * 1/|p(lambda)|_M = 1/Delta with a safeguarding bracket; the hard case (no root, H indefinite)
   * adds the direction of most negative curvature found by inverse iteration. False when no
   * positive definite shift was found.
   */
  bool trust_region_step(Context& ctx, double scale, bool escaping, Step* step) {
    const std::size_t dz = static_cast<std::size_t>(ctx.dim);
    const double tiny = 1e-14 * scale;
    if (!escaping && try_newton_ && factor(ctx, 0)) {
      // A positive definite Hessian: the full Newton step is tried first, whatever the radius
      // (refused, the next attempt solves the subproblem at the radius).
      solve_step(ctx);
      const double pn = metric_norm(p_, dz);
      if (delta_ <= 0) delta_ = pn;  // first step of a level
      lambda_ = 0;
      *step = Step{pn, true};
      return true;
    }
    if (delta_ <= 0) {
      // First step of a level with an indefinite Hessian: the first positive definite shift
      // (growing geometrically from the last one) sets the radius.
      double lambda = std::max(lambda_, 1e-6 * scale);
      for (int i = 0; i < 60 && !factor(ctx, lambda); ++i) lambda *= 4;
      if (assembled_lambda_ != lambda) return false;
      solve_step(ctx);
      lambda_ = lambda;
      delta_ = metric_norm(p_, dz);
      *step = Step{delta_, false};
      return delta_ > 0;
    }
    double lo = 0, hi = std::numeric_limits<double>::infinity();
    double lambda = std::max(lambda_, tiny);
    double best_lambda = -1, best_norm = 0;  // last positive definite shift, its step's norm
    bool hard = false;
    for (int it = 0; it < 40; ++it) {
      if (!factor(ctx, lambda)) {
        lo = std::max(lo, lambda);
        lambda = std::isfinite(hi) ? 0.5 * (lo + hi) : 4 * std::max(lambda, tiny);
        if (std::isfinite(hi) && hi - lo <= 1e-9 * hi) break;
        continue;
      }
      solve_step(ctx);
      const double pn = metric_norm(p_, dz);
      best_lambda = lambda;
      best_norm = pn;
      if (std::fabs(pn - delta_) <= 0.1 * delta_) break;
      if (pn > delta_) {
        lo = std::max(lo, lambda);
      } else {
        hi = std::min(hi, lambda);
        if (hi - lo <= 1e-6 * hi) {  // the bracket closed at the edge of definiteness: hard case
          hard = true;
          break;
        }
      }
      // Newton on the secular equation: lambda += (|p|^2 / p.M (H+lambda M)^{-1} M p) (|p| - Delta) / Delta.
      apply_metric(ctx, p_, w_);
      solve_other(ctx, w_, u_);
      double pw = 0;
      for (std::size_t i = 0; i < w_.size(); ++i) pw += w_[i] * u_[i];
      double next = pw > 0 ? lambda + (pn * pn / pw) * (pn - delta_) / delta_ : -1;
      if (!(next > lo && next < hi)) next = std::isfinite(hi) ? (lo > 0 ? std::sqrt(lo * hi) : 0.5 * hi) : 4 * lambda;
      if (!(next > lo && next < hi) && std::isfinite(hi)) next = 0.5 * (lo + hi);
      lambda = next;
      if (std::isfinite(hi) && hi - lo <= 1e-12 * hi) break;
    }
    if (best_lambda < 0) return false;
    if (assembled_lambda_ != best_lambda) {
      if (!factor(ctx, best_lambda)) return false;
      solve_step(ctx);
      best_norm = metric_norm(p_, dz);
    }
    lambda_ = best_lambda;
    if (best_norm > delta_ * 1.1) {
      // The secular iteration did not converge: the shifted step, cut back to the radius (still a
      // descent direction of the model).
      const double c = delta_ / best_norm;
      for (double& v : p_) v *= c;
      best_norm = delta_;
    } else if ((hard || escaping) && best_norm < 0.9 * delta_) {
      best_norm = add_negative_curvature(ctx);
    }
    *step = Step{best_norm, false};
    return best_norm > 0;
  }

  /**
   * Hard case: p_ += tau z with z the direction of least curvature of H + lambda M (three steps of
   * inverse iteration with the current factorization), tau chosen so that |p + tau z|_M = Delta
   * and the model decreases most. Returns the new |p|_M.
   */
  double add_negative_curvature(Context& ctx) {
    const std::size_t dz = static_cast<std::size_t>(ctx.dim), n = p_.size();
    for (std::size_t i = 0; i < n; ++i) {
      const double k = static_cast<double>(i / dz + 1), a = static_cast<double>(i % dz + 1);
      w_[i] = ctx.is_free[dz + i] ? std::sin(3.1 * k * a / static_cast<double>(n / dz + 1)) + 0.5 : 0.0;
    }
    for (int it = 0; it < 3; ++it) {
      apply_metric(ctx, w_, u_);
      solve_other(ctx, u_, w_);
      const double z = metric_norm(w_, dz);
      if (!(z > 0) || !std::isfinite(z)) return metric_norm(p_, dz);
      for (double& v : w_) v /= z;
    }
    // |p + tau z|^2 = Delta^2 with |z| = 1: tau^2 + 2 b tau + c = 0.
    apply_metric(ctx, w_, u_);
    double b = 0;
    for (std::size_t i = 0; i < n; ++i) b += p_[i] * u_[i];
    const double pn = metric_norm(p_, dz);
    const double c = pn * pn - delta_ * delta_;
    const double root = std::sqrt(std::max(b * b - c, 0.0));
    double best_tau = 0, best_model = std::numeric_limits<double>::infinity();
    for (double tau : {-b + root, -b - root}) {
      for (std::size_t i = 0; i < n; ++i) u_[i] = p_[i] + tau * w_[i];
      double gs = 0;
      for (std::size_t i = 0; i < n; ++i) gs -= rhs_[i] * u_[i];
      const double un = metric_norm(u_, dz);
      const double model = gs + 0.5 * (H_.quadratic_form(u_.data()) - assembled_lambda_ * un * un);
      if (model < best_model) {
        best_model = model;
        best_tau = tau;
      }
    }
    for (std::size_t i = 0; i < n; ++i) p_[i] += best_tau * w_[i];
    return metric_norm(p_, dz);
  }

  /** The watchdog found no decrease: back to its reference point, whose next step is solved within
   *  a radius below the refused Newton step. */
  StepOutcome revert(Context& ctx) {
    watchdog_.active = false;
    watchdog_.failed = true;
    std::copy(watchdog_.q.begin(), watchdog_.q.end(), ctx.q_next.begin());
    delta_ = std::min(delta_, 0.5 * watchdog_.norm);
    StepOutcome out;
    out.next_evaluated = false;
    return out;
  }

  /** The acceptance test of a trial step (see the file comment). */
  Verdict judge(double F, double Fn, double pred, bool finite, double rn, double r0, bool newton) {
    Verdict v;
    if (!finite) return v;
    const double ared = F - Fn;
    const double roundoff = 1e-13 * (1 + std::fabs(F));
    if (!(pred > roundoff)) {
      v.accepted = rn < r0 && ared > -roundoff;
      v.rho = v.accepted ? 1 : 0;
      return v;
    }
    v.rho = ared / pred;
    if (v.rho >= 1e-4) {
      v.accepted = true;
    } else if (newton && rn <= 0.9 * best_residual_) {
      v.accepted = true;
      v.by_residual = true;
    }
    return v;
  }

  bool cyclic_;
  bool difference_;
  BlockTridiagonal<D> H_;
  std::vector<double> rhs_, p_, u_, w_;
  TrialEvaluation trial_;
  double delta_ = 0, lambda_ = 0, assembled_lambda_ = -1;
  double best_residual_ = 0;
  int escapes_ = 0;
  bool escape_ = false;
  bool try_newton_ = true;  ///< the first attempt of an iteration tries the full Newton step
  struct Watchdog {
    bool active = false;  ///< Newton steps are being taken past a refused one
    bool failed = false;  ///< the last watchdog was reverted: this iteration solves the subproblem
    int steps = 0;
    double F = 0, pred = 0, norm = 0;  ///< action, predicted decrease and step size at the reference
    std::vector<double> q;             ///< the reference point
  } watchdog_;
};

}  // namespace

std::unique_ptr<Method_> make_newton(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<Newton<decltype(D)::value>>(options);
  });
}

}  // namespace pardel::detail
