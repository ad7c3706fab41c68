/**
 * @file levenberg_marquardt.hpp
 * What Newton's globalization shares between the one-process solve (newton.cpp) and the
 * distributed one (mpi/distributed.cpp): the Levenberg-Marquardt shift with Nielsen's update, the
 * acceptance test of a trial step on the discrete action, the stalled outcome, and the second set
 * of interval arrays a trial point is evaluated into.
 */
#ifndef PARDEL_RUNTIME_LEVENBERG_MARQUARDT_HPP
#define PARDEL_RUNTIME_LEVENBERG_MARQUARDT_HPP

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "engine.hpp"

namespace pardel::detail {

/** The shift mu of H + mu M and its growth factor nu. */
class LevenbergMarquardtShift {
 public:
  double mu() const { return mu_; }

  /** A new problem (or grid level): no shift; the growth factor is kept. */
  void restart() { mu_ = 0; }

  /** A shift that is set stays at least mu_min (the scale of this iteration's Hessian). */
  void clamp(double mu_min) {
    if (mu_ > 0 && mu_ < mu_min) mu_ = mu_min;
  }

  /** After a failed factorization or a refused step: mu grows geometrically (nu doubles up to 64). */
  void raise(double mu_min) {
    mu_ = mu_ == 0 ? mu_min : std::max(nu_ * mu_, mu_min);
    nu_ = std::min(2 * nu_, 64.0);
  }

  /** The shift has reached its limit relative to the Hessian's scale: the iteration stalls. */
  bool exhausted(double scale) const { return mu_ > 1e30 * scale; }

  /**
   * Judges a trial step from the action F (residual r0) to Fn (residual trial_residual), with
   * `pred` the decrease the quadratic model predicted and `trial_finite` false when the trial
   * point has a non-finite value. Accepted by the ratio of actual to predicted decrease, or, once
   * both are at the round-off level of F, by a decrease of the residual; an accepted step shrinks
   * the shift smoothly with the model's quality (Nielsen).
   */
  bool accept(double F, double Fn, double pred, bool trial_finite, double trial_residual, double r0,
              double mu_min) {
    const double ared = F - Fn;
    const double roundoff = 1e-13 * (1 + std::fabs(F));
    bool accepted = false;
    double rho = 0;
    if (trial_finite && std::isfinite(Fn)) {
      if (pred > roundoff) {
        rho = ared / pred;
        accepted = rho >= 1e-4;
      } else {
        accepted = trial_residual < r0 && ared > -roundoff;
        rho = accepted ? 1 : 0;
      }
    }
    if (!accepted) return false;
    const double t = 2 * std::min(rho, 1.0) - 1;
    mu_ *= std::max(1.0 / 3.0, 1 - t * t * t);
    if (mu_ < mu_min) mu_ = 0;
    nu_ = 2;
    return true;
  }

  std::vector<double> save() const { return {mu_, nu_}; }
  /** Restores what save() returned; false (nothing changed) when it is not a valid state. */
  bool load(const std::vector<double>& state) {
    if (state.size() != 2 || !(state[0] >= 0) || !(state[1] >= 2) || !std::isfinite(state[0]) ||
        !std::isfinite(state[1]))
      return false;
    mu_ = state[0];
    nu_ = state[1];
    return true;
  }

 private:
  double mu_ = 0, nu_ = 2;
};

/**
 * The outcome when the shift reached its limit without a decrease. With the shift at its limit
 * the step is a vanishing multiple of the negative gradient; an action that is unbounded below
 * would decrease along it, so failing here means that the gradient (the DEL residual) is at the
 * round-off level of the action.
 */
inline StepOutcome newton_stalled(long iteration, double residual, double residual_floor) {
  StepOutcome out;
  char buf[320];
  out.failure = Termination::stalled;
  std::snprintf(buf, sizeof buf,
                "newton stalled in iteration %ld: no decrease of the action even along vanishing gradient steps; "
                "the DEL residual %.3g is at the round-off level of this problem (estimate %.3g) and the "
                "tolerance cannot be reached in double precision",
                iteration, residual, residual_floor);
  out.message = buf;
  return out;
}

/** A second set of the context's interval arrays: a trial point is evaluated into the context's
 *  set after swapping, and a refused trial swaps the evaluation at q back. */
class TrialEvaluation {
 public:
  /** Sized like the context's arrays (which must hold a full evaluation's sizes). */
  void size_like(const Context& ctx) {
    Ld_ = ctx.Ld;
    D1_ = ctx.D1;
    D2_ = ctx.D2;
    D11_ = ctx.D11;
    D12_ = ctx.D12;
    D22_ = ctx.D22;
    res_ = ctx.res;
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

 private:
  std::vector<double> Ld_, D1_, D2_, D11_, D12_, D22_, res_;
};

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_LEVENBERG_MARQUARDT_HPP
