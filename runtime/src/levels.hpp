/**
 * @file levels.hpp
 * Internal: the grid levels of a solve (solve.cpp, over any topology: one process or MPI ranks,
 * topology.hpp): which grids coarse-to-fine refinement and the
 * automatic method's grid sequencing visit, and where each level after the first starts (the
 * previous level's solution, or Newton's extrapolation from the two previous levels), and the
 * checks and counters of resuming an interrupted solve at a level (SolverState).
 */
#ifndef PARDEL_RUNTIME_LEVELS_HPP
#define PARDEL_RUNTIME_LEVELS_HPP

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "constants.hpp"
#include "methods.hpp"
#include "pardel/pardel.hpp"

namespace pardel::detail {

/** The catalogue's whole_system_newton of `method` (methods.hpp): nested iteration solves each
 *  coarse level to the tolerance, and each level takes a step before it stops. */
inline bool whole_system_newton(Method method) {
  const MethodRow* row = method_row(method);
  return row && row->whole_system_newton;
}

/** Whether every knot lies on an interior node of the uniform grid with n intervals. */
bool knots_on_grid(const Problem& problem, int n);

/** Grid sequencing of the automatic method: N, N/4, N/16, ... (each rounded up to a grid that
 *  holds the knots) down to between kAutoCoarseN and kAutoRatio kAutoCoarseN, coarsest first;
 *  {N} when N <= kAutoRatio kAutoCoarseN. */
std::vector<int> automatic_levels(const Problem& problem);

/** Grid sizes of coarse-to-fine refinement (Options::refine_start_N, refine_factor; with
 *  `automatic` and no refine_start_N, automatic_levels), coarsest first, ending at problem.N. */
std::vector<int> refinement_levels(const Problem& problem, const Options& options, bool automatic);

/**
 * The start of a finer level of nested iteration: the two previous levels' solutions extrapolated
 * in h = T/N under the discretization's error model q(h) = q* + C h^p, i.e.
 * q_N = q_c + (q_c - q_cc) (h^p - h_c^p) / (h_c^p - h_cc^p), at the nodes of the coarse level (q_cc
 * resampled there), then resampled to N. Fixed values (boundaries, knots) agree on every level and
 * stay exact.
 */
Trajectory extrapolated_start(const Problem& problem, const Trajectory& coarse, const Trajectory& coarser, int N);

/**
 * The solutions of the levels settled so far (the last two) and the start of the next level
 * from them. Newton's nested iteration starts a level from the extrapolation of the solutions of
 * the two levels before it (both converged to tol); not under a clock, whose node times differ
 * per level; every other level starts from the previous level's solution, the first from the guess.
 */
class LevelStarts {
 public:
  LevelStarts(const Problem& problem, const Options& options)
      : problem_(problem), extrapolate_(whole_system_newton(options.method) && problem.clock == ClockMode::none) {}

  /** Whether a level starts from the extrapolation of the two before it (Newton without a clock). */
  bool extrapolates() const { return extrapolate_; }

  /** Returns enter(start, N) with the start of the level with N intervals: `guess` while no level
   *  has settled, then the previous level's solution or the extrapolation. An extrapolated start
   *  lives only for the call. */
  template <class Enter>
  bool enter(const Trajectory& guess, int N, Enter&& enter) const {
    if (previous_.N == 0) return enter(guess, N);
    if (extrapolate_ && coarser_.N > 0 && previous_.N > coarser_.N)
      return enter(extrapolated_start(problem_, previous_, coarser_, N), N);
    return enter(previous_, N);
  }

  /** A level has settled with this solution (on its grid, with its node times). */
  void settled(Trajectory solution) {
    coarser_ = std::move(previous_);
    previous_ = std::move(solution);
  }

  /** The previous level's solution (N = 0: none); a resumed solve restores it. */
  Trajectory& previous() { return previous_; }

  /** Releases both solutions (once the last level has been entered). */
  void release() {
    previous_ = Trajectory{};
    coarser_ = Trajectory{};
  }

 private:
  const Problem& problem_;
  bool extrapolate_;
  Trajectory previous_, coarser_;  // solutions of levels l-1 and l-2 (N = 0: none)
};

/** The options a solve runs with, the automatic method resolved to Newton (whose grid sequencing
 *  refinement_levels gives), and the summary's method, N and threads set from them. */
Options resolved_options(const Options& requested, const Problem& problem, Summary& summary);

/** What a solve does at each level (solve.cpp's, over its topology; see run_levels). */
struct LevelSteps {
  std::function<bool()> resume;             ///< enter the resumed state's level
  std::function<bool(int N)> warm;          ///< enter a warm start's first level, with its counts
  std::function<bool(int N)> enter;         ///< enter a level from its start (LevelStarts)
  std::function<void(bool last)> entered;   ///< after a level was entered (may be empty)
  std::function<bool(bool last)> run;       ///< iterate on it: whether it settled
  std::function<void()> settled;            ///< keep a settled level's solution for the next
};

/**
 * The loop over the levels of a solve: from the resumed state's level, or a warm start's first
 * level at or above its N (from `first` on), or `first`, each level is entered and run; a level
 * that settles below the last one is kept and the next entered. Returns the index of the level
 * where the iteration ended, or -1 when a level could not be entered.
 */
long run_levels(const std::vector<int>& levels, std::size_t first, const SolverState* resume,
                const SolverState* warm, const LevelSteps& steps);

/** A solve that did not converge and stopped at a refinement level below problem.N: its
 *  trajectory (that level's iterate) is interpolated to the requested grid, so that the result
 *  has the shape asked for, and the message says so (nothing when the level is problem.N). */
void note_stopped_level(const Problem& problem, Trajectory& trajectory, Summary& summary);

// ---- resuming an interrupted solve (Options::resume_from, warm_start), in one process or over ranks

/** Checks an interrupted solve's state against the problem, the options and `levels` (the
 *  one-process levels, refinement_levels): false with `error` ("resume: ...") if it does not fit. */
bool check_state(const Problem& problem, const Options& options, const SolverState& st, const std::vector<int>& levels,
                 std::string* error);

/** The message of a method state that Method_::load_state refused. */
std::string method_state_misfit(const SolverState& st);

/** Appends to a warm start's summary from which state it started. */
void note_warm_start(const SolverState& warm, Summary& summary);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_LEVELS_HPP
