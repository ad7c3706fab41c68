/**
 * @file solve.cpp
 * The solve in one process, for every method: validation, the loop over the levels of
 * coarse-to-fine refinement (levels.hpp: which grids, where each starts), resume and warm starts,
 * the result and the point assessment, around the iteration at each level (iteration.hpp:
 * node-time updates, stopping rules, history). A method only supplies evaluate/iterate.
 */
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "assessment.hpp"
#include "engine.hpp"
#include "iteration.hpp"
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

/** One solve with the requested method (solve() may make two). */
Summary solve_once(const Problem& problem, const Options& requested, Trajectory& trajectory) {
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
  const std::vector<int> levels = detail::refinement_levels(problem, options, automatic);
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
  driver.write_result(trajectory);
  if (summary.termination == Termination::interrupted) {
    driver.capture(summary.state, static_cast<int>(l));
    if (starts.extrapolates()) summary.state.previous_level = starts.previous();
  }
  // What the returned point is (a converged one only): from Newton's factorization at a minimum
  // where it stopped, else from a new one, the method's storage released first so as not to add
  // to the peak memory.
  driver.context().keep_going = options.keep_going;
  if (!detail::point_assessed(summary.termination)) {
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

}  // namespace

Summary solve(const Problem& problem, const Options& requested, Trajectory& trajectory) {
  // The automatic method minimizes first; where no minimum is found near the start and a saddle
  // would do, Newton on the DEL residual tries again from the same start.
  if (!saddles_answer(problem, requested)) return solve_once(problem, requested, trajectory);
  const Trajectory guess = trajectory;
  Summary first = solve_once(problem, requested, trajectory);
  if (!failed_numerically(first)) return first;
  Options options = requested;
  options.method = Method::stationary_newton;
  Trajectory second_trajectory = guess;
  Summary second = solve_once(problem, options, second_trajectory);
  if (second.termination == Termination::converged) trajectory = std::move(second_trajectory);
  return combined(std::move(first), std::move(second));
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
