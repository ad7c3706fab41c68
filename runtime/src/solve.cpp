/**
 * @file solve.cpp
 * The solve in one process, for every method: validation, the loop over the levels of
 * coarse-to-fine refinement (levels.hpp: which grids, where each starts), resume and warm starts,
 * the result and the point assessment, around the iteration at each level (iteration.hpp:
 * node-time updates, stopping rules, history), and the error estimate of a converged solve
 * (error_estimate.hpp: Richardson against a coarser nested grid). A method only supplies
 * evaluate/iterate.
 */
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "adaptive.hpp"
#include "assessment.hpp"
#include "batch_entries.hpp"
#include "engine.hpp"
#include "error_estimate.hpp"
#include "iteration.hpp"
#include "iterative_refinement.hpp"
#include "levels.hpp"

namespace pardel {
namespace {

using detail::Context;

/** Owns the context of a one-process solve (a base, so that it exists before Iteration's). */
struct OwnedContext {
  Context owned_ctx;
  detail::OneProcess one_process;
};

/** A solve in one process: the levels of refinement, resume, capture and the result around the
 *  iteration at each level (iteration.hpp). */
class Driver : private OwnedContext, public detail::Iteration {
 public:
  Driver(const Problem& problem, const Options& options, detail::Method_& method, Summary& summary)
      : detail::Iteration(options, method, one_process, owned_ctx, summary), problem_(problem) {}

  /** Levels up to N allocate their arrays for N at once (Context::reserve_N). */
  void reserve(int N) { ctx_.reserve_N = N; }

  /** Sets up ctx_ at N from `from`; false (with the summary filled) on bad constraints. */
  bool enter_level(const Trajectory& from, int N) {
    detail::setup_context(problem_, N, s_.threads, ctx_);
    const Trajectory& src = from.N == N ? from : (resampled_ = resample(problem_, from, N));
    ctx_.q = src.q;
    const std::size_t d = static_cast<std::size_t>(ctx_.dim);
    for (std::size_t i = 0; i < d; ++i) {
      ctx_.q[i] = problem_.q0[i];
      ctx_.q[static_cast<std::size_t>(N) * d + i] = problem_.qN[i];
    }
    std::string message;
    if (!detail::apply_constraints(problem_, ctx_, &message)) {
      s_.termination = Termination::invalid_input;
      s_.message = message;
      return false;
    }
    if (problem_.clock != ClockMode::none) {
      if (src.t.size() == ctx_.t.size()) ctx_.t = src.t;
      detail::update_times(ctx_, detail::Positions::follow_times);
    }
    if (!checked_regular_) {
      checked_regular_ = true;
      if (!detail::lagrangian_regular(ctx_, &message)) {
        s_.termination = Termination::invalid_input;
        s_.message = message;
        return false;
      }
    }
    method_.reset(ctx_);
    return true;
  }

  /** Sets up ctx_ from an interrupted solve's state (checked by check_state) instead of
   *  enter_level: the iterate, its node times, the method's state and every counter. */
  bool resume_level(const SolverState& st) {
    detail::setup_context(problem_, st.N, s_.threads, ctx_);
    ctx_.q = st.trajectory.q;
    std::string message;
    if (!detail::apply_constraints(problem_, ctx_, &message)) {
      s_.termination = Termination::invalid_input;
      s_.message = "resume: " + message;
      return false;
    }
    ctx_.t = st.trajectory.t;
    if (problem_.clock == ClockMode::fixed_total_time)
      for (int k = 0; k < ctx_.N; ++k) ctx_.hk[static_cast<std::size_t>(k)] = ctx_.t[k + 1] - ctx_.t[k];
    method_.reset(ctx_);
    if (!method_.load_state(st.method_state)) {
      s_.termination = Termination::invalid_input;
      s_.message = detail::method_state_misfit(st);
      return false;
    }
    resume_counters(st);
    checked_regular_ = true;
    return true;
  }

  /** Everything resume_level needs, at the current iterate (after an interruption). */
  void capture(SolverState& st, int level) {
    capture_counters(st);
    st.level = level;
    st.N = ctx_.N;
    st.trajectory.N = ctx_.N;
    st.trajectory.dim = ctx_.dim;
    st.trajectory.t = ctx_.t;
    st.trajectory.q = ctx_.q;
    st.method_state = method_.save_state();
  }

  void write_result(Trajectory& out) {
    out.N = ctx_.N;
    out.dim = ctx_.dim;
    out.t = ctx_.t;
    out.q = ctx_.q;
    summarize();
  }

 private:
  const Problem& problem_;
  Trajectory resampled_;
  bool checked_regular_ = false;
};

std::unique_ptr<detail::Method_> make_method(const Options& options, int dim, std::string* message) {
  switch (options.method) {
    case Method::jacobi: return detail::make_jacobi(options, dim);
    case Method::jacobi_newton: return detail::make_jacobi_newton(options, dim);
    case Method::automatic:
    case Method::newton: return detail::make_newton(options, dim);
    case Method::hybrid: return detail::make_hybrid(options, dim);
    case Method::stationary_newton: return detail::make_stationary_newton(options, dim);
  }
  *message = "unknown method";
  return nullptr;
}

/** What a solve_once does besides solving. */
struct OnceFlags {
  bool assess = true;      ///< assess the converged point (Summary::point)
  bool one_level = false;  ///< solve on problem.N alone, without refinement levels or grid sequencing
  /** When given: a converged solve's whole-system Newton grid level below problem.N (solved to the
   *  tolerance), for the error estimate; left empty (N = 0) where there is none. */
  Trajectory* coarser_level = nullptr;
};

/** One solve with the requested method (solve() may make two, and a third for the error estimate). */
Summary solve_once(const Problem& problem, const Options& requested, Trajectory& trajectory,
                   const OnceFlags& flags = {}) {
  const auto start = std::chrono::steady_clock::now();
  // The automatic method is Newton with grid sequencing (refinement_levels), and so is the
  // stationary Newton.
  const bool automatic = requested.method == Method::automatic || requested.method == Method::stationary_newton;
  Summary summary;
  const Options options = detail::resolved_options(requested, problem, summary);
  std::string error;
  const SolverState* resume = options.resume_from;
  const SolverState* warm = resume && options.warm_start ? resume : nullptr;
  if (warm) resume = nullptr;
  if (!options.is_valid(&error) || (!resume && !warm && !validate(problem, trajectory, &error))) {
    summary.termination = Termination::invalid_input;
    summary.message = error;
    return summary;
  }
  std::unique_ptr<detail::Method_> method = make_method(options, problem.model->dim, &error);
  if (!method) {
    summary.termination = Termination::invalid_input;
    summary.message = error;
    return summary;
  }
  const std::vector<int> levels =
      flags.one_level ? std::vector<int>{problem.N} : detail::refinement_levels(problem, options, automatic);
  if (resume || warm) {
    if (!detail::check_state(problem, options, resume ? *resume : *warm, levels, &error)) {
      summary.termination = Termination::invalid_input;
      summary.message = error;
      return summary;
    }
  }
  Driver driver(problem, options, *method, summary);
  driver.reserve(levels.back());
  detail::LevelStarts starts(problem, options);
  if (resume) starts.previous() = resume->previous_level;
  detail::LevelSteps steps;
  steps.resume = [&] { return driver.resume_level(*resume); };
  steps.warm = [&](int N) {
    if (!driver.enter_level(warm->trajectory, N)) return false;
    driver.continue_count(*warm);
    return true;
  };
  steps.enter = [&](int N) {
    return starts.enter(trajectory, N, [&driver](const Trajectory& from, int n) { return driver.enter_level(from, n); });
  };
  steps.run = [&](bool last) { return driver.run_level(last); };
  steps.settled = [&] {
    const Context& ctx = driver.context();
    starts.settled(Trajectory{ctx.N, ctx.dim, ctx.t, ctx.q});
  };
  const long l = detail::run_levels(levels, 0, resume, warm, steps);
  if (l < 0) {
    summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return summary;
  }
  if (summary.converged()) detail::refine_solution(driver.context(), options, summary);
  driver.write_result(trajectory);
  if (summary.termination == Termination::interrupted) {
    driver.capture(summary.state, static_cast<int>(l));
    if (starts.extrapolates()) summary.state.previous_level = starts.previous();
  }
  // Nested iteration's levels below N were solved to the tolerance (a coarse level of the other
  // methods' refinement only settled): the last of them can serve the error estimate.
  if (flags.coarser_level && summary.converged() && levels.size() >= 2 && detail::whole_system_newton(options.method))
    *flags.coarser_level = std::move(starts.previous());
  // What the returned point is (a converged one only): from Newton's factorization at a minimum
  // where it stopped, else from a new one, the method's storage released first so as not to add
  // to the peak memory.
  driver.context().keep_going = options.keep_going;
  if (!flags.assess) {
    summary.point.note = "not assessed";
  } else if (!detail::point_assessed(summary.termination)) {
    summary.point = detail::not_assessed(summary.termination);
  } else if (!method->assess(driver.context(), summary.point)) {
    method.reset();
    detail::assess(driver.context(), summary.point);
  }
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  detail::note_stopped_level(problem, trajectory, summary);
  if (warm) detail::note_warm_start(*warm, summary);
  return summary;
}

/** Whether a saddle of the action is an answer to the automatic method: the model declares no cost
 *  (a mechanical system, whose motion is any DEL solution; a declared cost asks for a minimum, and
 *  a saddle of it is no answer), and the solve is a fresh one (no resumed or warm state). */
bool saddles_answer(const Problem& problem, const Options& requested) {
  return requested.method == Method::automatic && !requested.resume_from && problem.model && !problem.model->cost_name;
}

/** The minimizing Newton failed numerically (neither converged, interrupted nor refused). */
bool failed_numerically(const Summary& first) {
  switch (first.termination) {
    case Termination::diverged:
    case Termination::stalled:
    case Termination::non_finite:
    case Termination::max_iterations: return true;
    default: return false;
  }
}

/** The automatic method's two attempts as one summary: the second's result and point, the
 *  iterations and history of both (the second's numbered on from the first's), the total time,
 *  and a message that says what happened to the first. */
Summary combined(Summary first, Summary second) {
  const std::string first_outcome = std::string(to_string(first.termination)) + ": " + first.message;
  if (second.termination != Termination::converged) {
    first.message += std::string("; then Newton on the DEL residual (stationary-newton), which also converges to "
                                 "saddles of the action, from the same start ended ") +
                     to_string(second.termination) + ": " + second.message;
    first.wall_seconds += second.wall_seconds;
    return first;
  }
  for (IterationRecord rec : second.history) {
    rec.iteration += first.iterations;
    rec.seconds += first.wall_seconds;
    first.history.push_back(rec);
  }
  second.history = std::move(first.history);
  second.iterations += first.iterations;
  second.wall_seconds += first.wall_seconds;
  second.message += " by Newton on the DEL residual (stationary-newton), after the minimizing Newton found no "
                    "minimum of the action near the start (" + first_outcome + ")";
  return second;
}

/** The solve without the error estimate: the automatic method minimizes first; where no minimum
 *  is found near the start and a saddle would do, Newton on the DEL residual tries again from the
 *  same start. *coarser_level: as OnceFlags::coarser_level, of the attempt whose result is returned. */
Summary solve_attempts(const Problem& problem, const Options& requested, Trajectory& trajectory,
                       Trajectory* coarser_level) {
  OnceFlags flags;
  flags.coarser_level = coarser_level;
  if (!saddles_answer(problem, requested)) return solve_once(problem, requested, trajectory, flags);
  const Trajectory guess = trajectory;
  Summary first = solve_once(problem, requested, trajectory, flags);
  if (!failed_numerically(first)) return first;
  Options options = requested;
  options.method = Method::stationary_newton;
  Trajectory second_trajectory = guess;
  Summary second = solve_once(problem, options, second_trajectory, flags);
  if (second.termination == Termination::converged) trajectory = std::move(second_trajectory);
  return combined(std::move(first), std::move(second));
}

/**
 * The error estimate of a converged solve (Options::error_estimate; docs/solvers.md, "Error
 * estimate"): Richardson against `level`, the solve's own coarser grid level, where it is nested
 * node for node in the final grid; otherwise against a solve on every other node of the final grid,
 * started from the solution there, with the method that converged and the same options but one
 * grid, no assessment and no estimate of its own; Options::keep_going interrupts it.
 */
void estimate_error(const Problem& problem, const Options& requested, const Trajectory& level, Trajectory& trajectory,
                    Summary& summary) {
  if (!requested.error_estimate) return detail::not_estimated(summary, "switched off (error_estimate = false)");
  if (!summary.converged())
    return detail::not_estimated(summary, std::string("the solve ended ") + to_string(summary.termination));
  if (problem.N < 4) return detail::not_estimated(summary, "N = " + std::to_string(problem.N) + " is below 4");
  const auto start = std::chrono::steady_clock::now();
  auto account = [&] {
    summary.error_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    summary.wall_seconds += summary.error_seconds;
  };
  int ratio = 0;
  if (detail::nested_level(problem, trajectory, level, &ratio)) {
    detail::richardson(problem, level, ratio, requested.extrapolate, trajectory, summary);
    summary.error_note += "; N = " + std::to_string(level.N) + " is a grid level the solve had solved to the tolerance";
    return account();
  }
  const std::string refusal = detail::coarse_grid_refusal(problem);
  if (!refusal.empty()) return detail::not_estimated(summary, refusal);
  Problem coarse_problem = problem;
  coarse_problem.N = problem.N / 2;
  if (!problem.times.empty()) {  // a given grid: its every other node
    coarse_problem.times.resize(static_cast<std::size_t>(coarse_problem.N) + 1);
    for (int m = 0; m <= coarse_problem.N; ++m)
      coarse_problem.times[static_cast<std::size_t>(m)] = problem.times[static_cast<std::size_t>(2 * m)];
  }
  Trajectory coarse = detail::every_other_node(trajectory, 2);
  Options options = requested;
  options.method = summary.method;  // the method that converged (auto resolved, or its second attempt)
  options.resume_from = nullptr;
  options.warm_start = false;
  options.error_estimate = false;
  options.extrapolate = false;
  options.refine_start_N = 0;
  // The coarse solve's iterations are not the user's history: on_iteration is not called, and
  // keep_going is what can stop it.
  options.on_iteration = nullptr;
  if (requested.keep_going) {
    const std::function<bool()> keep_going = requested.keep_going;
    options.on_iteration = [keep_going](const IterationRecord&) { return keep_going(); };
  }
  OnceFlags flags;
  flags.assess = false;
  flags.one_level = true;
  const Summary coarse_summary = solve_once(coarse_problem, options, coarse, flags);
  if (!coarse_summary.converged()) {
    const std::string grid = "N = " + std::to_string(coarse_problem.N);
    detail::not_estimated(summary, coarse_summary.termination == Termination::interrupted
                                       ? "interrupted during the solve on the coarse grid " + grid
                                       : "the solve on the coarse grid " + grid + " ended " +
                                             to_string(coarse_summary.termination) + ": " + coarse_summary.message);
    return account();
  }
  detail::richardson(problem, coarse, 2, requested.extrapolate, trajectory, summary);
  summary.error_note += "; N = " + std::to_string(coarse.N) + " solved from the solution's values there in " +
                        std::to_string(coarse_summary.iterations) + " iteration" +
                        (coarse_summary.iterations == 1 ? "" : "s");
  account();
}

}  // namespace

Summary solve(const Problem& problem, const Options& requested, Trajectory& trajectory) {
  if (requested.device != Device::cpu) return detail::solve_on_device(problem, requested, trajectory);
  if (requested.accuracy > 0) return detail::solve_adaptive(problem, requested, trajectory);
  Trajectory level;
  Summary summary = solve_attempts(problem, requested, trajectory, &level);
  estimate_error(problem, requested, level, trajectory, summary);
  // Richardson's rule assumes an error C h^p with C independent of h; along the soft direction of
  // a nearly degenerate minimum the solutions of different grids move by more than that.
  if (std::isfinite(summary.error_estimate) && summary.point.nearly_degenerate)
    summary.error_note +=
        "; caution: the point is a nearly degenerate minimum, whose trajectory is loosely determined, and the "
        "estimate can be far below the error";
  return summary;
}

double residual_norm(const Problem& problem, const Trajectory& trajectory) {
  std::string error;
  if (!validate(problem, trajectory, &error) || trajectory.N != problem.N)
    return std::numeric_limits<double>::quiet_NaN();
  Context ctx;
  detail::setup_context(problem, trajectory.N, 1, ctx);
  ctx.q = trajectory.q;
  if (!detail::apply_constraints(problem, ctx, &error)) return std::numeric_limits<double>::quiet_NaN();
  ctx.q = trajectory.q;  // the trajectory as given, knots included
  if (trajectory.t.size() == ctx.t.size()) {
    ctx.t = trajectory.t;
    if (problem.clock == ClockMode::fixed_total_time)
      for (int k = 0; k < ctx.N; ++k) ctx.hk[static_cast<std::size_t>(k)] = ctx.t[k + 1] - ctx.t[k];
  }
  detail::eval_grad(ctx, ctx.q);
  if (detail::compute_residual(ctx) >= 0) return std::numeric_limits<double>::quiet_NaN();
  return ctx.residual;
}

double discrete_action(const Problem& problem, const Trajectory& trajectory) {
  std::string error;
  if (!validate(problem, trajectory, &error) || trajectory.N != problem.N)
    return std::numeric_limits<double>::quiet_NaN();
  Context ctx;
  detail::setup_context(problem, trajectory.N, 1, ctx);
  if (trajectory.t.size() == ctx.t.size()) {
    ctx.t = trajectory.t;
    if (problem.clock == ClockMode::fixed_total_time)
      for (int k = 0; k < ctx.N; ++k) ctx.hk[static_cast<std::size_t>(k)] = ctx.t[k + 1] - ctx.t[k];
  }
  return detail::action_at(ctx, trajectory.q);
}

}  // namespace pardel
