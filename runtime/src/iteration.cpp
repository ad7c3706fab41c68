/**
 * @file iteration.cpp
 * The iteration at one grid level shared by the one-process and the MPI solve: node-time updates
 * under a clock, the history, and the stopping rules (converged, level settled, answer at the
 * tolerance, stalled, max_iterations, diverged, non-finite, interrupted), each with its message.
 */
#include "constants.hpp"
#include "iteration.hpp"

#include "levels.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

namespace pardel::detail {
namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[512];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}

/** `seconds` as a duration of the steady clock (moves a solve's start back by a resumed wall time). */
std::chrono::steady_clock::duration steady_seconds(double seconds) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
}

}  // namespace

bool Iteration::run_level(bool last) {
  if (!resumed_level_) {
    level_ = LevelCounters{};
    previous_comp_residual_.clear();
    refinements_ = 0;  // each level may be refined kMaxRefinements times where Newton stalls at round-off
  }
  resumed_level_ = false;
  const bool clocked = ctx_.clock != ClockMode::none;
  bool recheck_times = false;  // the nodes moved to the clock's times at the tolerance: check them again
  int unsettled = 0;           // such moves in a row that did not lower the residual at the clock's times
  double best_at_clock = std::numeric_limits<double>::infinity();
  long best_at_clock_iteration = iteration_;
  bool step_evaluated = false; // the last step's outcome left the residual and action at ctx.q set
  times_pending_ = false;      // the times were found unsettled: a step comes before any stopping test
  if (clocked && times_stop_increasing()) return false;  // the start's times
  for (;;) {
    if (clocked && level_.since_clock >= options_.clock_update_every) {
      partition_.update_times(ctx_, Positions::follow_times);
      if (times_stop_increasing()) return false;
      method_.times_changed();
      level_.since_clock = 0;
      step_evaluated = false;
    }
    int bad = step_evaluated ? -1 : partition_.agree_on_residual(ctx_, method_.evaluate(ctx_));
    step_evaluated = false;
    if (bad >= 0) return non_finite_residual(bad);
    if (start_scale_.size() != ctx_.comp_scale.size()) start_scale_ = ctx_.comp_scale;  // the solve's first iterate
    double r = ctx_.residual;
    if (clocked && !times_pending_ && at_target(r, target_residual()) && (level_.since_clock > 0 || recheck_times)) {
      // Declare convergence only with node times consistent with this trajectory: the times the
      // clock gives at these nodes, which keep their values (moved along the trajectory, they would
      // no longer be where the clock was read).
      recheck_times = false;
      ctx_.t_kept = ctx_.t;
      ctx_.hk_kept = ctx_.hk;
      partition_.update_times(ctx_, Positions::stay);
      if (times_stop_increasing()) return false;
      method_.times_changed();
      level_.since_clock = 0;
      bad = partition_.agree_on_residual(ctx_, method_.evaluate(ctx_));
      if (bad >= 0 || !at_target(ctx_.residual, target_residual())) {
        // The times had not settled (the DEL residual at the clock's times is above the target):
        // back to the previous times, from which the nodes move along the trajectory to the
        // clock's times; the method takes a step there (at the tolerance on the moved nodes a
        // check at once would only move them again), and the times are checked again when the
        // residual is at the target.
        const double at_clock = bad >= 0 ? std::numeric_limits<double>::infinity() : ctx_.residual;
        if (at_clock < 0.99 * best_at_clock) {
          best_at_clock = at_clock;
          best_at_clock_iteration = iteration_;
          unsettled = 0;
        } else {
          ++unsettled;
        }
        std::swap(ctx_.t, ctx_.t_kept);
        std::swap(ctx_.hk, ctx_.hk_kept);
        ctx_.evaluated = Evaluated::nothing;
        ctx_.action_known = false;
        partition_.update_times(ctx_, Positions::follow_times);
        if (times_stop_increasing()) return false;
        bad = partition_.agree_on_residual(ctx_, method_.evaluate(ctx_));
        if (bad >= 0) return non_finite_residual(bad);
        if (times_unsettled(unsettled, iteration_ - best_at_clock_iteration)) return false;
        recheck_times = true;
        times_pending_ = true;
        step_evaluated = true;
        continue;
      }
      r = ctx_.residual;
    }
    if (level_.level_it == 0) level_.r_level0 = r;
    if (!have_initial_) {
      r_initial_ = r;
      have_initial_ = true;
    }
    last_good_residual_ = r;
    if (should_record() && !record()) {
      finish(Termination::interrupted, "interrupted by on_iteration at iteration " + std::to_string(iteration_));
      return false;
    }
    const double target = target_residual();
    bool settled = false;
    if (!times_pending_) {
      if (converged_at_tolerance(last, r, target, &settled) || intermediate_level_settled(last, r, target, &settled))
        return settled;
      // Progress is measured against the test itself, so that a component far from its own target
      // counts as progress while the largest residual stays put.
      const double distance = distance_to_target(r, target);
      if (distance < 0.99 * best_residual_) {
        best_residual_ = distance;
        best_iteration_ = iteration_;
      }
      if (answer_at_tolerance(last, r, target, &settled)) return settled;
      if (last && refined_at_round_off(r, target)) continue;
    }
    if (stalled_at_round_off(r, target) || reached_max_iterations(r, target) || diverged(r)) return false;
    previous_comp_residual_.assign(ctx_.comp_residual.begin(), ctx_.comp_residual.end());
    StepOutcome outcome = method_.iterate(ctx_, iteration_ + 1);
    if (refined_after_stall(outcome)) continue;
    if (step_failed(outcome, last, r, target, &settled)) return settled;
    times_pending_ = false;
    std::swap(ctx_.q, ctx_.q_next);
    partition_.iterate_changed(ctx_);
    if (!outcome.next_evaluated) {
      ctx_.evaluated = Evaluated::nothing;
      ctx_.action_known = false;
    }
    step_evaluated = outcome.next_evaluated;
    ++iteration_;
    ++level_.level_it;
    ++level_.since_clock;
  }
}

/** Under a clock: whether the node times fail to increase (the model's clock is <= 0, or not
 *  finite, on an interval). At the start (the guess or a resumed iterate) that is invalid input;
 *  later the iterate has left the region where the clock is positive, and the solve ends diverged.
 *  Either way nothing is called converged with time running backwards. */
bool Iteration::times_stop_increasing() {
  int bad = -1;
  for (int k = 0; k < ctx_.N && bad < 0; ++k)
    if (!(ctx_.t[static_cast<std::size_t>(k) + 1] > ctx_.t[static_cast<std::size_t>(k)])) bad = k;
  if (partition_.all(bad < 0)) return false;
  std::string where = "on an interval";
  if (bad >= 0) {
    auto time = [](double t) { return std::isfinite(t) ? format("%.6g", t) : std::string("a value that is not finite"); };
    where = "on interval " + std::to_string(bad) + " (t = " + time(ctx_.t[static_cast<std::size_t>(bad)]) + " to " +
            time(ctx_.t[static_cast<std::size_t>(bad) + 1]) + ")";
  }
  const bool start = iteration_ == 0 && level_.level_it == 0 && !resumed_level_;
  const std::string fixed_point =
      ctx_.clock == ClockMode::free_final_time && end_times_are_fixed_points(ctx_)
          ? " (L or the clock depends on t: or no end time t1 = t0 + the clock integrated up to t1 was found on "
            "that interval, which a finer grid can change)"
          : "";
  if (start) {
    finish(Termination::invalid_input,
           "the node times do not increase " + where +
               " at the start: the model's clock (dt/ds) must be positive and finite along the path; a guess on "
               "which it is <= 0 gives no trajectory in time" + fixed_point);
  } else {
    finish(Termination::diverged,
           "the node times stopped increasing " + where + format(" at iteration %.0f", static_cast<double>(iteration_)) +
               ": the iterate left the region where the model's clock (dt/ds) is positive" + fixed_point +
               "; the iterate is returned but is no trajectory in time");
  }
  return true;
}

/** At the tolerance under a clock, `unsettled` checks of the clock's times in a row, each after a
 *  step, found the residual there above the target and not 1 % lower than its best, which is
 *  `since_best` iterations old. */
bool Iteration::times_unsettled(int unsettled, long since_best) {
  if (unsettled < kMaxPlacements || since_best < kUnsettledIterations) return false;
  finish(Termination::stalled,
         format("stalled: the node times do not settle: at the tolerance, the DEL residual at the times of the "
                "model's clock stayed above the target %.3g and came no 1%% lower in %.0f iterations and %.0f "
                "re-placements of the nodes there (the last iterate, moved to the clock's times, is returned)",
                target_residual(), static_cast<double>(since_best), static_cast<double>(unsettled)));
  return true;
}

bool Iteration::met_by_growth(double r) const {
  constexpr double kGrowthFactor = 10;
  // Against the solve's first residual and this level's (a finer level of a model of order >= 2
  // starts from larger DEL terms than the coarsest: h^(1 - 2 order)).
  return options_.tol <= 0 && have_initial_ && r > kGrowthFactor * std::max(r_initial_, level_.r_level0) &&
         !at_round_off(r, ctx_.residual_floor);
}

/** At the tolerance where the method accepts to stop (Newton not at a saddle): the last level
 *  has converged; an intermediate level of Newton's nested iteration is solved. */
bool Iteration::converged_at_tolerance(bool last, double r, double target, bool* settled) {
  // A level's start (the guess, or a coarser level's solution resampled) can have a residual below
  // the target and still a smooth error of any size: the Hessian's smallest eigenvalues are O(h),
  // so a small residual bounds only the rough part of the error. Newton takes one step on each
  // level before it stops; that step removes a smooth error.
  if (whole_system_newton(options_.method) && level_.level_it == 0) return false;
  const bool stop = at_target(r, target) && !met_by_growth(r) && method_.accept_stop(ctx_, last);
  if (!stop) return false;
  if (last) {
    finish(Termination::converged, converged_message(r, target));
    *settled = false;
    return true;
  }
  // Nested iteration: a coarse level is solved to the tolerance (quadratic convergence makes the
  // last digits cheap), so that the next level can start from a solution.
  if (!whole_system_newton(options_.method)) return false;
  *settled = true;
  return true;
}

/** A coarse level of the other methods' refinement: its residual fell by refine_settle, or it
 *  stagnates (less than 1% over 50 iterations). */
bool Iteration::intermediate_level_settled(bool last, double r, double target, bool* settled) {
  if (last || whole_system_newton(options_.method)) return false;
  *settled = true;
  if (r <= std::max(target, options_.refine_settle * level_.r_level0)) return true;
  if (level_.level_it > 0 && level_.level_it % 50 == 0) {
    if (r > 0.99 * level_.r_checkpoint) return true;
    level_.r_checkpoint = r;
  }
  *settled = false;
  return false;
}

/** At the tolerance, but the method would not stop (a saddle it tried to leave) and has found
 *  nothing better in 200 iterations: this point is the answer (the point assessment says what
 *  it is). */
bool Iteration::answer_at_tolerance(bool last, double r, double target, bool* settled) {
  if (!(at_target(r, target) && !met_by_growth(r) && iteration_ - best_iteration_ >= 200)) return false;
  *settled = !last;
  if (last) finish(Termination::converged, converged_message(r, target));
  return true;
}

/** At the round-off level of the residual and no 1% improvement in 200 iterations. */
bool Iteration::stalled_at_round_off(double r, double target) {
  if (!(at_round_off(r, ctx_.residual_floor) && iteration_ - best_iteration_ >= 200)) return false;
  if (unresolved_component() >= 0) {
    finish(Termination::stalled,
           format("stalled: the DEL residual %.3g is at the round-off level %.3g of the largest terms and no "
                  "component has come 1%% closer to its own target in 200 iterations",
                  r, ctx_.residual_floor) +
               unresolved_note());
    return true;
  }
  finish(Termination::stalled,
         format("stalled: the DEL residual %.3g is at the round-off level %.3g of this problem and has not "
                "improved in 200 iterations; tol %.3g cannot be reached in double precision",
                r, ctx_.residual_floor, target));
  return true;
}

/** On the last level of a whole-system Newton solve, with the residual at the target and at its
 *  round-off level but a component above its own target: the rounding of the double residual,
 *  which the Hessian of a model of order >= 2 amplifies like N^(2 order), is what keeps Newton from
 *  that component (an order-4 model at N = 1000 crept 800 iterations and stalled). Iterative
 *  refinement in extended precision (docs/solvers.md) runs there after 10 iterations without
 *  progress, once a level; its corrections
 *  kept, the iteration goes on from the refined iterate, which the next pass tests as any other. */
bool Iteration::refined_at_round_off(double r, double target) {
  // Only once Newton has stopped gaining there (10 iterations without coming 1% closer to the
  // test): where its next step resolves the component (min_jerk at N = 2e4), the extended
  // Hessian's refinement would only add its cost.
  if (refinements_ > 0 || !whole_system_newton(options_.method) || !(r <= target) ||
      !at_round_off(r, ctx_.residual_floor) ||
      iteration_ - best_iteration_ < 10 || unresolved_component() < 0)
    return false;
  return refine_during("where Newton stood at the round-off level with a component above its target");
}

bool Iteration::refined_after_stall(const StepOutcome& outcome) {
  // Newton stalled at the round-off level of the double residual: the extended one may still
  // show the way (a high-order Galerkin model of order 2 at N = 640 stalled 5e-7 from its motion).
  if (refinements_ >= kMaxRefinements || outcome.failure != Termination::stalled ||
      !whole_system_newton(options_.method) ||
      !at_round_off(ctx_.residual, ctx_.residual_floor))
    return false;
  return refine_during("where Newton stalled at the round-off level");
}

bool Iteration::refine_during(const std::string& where) {
  ++refinements_;
  refined_iteration_ = iteration_;
  partition_.refine(options_, s_);
  if (s_.refinement_steps == 0) return false;
  refined_note_ += std::string(refined_note_.empty() ? "" : "; ") + "in iteration " + std::to_string(iteration_) +
                   ", " + where + ": " + s_.refinement_note;
  ctx_.evaluated = Evaluated::nothing;  // evaluated again, by the method, at the refined iterate
  ctx_.action_known = false;
  method_.times_changed();  // the iterate moved outside the method: its trust-region history is void
  return true;
}

bool Iteration::reached_max_iterations(double r, double target) {
  if (iteration_ < options_.max_iterations) return false;
  finish(Termination::max_iterations, format("reached max_iterations = %.0f with DEL residual %.3g (tol %.3g)",
                                             static_cast<double>(options_.max_iterations), r, target) +
                                          (r <= target ? unresolved_note() : std::string()));
  return true;
}

bool Iteration::diverged(double r) {
  if (!(iteration_ > 0 && r_initial_ > 0 && r > options_.divergence_factor * r_initial_)) return false;
  finish(Termination::diverged,
         format("DEL residual %.3g grew beyond divergence_factor x initial residual %.3g at iteration %.0f. pardel's "
                "minimizing methods (all but stationary-newton) converge to minima of the action (docs/solvers.md); "
                "the usual causes are an action that is unbounded below along the iterates (where the DEL equations "
                "have a solution then, it is a saddle of the action, e.g. past a conjugate point: an oscillator over "
                "more than half its period; method stationary-newton converges to saddles) or no solution near the "
                "start",
                r, r_initial_, static_cast<double>(iteration_)));
  return true;
}

bool Iteration::step_failed(const StepOutcome& step, bool last, double r, double target, bool* settled) {
  StepOutcome outcome = step;
  *settled = false;
  if (!partition_.agree_on_outcome(outcome)) {
    // Newton could not leave a saddle or a degenerate point at the tolerance: it is the answer
    // (not where the times at the tolerance were found unsettled: r is not at the clock's times).
    // (A stall may have measured the round-off level above the estimate: the target is taken again.)
    const double now = std::max(target, target_residual());
    // A level below the last that stalls at its round-off level is solved as well as double
    // precision allows: the next level starts from it (an order-4 model under galerkin_gauss(s=5)
    // at N = 1000 stopped on its level N = 250 and returned it interpolated, 6e-2 off).
    if (outcome.failure == Termination::stalled && !last && at_round_off(r, ctx_.residual_floor) && !times_pending_) {
      *settled = true;
      return true;
    }
    if (outcome.failure == Termination::stalled && at_target(r, now) && !met_by_growth(r) && !times_pending_) {
      *settled = !last;
      if (last) finish(Termination::converged, converged_message(r, now));
      return true;
    }
    finish(outcome.failure, outcome.message);
    return true;
  }
  int node = -1;
  double qmax = 0;
  partition_.check_next(ctx_, outcome, &node, &qmax);
  if (node >= 0) {
    finish(Termination::non_finite, "non-finite value at node " + std::to_string(node) + " in iteration " +
                                        std::to_string(iteration_ + 1) + "; the last finite iterate is returned");
    return true;
  }
  if (qmax > kExplodedIterate) {
    finish(Termination::diverged, format("iterates exploded (max |q| = %.3g) in iteration %.0f", qmax,
                                         static_cast<double>(iteration_ + 1)));
    return true;
  }
  return false;
}

double Iteration::component_target(int i) const {
  // The rounding of the start's terms resolves a component only once the iteration cannot reduce
  // its residual any more (it fell less than tenfold in the last step on this level): a component
  // far from its solution at the start (a guess 1e10 times off in a coordinate of small units)
  // has a large start scale while its equations are still far from holding, and Newton's next
  // step would resolve them.
  const std::size_t ii = static_cast<std::size_t>(i);
  const bool stopped_falling = ii < start_scale_.size() && ii < previous_comp_residual_.size() &&
                               !(ctx_.comp_residual[ii] < 0.1 * previous_comp_residual_[ii]);
  return detail::component_target(options_, ctx_, i, stopped_falling ? start_scale_[ii] : 0.0);
}

int Iteration::unresolved_component() const {
  const int d = static_cast<int>(ctx_.comp_residual.size());
  for (int i = 0; i < d; ++i)
    if (!(ctx_.comp_residual[static_cast<std::size_t>(i)] <= component_target(i))) return i;
  return -1;
}

double Iteration::distance_to_target(double r, double target) const {
  auto ratio = [](double a, double b) {
    if (a == 0) return 0.0;
    return b > 0 ? a / b : std::numeric_limits<double>::infinity();
  };
  double distance = ratio(r, target);
  const int d = static_cast<int>(ctx_.comp_residual.size());
  for (int i = 0; i < d; ++i)
    distance = std::max(distance, ratio(ctx_.comp_residual[static_cast<std::size_t>(i)], component_target(i)));
  return distance;
}

std::string Iteration::unresolved_note() const {
  const int i = unresolved_component();
  if (i < 0) return std::string();
  const std::size_t ii = static_cast<std::size_t>(i);
  return "; component " + component_name(ctx_, i) +
         format("'s equations are resolved only to %.3g, above its own target %.3g (its terms are of size %.3g): "
                "the solve is not converged",
                ctx_.comp_residual[ii], component_target(i), ctx_.comp_scale[ii]);
}

bool Iteration::non_finite_residual(int node) {
  std::string msg =
      "non-finite DEL residual at node " + std::to_string(node) + " in iteration " + std::to_string(iteration_);
  if (iteration_ > 0) {
    std::swap(ctx_.q, ctx_.q_next);  // back to the last finite iterate
    partition_.iterate_changed(ctx_);
    ctx_.evaluated = Evaluated::nothing;
    ctx_.action_known = false;
    ctx_.residual = last_good_residual_;
    msg += "; the last finite iterate (iteration " + std::to_string(iteration_ - 1) + ") is returned";
    --iteration_;
  } else {
    msg += " (the initial guess)";
  }
  msg += ": a kernel of the intervals next to it returned a value that is not finite (L is not finite there, or, "
         "for a Galerkin discretization with interior values, the interval's interior Newton iteration did not "
         "converge; more intervals or a closer guess help)";
  finish(Termination::non_finite, msg);
  return false;
}

std::string Iteration::converged_message(double r, double target) const {
  if (options_.tol > 0) return format("DEL residual %.3g <= tol %.3g", r, target);
  std::string message = format(
      "DEL residual %.3g <= %.3g = max(rtol x scale of the DEL terms %.3g, 10 x round-off level)", r, target,
      ctx_.residual_scale);
  // Where the round-off level sets the target far above rtol, say how little the equations are resolved.
  const double relative = ctx_.residual_scale > 0 ? target / ctx_.residual_scale : 0;
  if (relative >= 1)
    message += format("; the round-off level dominates: at this N the target it sets is %.2g times the DEL terms' "
                      "scale, so the residual does not show that the DEL equations hold (the point note says how "
                      "far round-off can move the trajectory); a smaller N resolves them",
                      relative);
  else if (relative > kRoundOffDominates * options_.rtol)
    message += format("; the round-off level dominates: at this N the DEL equations are resolved only to %.2g of "
                      "their scale (rtol %.2g), and the answer is uncertain accordingly; a smaller N resolves them "
                      "better",
                      relative, options_.rtol);
  return message + measured_note();
}

std::string Iteration::measured_note() const {
  if (ctx_.comp_floor_measured.empty()) return {};
  return format("; the round-off level was measured where Newton stalled (the residual's change when the "
                "iterate moves by a few units in its last place): %.3g, where the terms' sizes gave less (an "
                "evaluation that amplifies rounding, as the elimination of high-order interior values does)",
                ctx_.residual_floor);
}

bool Iteration::should_record() {
  if (iteration_ < next_record_) return false;
  next_record_ = next_history_record(iteration_, options_.history_every, s_.history.size());
  return true;
}

bool Iteration::record() {
  IterationRecord rec;
  rec.iteration = iteration_;
  rec.N = partition_.global_N(ctx_);
  rec.residual = ctx_.residual;
  if (!ctx_.action_known) {
    ctx_.action = partition_.action(ctx_);
    ctx_.action_known = true;
  }
  rec.action = ctx_.action;
  rec.seconds = seconds();
  s_.history.push_back(rec);
  const bool go_on = options_.on_iteration ? options_.on_iteration(rec) : true;
  return partition_.all(go_on);
}

void Iteration::finish(Termination termination, std::string message) {
  s_.termination = termination;
  s_.message = std::move(message);
}

void Iteration::summarize() {
  s_.N = partition_.global_N(ctx_);
  s_.iterations = iteration_;
  s_.residual = ctx_.residual;
  s_.action = ctx_.action_known ? ctx_.action : partition_.action(ctx_);
  if (s_.termination == Termination::converged && std::isnan(s_.action)) {
    // The DEL equations hold (their derivatives are finite), but the discrete Lagrangian is NaN
    // somewhere along the path (log(x) at a node with x < 0): no discrete problem is solved. (An
    // infinite action can come from a fixed end alone, 1/x with x(0) = 0, whose singular terms
    // do not enter the equations of the unknowns; at an unknown they make the residual infinite.)
    s_.termination = Termination::non_finite;
    s_.message = "the DEL residual meets the tolerance, but the discrete action is NaN at this iterate: the path "
                 "leaves the domain of L (an interval where the discrete Lagrangian is not a number), so it solves "
                 "no discrete problem (" + s_.message + ")";
  }
  s_.final_time = partition_.final_time(ctx_);
  s_.residual_floor = ctx_.residual_floor;
  s_.residual_at_round_off = residual_at_round_off(ctx_);
  s_.tolerance = target_residual();
  if (s_.history.empty() || s_.history.back().iteration != iteration_ || s_.history.back().N != s_.N) {
    IterationRecord rec;
    rec.iteration = iteration_;
    rec.N = s_.N;
    rec.residual = s_.residual;
    rec.action = s_.action;
    rec.seconds = seconds();
    s_.history.push_back(rec);
    // The callback sees every record of the history, this last one too (the solve has ended:
    // what it returns changes nothing).
    if (options_.on_iteration) (void)options_.on_iteration(rec);
  }
  s_.wall_seconds = seconds();
}

void Iteration::capture_counters(SolverState& st) const {
  st.valid = true;
  st.method = options_.method;
  st.iteration = iteration_;
  st.level_iteration = level_.level_it;
  st.since_clock_update = level_.since_clock;
  st.next_record = next_record_;
  st.best_iteration = best_iteration_;
  st.have_initial_residual = have_initial_;
  st.initial_residual = r_initial_;
  st.last_good_residual = last_good_residual_;
  st.best_residual = best_residual_;
  st.level_initial_residual = level_.r_level0;
  st.level_checkpoint_residual = level_.r_checkpoint;
  st.seconds = seconds();
  st.history = s_.history;
  st.component_start_scale = start_scale_;
  st.component_previous_residual = previous_comp_residual_;
}

void Iteration::continue_count(const SolverState& st) {
  iteration_ = st.iteration;
  next_record_ = st.next_record;
  best_iteration_ = st.iteration;
  r_initial_ = st.initial_residual;
  have_initial_ = st.have_initial_residual;
  s_.history = st.history;
  start_scale_ = st.component_start_scale;
  start_ -= steady_seconds(st.seconds);
}

void Iteration::resume_counters(const SolverState& st) {
  continue_count(st);
  best_iteration_ = st.best_iteration;
  last_good_residual_ = st.last_good_residual;
  best_residual_ = st.best_residual;
  level_ = LevelCounters{st.level_iteration, st.since_clock_update, st.level_initial_residual,
                         st.level_checkpoint_residual};
  previous_comp_residual_ = st.component_previous_residual;
  resumed_level_ = true;
}

}  // namespace pardel::detail
