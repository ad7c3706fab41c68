/**
 * @file trust_region.hpp
 * Newton's method on the whole DEL system (beyond the seed), globalized by a trust region on the
 * discrete action that these problems minimize; written once for the one-process solve
 * (newton.cpp) and over MPI ranks (mpi/distributed_newton.cpp), which differ only in the Space that
 * holds the Hessian, its solver and the reductions over the unknowns. Each step solves the
 * trust-region subproblem
 *   min g.s + s.H.s/2  subject to  |s|_M <= Delta
 * exactly (Moré-Sorensen): the shift lambda of H + lambda M is found by Newton's method on the
 * secular equation with O(N) block factorizations, whose success certifies H + lambda M positive
 * definite; when H is indefinite and the secular equation has no root (the hard case, e.g. at a
 * saddle) the step follows negative curvature to the boundary. The metric M is the kinetic form
 * tridiag(-1, 2, -1) per component (Options::newton_shift = difference, the default) or the
 * identity.
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
 *
 * A Space provides, over the unknowns it holds (all of them, or one rank's; every reduction and
 * every verdict the same on all ranks):
 *   void resize(Context&);  std::size_t size();  std::size_t offset();  (index of unknown 0 in ctx.q)
 *   bool is_free(const Context&, i);  int first_node();  (global node of unknown 0)  int intervals();  (N)
 *   double sum(double);  double max(double);  double max_abs_diagonal(const Context&);
 *   bool factor(const Context&, lambda, rhs, x);  (H + lambda M positive definite: x = its inverse times rhs)
 *   void solve(const Context&, in, out);  (after a successful factor)
 *   double quadratic_form(x);  (with the factored shift)  long negative_eigenvalues(const Context&);  (-1: unknown)
 *   void apply_metric(const Context&, x, y);  double metric_norm(x);
 *   void trial_point(Context&, step);  (ctx.q_next = ctx.q + step)
 *   int evaluate(Context&, q);  (full evaluation and residual: the first non-finite node or -1)
 *   double action(const Context&);
 *   bool newton_correction(Context&, std::vector<double>& delta);  (-H^-1 r from that factorization, or false)
 *   bool assess_factored(Context&, PointAssessment&, work);  (after factor at lambda = 0 succeeded there, with
 *     four vectors of size() as scratch; false: cannot)
 *   void level_settled(Context&, work);  (a coarse level stopped with H factored at lambda = 0 at or next to
 *     ctx.q; the same scratch)
 */
#ifndef PARDEL_RUNTIME_TRUST_REGION_HPP
#define PARDEL_RUNTIME_TRUST_REGION_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "constants.hpp"
#include "engine.hpp"

namespace pardel::detail {

/**
 * The outcome when no trial step, down to a vanishing radius, decreased the action. A vanishing
 * trust-region step is a multiple of the negative gradient; an action that is unbounded below
 * would decrease along it, so failing here means that the gradient (the DEL residual) is at the
 * round-off level of the action.
 */
inline StepOutcome newton_stalled(long iteration, double residual, double residual_floor, double diagonal_spread = 1,
                                  double largest = 0, const std::string& unsolved = std::string()) {
  StepOutcome out;
  char buf[640];
  out.failure = Termination::stalled;
  // Within a factor 1e8 of the largest double, sums of the action and steps of the iterate
  // overflow or lose their changes: no verdict on the model can be drawn there.
  constexpr double kNearOverflow = 1e300;
  if (!std::isfinite(largest)) {
    std::snprintf(buf, sizeof buf,
                  "newton stalled in iteration %ld: no decrease of the action even along vanishing gradient steps, "
                  "at a DEL residual %.3g, with an action that is not finite (a term of L infinite at these values, "
                  "or an overflow): its changes cannot be compared",
                  iteration, residual);
  } else if (largest > kNearOverflow) {
    std::snprintf(buf, sizeof buf,
                  "newton stalled in iteration %ld: no decrease of the action even along vanishing gradient steps, "
                  "at a DEL residual %.3g, with the action or the DEL terms of size %.3g, within a factor 1e8 of the "
                  "largest double: their sums overflow or lose the steps' changes at this size; in other units "
                  "(rescaled time or coordinates) that keep them far below 1e300 the problem can be solved",
                  iteration, residual, largest);
  } else if (at_round_off(residual, residual_floor) && !unsolved.empty()) {
    // Below the largest terms' rounding, but not below its own: the action (and its infinity-norm
    // residual) cannot see the component's steps, as it cannot see changes below its rounding.
    std::snprintf(buf, sizeof buf,
                  "newton stalled in iteration %ld: no decrease of the action even along vanishing gradient steps; "
                  "the DEL residual %.3g is at the round-off level of the largest DEL terms (estimate %.3g) but %s",
                  iteration, residual, residual_floor, unsolved_component_note(unsolved, "the action").c_str());
  } else if (at_round_off(residual, residual_floor)) {
    std::snprintf(buf, sizeof buf,
                  "newton stalled in iteration %ld: no decrease of the action even along vanishing gradient steps; "
                  "the DEL residual %.3g is at the round-off level of this problem (estimate %.3g) and the "
                  "tolerance cannot be reached in double precision",
                  iteration, residual, residual_floor);
  } else {
    std::snprintf(buf, sizeof buf,
                  "newton stalled in iteration %ld: no decrease of the action even along vanishing gradient steps, "
                  "at a DEL residual %.3g far above its round-off level (estimate %.3g): the action's derivatives "
                  "disagree with its values here (a model that is not smooth, or not differentiable, at this iterate)",
                  iteration, residual, residual_floor);
    if (diagonal_spread > kStallSpread) {
      // Steps in one metric for coordinates of very different units: the decrease along the
      // stiff coordinates is below the action's round-off while the soft ones' residual remains.
      const std::size_t used = std::strlen(buf);
      std::snprintf(buf + used, sizeof buf - used,
                    ", or coordinates whose scales differ too much for steps in one metric (the Hessian's diagonal "
                    "spans a factor %.2g: solver.newton_shift = \"identity\", or coordinates in comparable units, "
                    "may reach the solution)",
                    diagonal_spread);
    }
  }
  out.message = buf;
  return out;
}

/**
 * Where the evaluation of a trial point goes (trust-region Newton, stationary-newton): into the
 * context's interval arrays, with the evaluation at q kept in a second set of them while a level's
 * trials can be refused. The second set is taken only from the first refusal of a level on: until
 * then a trial is evaluated over the arrays at q, and that refusal evaluates q again (one kernel
 * pass) and keeps the set for the rest of the level. A level whose steps are all accepted, as the
 * fine levels of a nested solve are, so never touches it (at N = 2e6 of a 2-D model 300 MB of the
 * solve's 1.3 GB). Either way the context after a refusal is the same to the bit: the arrays and
 * residual at q, and the round-off level and per-component sizes of the refused trial's pass.
 */
class TrialEvaluation {
 public:
  /** A new level (or grid): nothing kept yet. */
  void begin_level() { kept_ = false; }

  /** Before a trial point is evaluated into the context. */
  void before_trial(Context& ctx) {
    if (kept_) swap_with(ctx);
  }

  /** After a refused trial: the evaluation at ctx.q back in the context, by a swap or, the first
   *  time on a level, by `evaluate_at_q` (the full evaluation and residual pass at ctx.q). */
  template <class EvaluateAtQ>
  void refused(Context& ctx, EvaluateAtQ&& evaluate_at_q) {
    if (kept_) {
      swap_with(ctx);
      return;
    }
    const double floor = ctx.residual_floor, scale = ctx.residual_scale;
    comp_residual_ = ctx.comp_residual;
    comp_scale_ = ctx.comp_scale;
    comp_hq_ = ctx.comp_hq;
    evaluate_at_q();
    ctx.residual_floor = floor;
    ctx.residual_scale = scale;
    ctx.comp_residual.swap(comp_residual_);
    ctx.comp_scale.swap(comp_scale_);
    ctx.comp_hq.swap(comp_hq_);
    size_like(ctx);
    kept_ = true;
  }

 private:
  /** Sized like the context's arrays (which must hold a full evaluation's sizes). */
  void size_like(const Context& ctx) {
    auto fit = [&ctx](std::vector<double>& mine, const std::vector<double>& theirs) {
      assign_within(mine, theirs.size(), ctx.capacity(theirs.size()), 0.0);
    };
    fit(Ld_, ctx.Ld);
    fit(D1_, ctx.D1);
    fit(D2_, ctx.D2);
    fit(D11_, ctx.D11);
    fit(D12_, ctx.D12);
    fit(D22_, ctx.D22);
    fit(res_, ctx.res);
  }

  void swap_with(Context& ctx) {
    std::swap(ctx.Ld, Ld_);
    std::swap(ctx.D1, D1_);
    std::swap(ctx.D2, D2_);
    std::swap(ctx.D11, D11_);
    std::swap(ctx.D12, D12_);
    std::swap(ctx.D22, D22_);
    std::swap(ctx.res, res_);
  }

  bool kept_ = false;  ///< the second set holds the evaluation at q during a trial (swapped in)
  std::vector<double> Ld_, D1_, D2_, D11_, D12_, D22_, res_;
  std::vector<double> comp_residual_, comp_scale_, comp_hq_;  ///< the refused trial's, across the evaluation at q
};


template <class Space>
class TrustRegionNewton : public Method_ {
 public:
  template <class... Args>
  explicit TrustRegionNewton(Args&&... args) : space_(std::forward<Args>(args)...) {}

  void reset(Context& ctx) override {
    space_.resize(ctx);
    const std::size_t n = space_.size();
    for (std::vector<double>* v : {&rhs_, &p_, &u_, &w_}) assign_within(*v, n, ctx.capacity(n), 0.0);
    ensure_interval_arrays(ctx, Evaluated::full);
    trial_.begin_level();
    delta_ = 0;
    lambda_ = 0;
    assembled_lambda_ = -1;
    best_residual_ = std::numeric_limits<double>::infinity();
    escapes_ = 0;
    escape_ = false;
    stop_factored_ = false;
    last_step_newton_ = false;
    watchdog_.active = watchdog_.failed = false;
    watchdog_.q.reserve(ctx.q.size());
  }

  int evaluate(Context& ctx) override {
    if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
    const int bad = compute_residual(ctx);
    ctx.action = space_.action(ctx);
    ctx.action_known = true;
    return bad;
  }

  /** Whether the unshifted Hessian at the full evaluation in ctx is positive definite. */
  bool hessian_positive_definite(const Context& ctx) {
    std::fill(u_.begin(), u_.end(), 0.0);
    return factor(ctx, 0, u_, w_);
  }

  /** New node times: the watchdog's reference action and the level's best residual belong to the
   *  problem before the change. */
  void times_changed() override {
    stop_factored_ = false;
    last_step_newton_ = false;
    watchdog_.active = false;
    watchdog_.failed = false;
    best_residual_ = std::numeric_limits<double>::infinity();
  }

  /** At the tolerance: stop at a minimum or a degenerate point, but leave a saddle along negative
   *  curvature (up to kMaxEscapes times in a level; then the saddle is reported as found). On a
   *  coarse level reached by a full Newton step from a positive definite Hessian the check is
   *  spared: a saddle there would be one Newton left on the next level, where it checks again. */
  bool accept_stop(Context& ctx, bool final_level) override {
    if (!final_level && last_step_newton_) {
      if (assembled_lambda_ == 0) coarse_level_settled(ctx);  // factored at the iterate before the step
      return true;
    }
    stop_factored_ = factor(ctx, 0, rhs_, p_);
    if (!stop_factored_) {
      assembled_lambda_ = -1;  // the inertia overwrites the factorization
      if (escapes_ < kMaxEscapes && space_.negative_eigenvalues(ctx) > 0) {
        ++escapes_;
        escape_ = true;
        delta_ = std::max(delta_, 0.1 * std::max(1.0, metric_norm_of_iterate(ctx)));
        return false;
      }
    } else if (!final_level) {
      coarse_level_settled(ctx);
    }
    return true;
  }

  /** Seconds spent on the coarse levels' eigenvector estimates (part of the point assessment's cost). */
  double level_assessment_seconds() const override { return level_seconds_; }

  /** A coarse level stops with the unshifted Hessian factored: the eigenvector estimates that start
   *  the next level's (and the final assessment's) Lanczos runs, timed. */
  void coarse_level_settled(Context& ctx) {
    const auto start = std::chrono::steady_clock::now();
    double* const work[4] = {rhs_.data(), p_.data(), u_.data(), w_.data()};  // free once the level stopped
    space_.level_settled(ctx, work);
    level_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  /** At a minimum where accept_stop() factored the Hessian: the Newton correction from it. */
  bool newton_correction(Context& ctx, std::vector<double>& delta) override {
    return stop_factored_ && space_.newton_correction(ctx, delta);
  }

  /** At a minimum where accept_stop() factored the Hessian, the assessment reuses that factorization. */
  bool assess(Context& ctx, PointAssessment& out) override {
    double* const work[4] = {rhs_.data(), p_.data(), u_.data(), w_.data()};  // free once the iteration stopped
    return stop_factored_ && space_.assess_factored(ctx, out, work);
  }

  StepOutcome iterate(Context& ctx, long iteration) override {
    stop_factored_ = false;
    last_step_newton_ = false;
    const std::size_t n = rhs_.size(), o = space_.offset();
    const double F = ctx.action, r0 = ctx.residual;
    const std::string unsolved0 = unsolved_component(ctx);  // at q, before a trial's evaluation
    for (std::size_t i = 0; i < n; ++i) rhs_[i] = -ctx.res[o + i];
    best_residual_ = std::min(best_residual_, r0);
    double scale = space_.max_abs_diagonal(ctx);
    if (!(scale > 0) || !std::isfinite(scale)) scale = 1;
    const bool escaping = escape_;
    escape_ = false;
    try_newton_ = !watchdog_.failed;
    watchdog_.failed = false;
    if (watchdog_.active && (watchdog_.steps >= kWatchdogSteps || !factor(ctx, 0, rhs_, p_))) return revert(ctx);
    bool all_nonfinite = true;  // every trial so far reached a non-finite value
    int nonfinite_trials = 0, nonfinite_node = -1;
    for (int attempt = 0; attempt < 60; ++attempt) {
      Step step;
      if (!trust_region_step(ctx, scale, escaping, &step)) break;
      try_newton_ = false;
      // Predicted decrease of the action with the unshifted Hessian: -(g.s + s.H.s/2).
      const double gs = -dot(rhs_, p_);
      const double sHs = space_.quadratic_form(p_.data()) - assembled_lambda_ * step.norm * step.norm;
      const double pred = -(gs + 0.5 * sHs);
      space_.trial_point(ctx, p_.data());
      trial_.before_trial(ctx);
      const int bad = space_.evaluate(ctx, ctx.q_next);
      const double Fn = space_.action(ctx), rn = ctx.residual;
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
        if (v.rho < kShrinkRatio && !v.by_residual) {
          delta_ = 0.5 * step.norm;
        } else if (v.rho > kExpandRatio && step.norm >= kBoundaryShare * delta_) {
          delta_ = std::max(delta_, 2 * step.norm);
        } else if (v.by_residual || step.newton) {
          delta_ = std::max(delta_, step.norm);
        }
        ctx.action = Fn;
        ctx.action_known = true;
        last_step_newton_ = step.newton && !watchdog_.active;
        StepOutcome done;
        done.next_evaluated = true;
        return done;
      }
      trial_.refused(ctx, [&] { space_.evaluate(ctx, ctx.q); });  // the evaluation at q again
      ctx.residual = r0;
      if (!finite) {
        if (nonfinite_trials++ == 0) nonfinite_node = bad;
      } else {
        all_nonfinite = false;
      }
      if (step.newton && step.norm > delta_) continue;  // the full step beyond the radius: now within it
      delta_ = 0.25 * std::min(delta_, step.norm);
      if (!(delta_ > 1e-15 * std::max(1.0, metric_norm_of_iterate(ctx)))) break;
    }
    if (nonfinite_trials > 0 && (all_nonfinite || r0 > kRoundOffResidual * ctx.residual_floor)) {
      // The steps, down to a vanishing one, reach points where the model is not finite (or, the
      // shortest of them, no lower action): the model's domain ends next to this iterate.
      StepOutcome out;
      out.failure = Termination::non_finite;
      out.message = "newton: in iteration " + std::to_string(iteration) +
                    (all_nonfinite ? " every trial step, down to a vanishing radius, gives"
                                   : " trial steps, down to a vanishing radius, give either no decrease of the action or") +
                    " a non-finite DEL residual or action" +
                    (nonfinite_node >= 0 ? " (first at node " + std::to_string(nonfinite_node) + ")" : std::string()) +
                    "; the last finite iterate is returned";
      return out;
    }
    if (!at_round_off(r0, ctx.residual_floor)) measure_round_off(ctx);
    return newton_stalled(iteration, ctx.residual, ctx.residual_floor, diagonal_spread(ctx),
                          std::max(std::fabs(ctx.action), ctx.residual_scale), unsolved0);
  }

  /** Values of save_state() before the watchdog's reference point. */
  static constexpr std::size_t kStateHead = 4 + 6;

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
    constexpr std::size_t head = kStateHead;
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
  struct Step {
    double norm = 0;      ///< |s|_M
    bool newton = false;  ///< the full Newton step of a positive definite Hessian
  };
  struct Verdict {
    bool accepted = false, by_residual = false;
    double rho = 0;
  };

  /** Assembles H + lambda M and factors it; false if it is not positive definite, else
   *  x = (H + lambda M)^{-1} b. */
  bool factor(const Context& ctx, double lambda, const std::vector<double>& b, std::vector<double>& x) {
    assembled_lambda_ = lambda;
    return space_.factor(ctx, lambda, b.data(), x.data());
  }
  /** Sum over all unknowns of a[i] b[i]. */
  double dot(const std::vector<double>& a, const std::vector<double>& b) const {
    double s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
    return space_.sum(s);
  }
  /** A stall far above the estimated round-off level: the level measured at ctx.q instead, per
   *  component the largest change of its residual when every free value moves by four units in its
   *  last place (two sign patterns), kept in ctx.comp_floor_measured where it exceeds the estimate;
   *  ctx is evaluated at q again (the same bits as before, the floors now at least the measured
   *  ones). Collective. */
  void measure_round_off(Context& ctx) {
    const std::size_t o = space_.offset(), n = space_.size(), d = static_cast<std::size_t>(ctx.dim);
    const double eps = std::numeric_limits<double>::epsilon();
    const std::vector<double> q = ctx.q, at_q(ctx.res.begin() + static_cast<std::ptrdiff_t>(o),
                                              ctx.res.begin() + static_cast<std::ptrdiff_t>(o + n));
    std::vector<double> change(d, 0.0), moved;
    for (std::size_t pattern = 0; pattern < 2; ++pattern) {
      moved = q;
      for (std::size_t i = 0; i < n; ++i)
        if (space_.is_free(ctx, i)) moved[o + i] *= 1 + (((i / d + pattern * (i % d)) % 2) ? 4 : -4) * eps;
      space_.evaluate(ctx, moved);
      for (std::size_t i = 0; i < n; ++i)
        if (space_.is_free(ctx, i))
          change[(o + i) % d] = std::max(change[(o + i) % d], std::fabs(ctx.res[o + i] - at_q[i]));
    }
    const double estimated = ctx.residual_floor;  // at the last pattern's point, as at q to rounding
    double largest = 0;
    for (double& c : change) largest = std::max(largest, c = space_.max(c));
    if (largest > estimated) ctx.comp_floor_measured = std::move(change);  // kept where it says more
    space_.evaluate(ctx, q);
  }

  /** |q|_M of the unknowns' free components: the scale of an escape step. */
  double metric_norm_of_iterate(const Context& ctx) {
    const std::size_t o = space_.offset();
    for (std::size_t i = 0; i < u_.size(); ++i) u_[i] = space_.is_free(ctx, i) ? ctx.q[o + i] : 0.0;
    return space_.metric_norm(u_.data());
  }

  /**
   * The trust-region step into p_ (and its M-norm), Moré-Sorensen on the secular equation
   * 1/|p(lambda)|_M = 1/Delta with a safeguarding bracket; the hard case (no root, H indefinite)
   * adds the direction of most negative curvature found by inverse iteration. False when no
   * positive definite shift was found.
   */
  bool trust_region_step(Context& ctx, double scale, bool escaping, Step* step) {
    const double tiny = 1e-14 * scale;
    if (!escaping && try_newton_ && factor(ctx, 0, rhs_, p_)) {
      // A positive definite Hessian: the full Newton step is tried first, whatever the radius
      // (refused, the next attempt solves the subproblem at the radius).
      const double pn = space_.metric_norm(p_.data());
      if (delta_ <= 0) delta_ = pn;  // first step of a level
      lambda_ = 0;
      *step = Step{pn, true};
      return true;
    }
    if (delta_ <= 0) {
      // First step of a level with an indefinite Hessian: the first positive definite shift
      // (growing geometrically from the last one) sets the radius.
      double lambda = std::max(lambda_, 1e-6 * scale);
      bool ok = false;
      for (int i = 0; i < 60 && !(ok = factor(ctx, lambda, rhs_, p_)); ++i) lambda *= 4;
      if (!ok) return false;
      lambda_ = lambda;
      delta_ = space_.metric_norm(p_.data());
      *step = Step{delta_, false};
      return delta_ > 0;
    }
    double lo = 0, hi = std::numeric_limits<double>::infinity();
    double lambda = std::max(lambda_, tiny);
    double best_lambda = -1, best_norm = 0;  // last positive definite shift, its step's norm
    bool hard = false;
    for (int it = 0; it < 40; ++it) {
      if (!factor(ctx, lambda, rhs_, p_)) {
        lo = std::max(lo, lambda);
        lambda = std::isfinite(hi) ? 0.5 * (lo + hi) : 4 * std::max(lambda, tiny);
        if (std::isfinite(hi) && hi - lo <= 1e-9 * hi) break;
        continue;
      }
      const double pn = space_.metric_norm(p_.data());
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
      space_.apply_metric(ctx, p_.data(), w_.data());
      space_.solve(ctx, w_.data(), u_.data());
      const double pw = dot(w_, u_);
      double next = pw > 0 ? lambda + (pn * pn / pw) * (pn - delta_) / delta_ : -1;
      if (!(next > lo && next < hi)) next = std::isfinite(hi) ? (lo > 0 ? std::sqrt(lo * hi) : 0.5 * hi) : 4 * lambda;
      if (!(next > lo && next < hi) && std::isfinite(hi)) next = 0.5 * (lo + hi);
      lambda = next;
      if (std::isfinite(hi) && hi - lo <= 1e-12 * hi) break;
    }
    if (best_lambda < 0) return false;
    if (assembled_lambda_ != best_lambda) {
      if (!factor(ctx, best_lambda, rhs_, p_)) return false;
      best_norm = space_.metric_norm(p_.data());
    }
    lambda_ = best_lambda;
    if (best_norm > delta_ * 1.1) {
      // The secular iteration did not converge: the shifted step, cut back to the radius (still a
      // descent direction of the model).
      const double c = delta_ / best_norm;
      for (double& v : p_) v *= c;
      best_norm = delta_;
    } else if ((hard || escaping) && best_norm < kBoundaryShare * delta_) {
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
    const double nodes = static_cast<double>(space_.intervals());
    for (std::size_t i = 0; i < n; ++i) {
      const double k = static_cast<double>(space_.first_node() + static_cast<int>(i / dz));
      const double a = static_cast<double>(i % dz + 1);
      w_[i] = space_.is_free(ctx, i) ? std::sin(3.1 * k * a / nodes) + 0.5 : 0.0;
    }
    for (int it = 0; it < 3; ++it) {
      space_.apply_metric(ctx, w_.data(), u_.data());
      space_.solve(ctx, u_.data(), w_.data());
      const double z = space_.metric_norm(w_.data());
      if (!(z > 0) || !std::isfinite(z)) return space_.metric_norm(p_.data());
      for (double& v : w_) v /= z;
    }
    // |p + tau z|^2 = Delta^2 with |z| = 1: tau^2 + 2 b tau + c = 0.
    space_.apply_metric(ctx, w_.data(), u_.data());
    const double b = dot(p_, u_);
    const double pn = space_.metric_norm(p_.data());
    const double c = pn * pn - delta_ * delta_;
    const double root = std::sqrt(std::max(b * b - c, 0.0));
    double best_tau = 0, best_model = std::numeric_limits<double>::infinity();
    for (double tau : {-b + root, -b - root}) {
      for (std::size_t i = 0; i < n; ++i) u_[i] = p_[i] + tau * w_[i];
      const double gs = -dot(rhs_, u_);
      const double un = space_.metric_norm(u_.data());
      const double model = gs + 0.5 * (space_.quadratic_form(u_.data()) - assembled_lambda_ * un * un);
      if (model < best_model) {
        best_model = model;
        best_tau = tau;
      }
    }
    for (std::size_t i = 0; i < n; ++i) p_[i] += best_tau * w_[i];
    return space_.metric_norm(p_.data());
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
    if (v.rho >= kAcceptRatio) {
      v.accepted = true;
    } else if (newton && rn <= kResidualAccept * best_residual_) {
      v.accepted = true;
      v.by_residual = true;
    }
    return v;
  }

  Space space_;
  std::vector<double> rhs_, p_, u_, w_;
  TrialEvaluation trial_;
  double delta_ = 0, lambda_ = 0, assembled_lambda_ = -1;
  double best_residual_ = 0;
  int escapes_ = 0;
  bool escape_ = false;
  bool stop_factored_ = false;  ///< accept_stop() factored the unshifted Hessian at ctx.q
  double level_seconds_ = 0;    ///< coarse_level_settled's time over the solve
  bool last_step_newton_ = false;  ///< ctx.q came from a full Newton step of a positive definite Hessian
  bool try_newton_ = true;  ///< the first attempt of an iteration tries the full Newton step
  struct Watchdog {
    bool active = false;  ///< Newton steps are being taken past a refused one
    bool failed = false;  ///< the last watchdog was reverted: this iteration solves the subproblem
    int steps = 0;
    double F = 0, pred = 0, norm = 0;  ///< action, predicted decrease and step size at the reference
    std::vector<double> q;             ///< the reference point
  } watchdog_;
};

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_TRUST_REGION_HPP
