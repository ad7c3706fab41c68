/**
 * @file solve.cpp
 * The solve over a topology (topology.hpp: one process, or MPI ranks), for every method, written
 * once: the method factory, validation, the loop over the levels of coarse-to-fine refinement
 * (levels.hpp: which grids, where each starts), resume and warm starts, the result and the point
 * assessment, around the iteration at each level (iteration.hpp: node-time updates, stopping
 * rules, history); the automatic method's second attempt, and the error estimate of a converged
 * solve (error_estimate.hpp: Richardson against a coarser nested grid, checked over a third).
 * A method only supplies evaluate/iterate; pardel::solve is this solve over OneProcess.
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
#include "extended_assessment.hpp"
#include "iteration.hpp"
#include "iterative_refinement.hpp"
#include "levels.hpp"
#include "methods.hpp"
#include "topology.hpp"

namespace pardel {
namespace detail {

std::unique_ptr<Method_> make_method(const Options& options, int dim, Topology& topology, std::string* message) {
  const MethodRow* row = method_row(options.method);
  if (!row) {
    *message = "unknown method";
    return nullptr;
  }
  return row->make(options, dim, topology, message);
}

}  // namespace detail

namespace {

using detail::Context;
using detail::Topology;
using detail::TopologyFactory;

/** A solve over a topology: the levels of refinement, resume, capture and the result around the
 *  iteration at each level (iteration.hpp). A level's context is the topology's. */
class Driver : public detail::Iteration {
 public:
  Driver(const Problem& problem, const Options& options, detail::Method_& method, Topology& topology,
         Summary& summary)
      : detail::Iteration(options, method, topology, topology.context(), summary),
        problem_(problem),
        topology_(topology) {}

  /** Sets up the level of N intervals from `from` (resampled to N when it lies on another grid);
   *  false with the summary filled on bad constraints or a Lagrangian that is not regular. */
  bool enter_level(const Trajectory& from, int N) {
    const Trajectory& src = from.N == N ? from : (resampled_ = resample(problem_, from, N));
    std::string message;
    const bool set = topology_.set_up(problem_, N, s_.threads, src, &message);
    resampled_ = Trajectory{};
    if (!set) return refuse(std::move(message));
    if (problem_.clock != ClockMode::none) partition_.update_times(ctx_, detail::Positions::follow_times);
    if (!checked_regular_) {
      checked_regular_ = true;
      if (!topology_.lagrangian_regular(problem_, &message)) return refuse(std::move(message));
    }
    method_.reset(ctx_);
    return true;
  }

  /** Sets up the level of an interrupted solve's state (checked by check_state) instead of
   *  enter_level: the iterate, its node times, the method's state and every counter. */
  bool resume_level(const SolverState& st) {
    std::string message;
    if (!topology_.set_up_resumed(problem_, st, s_.threads, &message)) return refuse("resume: " + message);
    method_.reset(ctx_);
    if (!partition_.all(method_.load_state(st.method_state))) return refuse(detail::method_state_misfit(st));
    resume_counters(st);
    checked_regular_ = true;
    return true;
  }

  /** Everything resume_level needs, at the current iterate (after an interruption): the iterate
   *  and its node times from `result` (which write_result gathered), the method's state in node
   *  order; on the process that holds the result (the others' `st` stays empty). Collective. */
  void capture(SolverState& st, int level, const Trajectory& result) {
    std::vector<double> method_state = method_.save_state();
    if (!topology_.holds_result()) return;
    capture_counters(st);
    st.level = level;
    st.N = result.N;
    st.trajectory = result;
    st.method_state = std::move(method_state);
  }

  /** The summary's numbers (the same on every process) and the iterate of the current level,
   *  gathered where the result is held. Collective. */
  void write_result(Trajectory& out) {
    topology_.gather(false, out);
    summarize();
  }

 private:
  bool refuse(std::string message) {
    s_.termination = Termination::invalid_input;
    s_.message = std::move(message);
    return false;
  }

  const Problem& problem_;
  Topology& topology_;
  Trajectory resampled_;
  bool checked_regular_ = false;
};

/** The last two grid levels below problem.N that a converged whole-system Newton solve solved to
 *  the tolerance, the finer first (N = 0: none), for the error estimate. */
struct SolvedLevels {
  Trajectory below, further;
  /** The Newton correction at the returned iterate (Summary::solve_error), the unknowns of nodes
   *  1..N-1; empty where not computed. The estimate compares the corrected iterate. */
  std::vector<double> correction;
};

/** What a solve_once does besides solving. */
struct OnceFlags {
  bool assess = true;      ///< assess the converged point (Summary::point)
  bool one_level = false;  ///< solve on problem.N alone, without refinement levels or grid sequencing
  /** When given: filled with the solve's levels (left empty where there are none). */
  SolvedLevels* coarser_levels = nullptr;
};

/** The input checks of a solve of `requested` (resolved into `options`), the levels it visits
 *  (refinement_levels, or problem.N alone) and the index of the first that fits the topology; false with `error` (the same verdict on every
 *  process: a process refuses when any does). */
bool check_input(const Problem& problem, const Options& requested, const Options& options,
                 const Trajectory& trajectory, const OnceFlags& flags, Topology& topology, std::vector<int>& levels,
                 std::size_t& first, std::string* error) {
  // The automatic method is Newton with grid sequencing (refinement_levels), and so is the
  // stationary Newton.
  const bool automatic = requested.method == Method::automatic || requested.method == Method::stationary_newton;
  const SolverState* state = options.resume_from;
  *error = topology.unsupported(problem, options);
  bool valid = error->empty() && options.is_valid(error) && (state || validate(problem, trajectory, error));
  if (valid) levels = flags.one_level ? std::vector<int>{problem.N} : detail::refinement_levels(problem, options, automatic);
  first = static_cast<std::size_t>(
      std::find_if(levels.begin(), levels.end(), [&](int n) { return topology.level_fits(n); }) - levels.begin());
  if (valid && state) valid = detail::check_state(problem, options, *state, levels, error);
  if (valid && state && !options.warm_start && static_cast<std::size_t>(state->level) < first) {
    valid = false;
    *error = "resume: refinement level " + std::to_string(state->level) + " with N = " + std::to_string(state->N) +
             topology.level_misfit();
  }
  // Every process was given the same input; agree anyway, so that none iterates alone.
  if (topology.all(valid)) return true;
  if (valid) *error = "invalid input on another rank";
  return false;
}

/** The point of a finished solve: from the method's own factorization where it holds one (Newton
 *  stopped at a minimum), else from a new one, the method's storage released first so as not to
 *  add to the peak memory. */
void assess_point(const Options& options, const OnceFlags& flags, std::unique_ptr<detail::Method_>& method,
                  Topology& topology, Summary& summary) {
  // The one-process assessment polls Options::keep_going; the assessment over ranks does not (one
  // rank alone must not leave a collective).
  topology.context().keep_going = options.keep_going;
  if (!flags.assess) {
    summary.point.note = "not assessed";
  } else if (!detail::point_assessed(summary.termination)) {
    summary.point = detail::not_assessed(summary.termination);
  } else {
    const auto start = std::chrono::steady_clock::now();
    const double on_levels = method->level_assessment_seconds();  // its preparation on coarse levels
    if (!method->assess(topology.context(), summary.point)) {
      method.reset();
      topology.assess(options, summary.point);
    }
    // Where double precision cannot tell the point's kind (order >= 2 on fine grids), in extended.
    const bool extended = detail::beyond_double(summary.point) && topology.assess_extended(summary.point);
    // Under a discretization with interior values the action's own inertia adds theirs.
    const pardel_discretization* disc = topology.context().disc;
    if (disc && disc->interior_size > 0) {
      detail::Inertia interior;
      topology.interior_inertia(interior);
      detail::add_interior_inertia(interior, summary.point);
    }
    summary.assessment_seconds =
        on_levels + std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!extended || summary.point.kind == PointKind::degenerate)  // no saddle caveat of double precision
      detail::note_residual_caveats(summary.residual, summary.residual_floor, topology.context().residual_scale,
                                    summary.point);
  }
}

/** One solve with the requested method over a fresh topology of `make` (solve_over may make two,
 *  and a third for the error estimate). */
Summary solve_once(const Problem& problem, const Options& requested, Trajectory& trajectory, const OnceFlags& flags,
                   const TopologyFactory& make) {
  const auto start = std::chrono::steady_clock::now();
  Summary summary;
  const Options options = detail::resolved_options(requested, problem, summary);
  auto finished = [&] {
    summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return summary;
  };
  const std::unique_ptr<Topology> topology = make();
  const SolverState* resume = options.resume_from;
  const SolverState* warm = resume && options.warm_start ? resume : nullptr;
  if (warm) resume = nullptr;
  std::vector<int> levels;
  std::size_t first = 0;
  std::string error;
  std::unique_ptr<detail::Method_> method;
  if (check_input(problem, requested, options, trajectory, flags, *topology, levels, first, &error))
    method = detail::make_method(options, problem.model->dim, *topology, &error);
  if (!method) {
    summary.termination = Termination::invalid_input;
    summary.message = error;
    return finished();
  }
  Driver driver(problem, options, *method, *topology, summary);
  topology->reserve(levels.back());
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
  steps.entered = [&](bool last) {
    if (!last || !topology->releases_whole_trajectories()) return;
    // From here on a process holds its share of the nodes; the one that holds the result keeps
    // the previous level's solution that an interruption's state carries for Newton's extrapolation.
    std::vector<double>().swap(trajectory.q);
    std::vector<double>().swap(trajectory.t);
    Trajectory previous = std::move(starts.previous());
    starts.release();
    if (topology->holds_result() && starts.extrapolates()) starts.previous() = std::move(previous);
  };
  steps.run = [&](bool last) { return driver.run_level(last); };
  Trajectory further;  // the level before the previous one, for the error estimate's third level
  steps.settled = [&] {
    // The level's solution on every process: the start of the next level.
    Trajectory solution;
    topology->gather(true, solution);
    if (flags.coarser_levels && (!topology->releases_whole_trajectories() || topology->holds_result()))
      further = starts.previous();
    starts.settled(std::move(solution));
  };
  const long l = detail::run_levels(levels, first, resume, warm, steps);
  if (l < 0) return finished();
  if (summary.converged() && !driver.refined()) {
    topology->refine(options, summary);
    if (!driver.refined_note().empty())
      summary.refinement_note = driver.refined_note() + (summary.refinement_note.empty()
                                                              ? std::string()
                                                              : "; at the converged point: " + summary.refinement_note);
  } else if (!driver.refined_note().empty()) {
    summary.refinement_note = driver.refined_note();
  }
  driver.write_result(trajectory);
  if (summary.termination == Termination::interrupted) {
    driver.capture(summary.state, static_cast<int>(l), trajectory);
    if (topology->holds_result() && starts.extrapolates()) summary.state.previous_level = starts.previous();
  }
  // Nested iteration's levels below N were solved to the tolerance (a coarse level of the other
  // methods' refinement only settled): the last of them can serve the error estimate. Not where
  // iterative refinement corrected this level: the levels were not refined, and their round-off
  // (growing like eps N^(2 order)) would enter the estimate; it solves its coarse grids itself.
  const bool refined = summary.refinement_steps > 0 || !driver.refined_note().empty();
  if (flags.coarser_levels && summary.converged() && levels.size() >= 2 && !refined &&
      detail::whole_system_newton(options.method)) {
    flags.coarser_levels->below = std::move(starts.previous());
    flags.coarser_levels->further = std::move(further);
  }
  // The solve's own error (Summary::solve_error), one process: from the method's factorization
  // at the answer before the assessment uses it (Newton at a minimum), else from a factorization
  // of its own after the method's storage is released.
  const bool solve_error = flags.assess && options.error_estimate && summary.converged() &&
                           !topology->releases_whole_trajectories();
  std::vector<double> delta;
  if (solve_error) detail::extend_residual(topology->context());  // its right-hand side, where refinement has one
  bool corrected = solve_error && method->newton_correction(topology->context(), delta);
  assess_point(options, flags, method, *topology, summary);
  if (solve_error && !corrected) {
    method.reset();
    corrected = detail::newton_correction(topology->context(), delta);
  }
  if (corrected) {
    detail::record_solve_error(delta, topology->context().dim, problem.model->ncoords, summary);
    if (problem.clock == ClockMode::free_final_time && std::isfinite(summary.solve_error))
      summary.solve_time_error = detail::time_shift(topology->context(), delta);
    if (flags.coarser_levels) flags.coarser_levels->correction = std::move(delta);
  }
  finished();
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

/** The minimizing Newton failed numerically (neither converged, interrupted nor refused), and not
 *  by stalling with its residual at the round-off level: such an iterate solves the DEL equations
 *  as well as double precision can, and a second attempt would reach no smaller tolerance. */
bool failed_numerically(const Summary& first) {
  switch (first.termination) {
    case Termination::stalled: return !first.residual_at_round_off;
    case Termination::diverged:
    case Termination::non_finite:
    case Termination::max_iterations: return true;
    default: return false;
  }
}

/** A later attempt that converged, as the summary of both: its result and point, the iterations
 *  and history of both (its own numbered on from the first's), the total time. */
Summary after(Summary first, Summary second) {
  for (IterationRecord rec : second.history) {
    rec.iteration += first.iterations;
    rec.seconds += first.wall_seconds;
    first.history.push_back(rec);
  }
  second.history = std::move(first.history);
  second.iterations += first.iterations;
  second.wall_seconds += first.wall_seconds;
  return second;
}

/** A later attempt (`what`) that `keep_going` interrupted: the solve ends interrupted with that
 *  attempt's iterate, the history of both and the first attempt's outcome in the message. No
 *  state is kept: a resume with the requested options would not continue that attempt. */
Summary interrupted_after(Summary first, Summary later, const std::string& what) {
  const std::string first_outcome = std::string(to_string(first.termination)) + ": " + first.message;
  Summary both = after(std::move(first), std::move(later));
  both.state = SolverState{};
  both.message += " during " + what + ", the automatic method's attempt after the first ended " + first_outcome +
                  "; not resumable (no checkpoint): a later attempt is not continued by a resume, its iterate can "
                  "start a new solve";
  return both;
}

/** `options` for an attempt after `first`: Options::on_iteration sees its iterations numbered on
 *  from the first's, with the first's time added, as the history has them (after()). */
Options numbered_after(Options options, const Summary& first) {
  if (options.on_iteration)
    options.on_iteration = [inner = options.on_iteration, offset = first.iterations,
                            seconds = first.wall_seconds](const IterationRecord& record) {
      IterationRecord shifted = record;
      shifted.iteration += offset;
      shifted.seconds += seconds;
      return inner(shifted);
    };
  return options;
}

/** The automatic method's two attempts as one summary: the second's as after() where it
 *  converged or was interrupted (interrupted_after), else the first's; the message says what
 *  happened to the first or the second. */
Summary combined(Summary first, Summary second) {
  const std::string first_outcome = std::string(to_string(first.termination)) + ": " + first.message;
  if (second.termination == Termination::interrupted)
    return interrupted_after(std::move(first), std::move(second),
                             "Newton on the DEL residual (stationary-newton) from the same start");
  if (second.termination != Termination::converged) {
    first.message += std::string("; then Newton on the DEL residual (stationary-newton), which also converges to "
                                 "saddles of the action, from the same start ended ") +
                     to_string(second.termination) + ": " + second.message;
    first.wall_seconds += second.wall_seconds;
    return first;
  }
  Summary both = after(std::move(first), std::move(second));
  both.message += " by Newton on the DEL residual (stationary-newton), after the minimizing Newton found no "
                  "minimum of the action near the start (" + first_outcome + ")";
  return both;
}

/** The automatic method's minimizing Newton in the kinetic metric (newton_shift = difference)
 *  stalled far above the round-off level on the problem's own grid: no step decreased the action
 *  even at a vanishing radius, which coordinates in units far apart cause as well as a model that
 *  is not smooth there. It is retried from where it stopped in the identity metric, whose steps
 *  along the stiff coordinates are not tied to the soft ones'. */
bool retries_in_identity_metric(const Problem& problem, const Options& requested, const Summary& first,
                                const Trajectory& trajectory) {
  return requested.method == Method::automatic && !requested.resume_from &&
         requested.newton_shift == NewtonShift::difference && first.termination == Termination::stalled &&
         !first.residual_at_round_off && trajectory.N == problem.N;
}

/** How a later attempt of the automatic method is named in the solve's message. */
struct LaterAttempt {
  std::string what;       ///< "a retry from there in the identity metric (...)": where it ended or was interrupted
  std::string converged;  ///< appended to its own message where it converged, before "(first outcome)"
};

/** A later attempt with `options` from `start` after `first`: its result as after() where it
 *  converged or was interrupted (trajectory then its iterate), else `first` with the attempt's
 *  outcome in the message. */
Summary later_attempt(const Problem& problem, const Options& options, Summary first, Trajectory start,
                      Trajectory& trajectory, const OnceFlags& flags, const TopologyFactory& make,
                      const LaterAttempt& named) {
  Summary again = solve_once(problem, numbered_after(options, first), start, flags, make);
  if (again.termination == Termination::interrupted) {
    trajectory = std::move(start);
    return interrupted_after(std::move(first), std::move(again), named.what);
  }
  if (again.termination != Termination::converged) {
    first.message += "; " + named.what + " ended " + to_string(again.termination) + ": " + again.message;
    first.wall_seconds += again.wall_seconds;
    return first;
  }
  const std::string first_outcome = std::string(to_string(first.termination)) + ": " + first.message;
  trajectory = std::move(start);
  Summary both = after(std::move(first), std::move(again));
  both.message += named.converged + " (" + first_outcome + ")";
  return both;
}

/** `first`, or where retries_in_identity_metric() its retry from where it stopped (later_attempt;
 *  a retry that fails leaves the first attempt's iterate). */
Summary with_identity_retry(const Problem& problem, const Options& requested, Summary first, Trajectory& trajectory,
                            const OnceFlags& flags, const TopologyFactory& make) {
  if (!retries_in_identity_metric(problem, requested, first, trajectory)) return first;
  Options options = requested;
  options.newton_shift = NewtonShift::identity;
  const Trajectory from = trajectory;
  return later_attempt(problem, options, std::move(first), from, trajectory, flags, make,
                       {"a retry from there in the identity metric (newton_shift = identity)",
                        " in the identity metric (newton_shift = identity), retried from where the minimizing "
                        "Newton in the kinetic metric stopped"});
}

/** The automatic method's attempts all stalled with the residual at the round-off level of the
 *  largest DEL terms but a component far above its own (a coordinate whose terms are too small
 *  against the others' for the action or the residual's norm to show its steps: L = x'^2/2 +
 *  1e-14 (y'^2/2 + 9.81 cos y)). */
bool needs_node_steps(const Options& requested, const Summary& attempts) {
  return requested.method == Method::automatic && !requested.resume_from &&
         attempts.termination == Termination::stalled && detail::at_round_off(attempts.residual, attempts.residual_floor) &&
         !attempts.residual_at_round_off;
}

/** `attempts`, or where needs_node_steps() the seed's Jacobi-Newton from the start `guess`, whose
 *  node steps are in each coordinate's own units (later_attempt). */
Summary with_node_steps(const Problem& problem, const Options& requested, Summary attempts, const Trajectory& guess,
                        Trajectory& trajectory, const OnceFlags& flags, const TopologyFactory& make) {
  if (!needs_node_steps(requested, attempts)) return attempts;
  Options options = requested;
  options.method = Method::jacobi_newton;
  // Its sweeps needed about N^2 / 2.4 on the problems measured (1865 at N = 64, 27788 at N = 256):
  // a budget of 4 N^2 sweeps (at least 20000), and at most 10^8 node updates (about 20 s at
  // 0.2 us a node), keeps an attempt the user did not ask for from running to max_iterations
  // where it does not converge.
  const long n = std::max(1L, static_cast<long>(problem.N));
  const long budget = std::min(std::max(20000L, 4 * n * n), std::max(1L, 100000000L / n));
  options.max_iterations = std::min(requested.max_iterations, budget);
  const std::string what = "Jacobi-Newton from the same start (node steps in each coordinate's own units)";
  return later_attempt(problem, options, std::move(attempts), guess, trajectory, flags, make,
                       {what,
                        " by " + what + ", after the Newton methods stalled with a component's residual far above "
                        "its own round-off level"});
}

/** The solve without the error estimate: the automatic method minimizes first; where no minimum
 *  is found near the start and a saddle would do, Newton on the DEL residual tries again from the
 *  same start, where the topology runs it (where not, the message says why the second attempt was
 *  not made). *coarser_levels: as OnceFlags::coarser_levels, of the attempt whose result is returned. */
Summary solve_attempts(const Problem& problem, const Options& requested, Trajectory& trajectory,
                       SolvedLevels* coarser_levels, const TopologyFactory& make) {
  OnceFlags flags;
  flags.coarser_levels = coarser_levels;
  // The start of a later attempt (the automatic method's, which keeps the iterate it returns).
  const Trajectory guess = requested.method == Method::automatic ? trajectory : Trajectory{};
  auto nodes_after = [&](Summary attempts) {
    return with_node_steps(problem, requested, std::move(attempts), guess, trajectory, flags, make);
  };
  if (!saddles_answer(problem, requested))
    return nodes_after(with_identity_retry(problem, requested, solve_once(problem, requested, trajectory, flags, make),
                                           trajectory, flags, make));
  Options options = requested;
  options.method = Method::stationary_newton;
  const std::string refusal = make()->unsupported(problem, options);
  if (!refusal.empty()) {
    Summary first =
        with_identity_retry(problem, requested, solve_once(problem, requested, trajectory, flags, make), trajectory,
                            flags, make);
    if (failed_numerically(first))
      first.message += "; Newton on the DEL residual (stationary-newton), the automatic method's second attempt "
                       "for a model without a declared cost, was not made: " + refusal;
    return nodes_after(std::move(first));
  }
  Summary first =
      with_identity_retry(problem, requested, solve_once(problem, requested, trajectory, flags, make), trajectory,
                          flags, make);
  if (!failed_numerically(first)) return first;
  Trajectory second_trajectory = guess;
  Summary second = solve_once(problem, numbered_after(options, first), second_trajectory, flags, make);
  if (second.termination == Termination::converged || second.termination == Termination::interrupted)
    trajectory = std::move(second_trajectory);
  return nodes_after(combined(std::move(first), std::move(second)));
}

/** The grid of every ratio-th node of `problem`'s (its times where it has given ones). */
Problem coarser_problem(const Problem& problem, int ratio) {
  Problem coarse = problem;
  coarse.N = problem.N / ratio;
  if (!problem.times.empty()) {
    coarse.times.resize(static_cast<std::size_t>(coarse.N) + 1);
    for (int m = 0; m <= coarse.N; ++m)
      coarse.times[static_cast<std::size_t>(m)] = problem.times[static_cast<std::size_t>(ratio * m)];
  }
  return coarse;
}

/** A solve on every other node of `fine_problem`'s grid, started from `fine`'s values there, into
 *  `coarse`: the method that converged (`method`) and the requested options, but one grid, no
 *  assessment and no estimate of its own; Options::keep_going interrupts it. */
Summary solve_every_other_node(const Problem& fine_problem, const Trajectory& fine, const Options& requested,
                               Method method, const TopologyFactory& make, Trajectory& coarse) {
  const Problem coarse_problem = coarser_problem(fine_problem, 2);
  coarse = detail::every_other_node(fine, 2);
  Options options = requested;
  options.method = method;  // the method that converged (auto resolved, or its second attempt)
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
  return solve_once(coarse_problem, options, coarse, flags, make);
}

/** Why the solve on a coarse grid failed, for a note. */
std::string coarse_failure(const Summary& coarse_summary, int N) {
  const std::string grid = "N = " + std::to_string(N);
  return coarse_summary.termination == Termination::interrupted
             ? "interrupted during the solve on the coarse grid " + grid
             : "the solve on the coarse grid " + grid + " ended " + to_string(coarse_summary.termination) + ": " +
                   coarse_summary.message;
}

std::string solved_in(int N, long iterations) {
  return "N = " + std::to_string(N) + " solved from the solution's values there in " + std::to_string(iterations) +
         " iteration" + (iterations == 1 ? "" : "s");
}

/** The third level for the estimate against `coarse` (every ratio-th node of `problem`'s grid): one
 *  of the solve's own levels where it is nested in `coarse`, else a solve on every other node of
 *  `coarse` where that grid allows it; appends to `how` how it was had. */
detail::ThirdLevel third_level(const Problem& problem, const Options& requested, Method method,
                               const SolvedLevels& levels, const Trajectory& coarse, int ratio,
                               const TopologyFactory& make, const std::string& no_solve, Trajectory& solved,
                               std::string& how) {
  detail::ThirdLevel third;
  for (const Trajectory* level : {&levels.below, &levels.further})
    if (level != &coarse && detail::nested_level(problem, coarse, *level, &third.ratio)) {
      third.level = level;
      how += "; N = " + std::to_string(level->N) + " is another grid level the solve had solved";
      return third;
    }
  if (!no_solve.empty()) {
    third.why_not = no_solve;
    return third;
  }
  const Problem coarse_problem = coarser_problem(problem, ratio);
  third.why_not = detail::coarse_grid_refusal(coarse_problem);
  if (!third.why_not.empty()) return third;
  const Summary s = solve_every_other_node(coarse_problem, coarse, requested, method, make, solved);
  if (!s.converged()) {
    third.why_not = coarse_failure(s, solved.N);
    return third;
  }
  third.level = &solved;
  third.ratio = 2;
  how += "; " + solved_in(solved.N, s.iterations);
  return third;
}

/**
 * The error estimate of a converged solve against its coarse grid: Richardson against the solve's
 * own coarser grid level where it is nested node for node in the final grid, otherwise (where the
 * topology makes solves of its own: `no_solve` empty) against a solve on every other node of the
 * final grid, started from the solution there; checked by the order observed over a third,
 * coarser level (third_level).
 */
void estimate_against_coarse(const Problem& problem, const Options& requested, const SolvedLevels& levels,
                             const std::string& no_solve, Trajectory& trajectory, Summary& summary,
                             const TopologyFactory& make) {
  int ratio = 0;
  std::string how;
  Trajectory solved;
  const Trajectory* coarse = &levels.below;
  if (detail::nested_level(problem, trajectory, levels.below, &ratio)) {
    how = "; N = " + std::to_string(levels.below.N) + " is a grid level the solve had solved to the tolerance";
  } else {
    if (!no_solve.empty())
      return detail::not_estimated(summary, "no grid level of the solve lies on every r-th node of N = " +
                                                std::to_string(problem.N) + ", and " + no_solve);
    const std::string refusal = detail::coarse_grid_refusal(problem);
    if (!refusal.empty()) return detail::not_estimated(summary, refusal);
    const Summary s = solve_every_other_node(problem, trajectory, requested, summary.method, make, solved);
    if (!s.converged()) return detail::not_estimated(summary, coarse_failure(s, solved.N));
    coarse = &solved;
    ratio = 2;
    how = "; " + solved_in(solved.N, s.iterations);
  }
  Trajectory third_solved;
  const detail::ThirdLevel third =
      third_level(problem, requested, summary.method, levels, *coarse, ratio, make, no_solve, third_solved, how);
  if (levels.correction.empty()) {
    detail::richardson(problem, *coarse, ratio, third, requested.extrapolate, trajectory, summary);
  } else {
    // Richardson's difference of the iterate plus its Newton correction, the discrete solution to
    // first order: the tolerance's share of the error, added after (include_solve_error), would
    // otherwise also enter the difference and the order observed.
    Trajectory corrected = trajectory;
    const std::size_t offset = static_cast<std::size_t>(corrected.dim);
    for (std::size_t i = 0; i < levels.correction.size() && offset + i < corrected.q.size(); ++i)
      corrected.q[offset + i] += levels.correction[i];
    detail::richardson(problem, *coarse, ratio, third, requested.extrapolate, corrected, summary);
    if (summary.extrapolated) trajectory = std::move(corrected);
  }
  summary.error_note += how;
}

/**
 * The error estimate of a converged solve (Options::error_estimate; docs/solvers.md, "Error
 * estimate"), made where the result is held (every process in one, rank 0 over ranks) and shared
 * with the others; its time is added to wall_seconds. Collective.
 */
void estimate_error(const Problem& problem, const Options& requested, const SolvedLevels& levels,
                    Trajectory& trajectory, Summary& summary, const TopologyFactory& make) {
  if (!requested.error_estimate) return detail::not_estimated(summary, "switched off (error_estimate = false)");
  if (!summary.converged())
    return detail::not_estimated(summary, std::string("the solve ended ") + to_string(summary.termination));
  if (problem.N < 4) return detail::not_estimated(summary, "N = " + std::to_string(problem.N) + " is below 4");
  // The clock's node times are a left rule, of first order: between two grids their shift at the
  // common nodes dominates the difference of the coordinates there (by 60 to 10^7 times the true
  // error at the nodes' times, measured on an oscillator with a Sundman clock).
  if (problem.clock == ClockMode::fixed_total_time)
    return detail::not_estimated(summary, "under the fixed_total_time clock the grids place their common nodes at "
                                          "other times (a first-order rule), so their difference is not the error");
  const std::unique_ptr<detail::Topology> topology = make();
  const std::string no_solve = topology->coarse_solve_refusal();
  const auto start = std::chrono::steady_clock::now();
  if (no_solve.empty() || topology->holds_result()) {
    estimate_against_coarse(problem, requested, levels, no_solve, trajectory, summary, make);
    detail::include_solve_error(summary);
  }
  summary.error_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!no_solve.empty()) topology->share_estimate(summary);
  summary.wall_seconds += summary.error_seconds;
}

}  // namespace

namespace detail {

Summary solve_over(const Problem& problem, const Options& requested, Trajectory& trajectory,
                   const TopologyFactory& make) {
  SolvedLevels levels;
  Summary summary = solve_attempts(problem, requested, trajectory, &levels, make);
  estimate_error(problem, requested, levels, trajectory, summary, make);
  // Richardson's rule assumes an error C h^p with C independent of h; along the soft direction of
  // a nearly degenerate minimum the solutions of different grids move by more than that.
  if (std::isfinite(summary.error_estimate) && summary.point.nearly_degenerate)
    summary.error_note +=
        "; caution: the point is a nearly degenerate minimum, whose trajectory is loosely determined, and the "
        "estimate can be far below the error";
  return summary;
}

}  // namespace detail

Summary solve(const Problem& problem, const Options& requested, Trajectory& trajectory) {
  if (requested.device != Device::cpu) return detail::solve_on_device(problem, requested, trajectory);
  if (requested.accuracy > 0) return detail::solve_adaptive(problem, requested, trajectory);
  return detail::solve_over(problem, requested, trajectory, [] { return std::make_unique<detail::OneProcess>(); });
}

double residual_norm(const Problem& problem, const Trajectory& trajectory) {
  Context ctx;
  std::string error;
  if (!detail::context_at(problem, trajectory, 1, ctx, &error)) return std::numeric_limits<double>::quiet_NaN();
  detail::eval_grad(ctx, ctx.q);
  if (detail::compute_residual(ctx) >= 0) return std::numeric_limits<double>::quiet_NaN();
  return ctx.residual;
}

std::vector<double> grid_times(const Problem& problem, int N) {
  Problem on_its_grid = problem;
  on_its_grid.N = N;
  std::string error;
  if (problem.clock != ClockMode::none || N < 1 || !problem.model || !problem.discretization ||
      !validate(on_its_grid, linear_guess(on_its_grid), &error))
    return {};
  detail::Grid grid;
  detail::setup_grid(on_its_grid, N, 1, grid);
  return grid.t;
}

double discrete_action(const Problem& problem, const Trajectory& trajectory) {
  Context ctx;
  std::string error;
  if (!detail::context_at(problem, trajectory, 1, ctx, &error)) return std::numeric_limits<double>::quiet_NaN();
  return detail::action_at(ctx, ctx.q);
}

}  // namespace pardel
