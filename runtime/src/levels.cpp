/**
 * @file levels.cpp
 * The grid levels shared by the one-process and the distributed solve (levels.hpp): refinement
 * and grid-sequencing levels, nested iteration's extrapolated start, and resuming an interrupted
 * solve: the checks of its state (the Iteration's counters are captured and restored in
 * iteration.cpp).
 */
#include "constants.hpp"
#include "levels.hpp"

#include <algorithm>
#include <cmath>

#include "engine.hpp"
#include "invariant.hpp"

namespace pardel::detail {

bool knots_on_grid(const Problem& problem, int n) {
  if (!problem.times.empty()) {  // a given grid: only its own N, each knot at one of its times
    if (n != problem.N) return false;
    for (std::size_t a = 0; a < problem.knots.size(); ++a)
      if (knot_node(problem, a, n, nullptr) < 0) return false;
    return true;
  }
  for (const Knot& knot : problem.knots) {
    const double s = (knot.t - problem.t0) / problem.T * n;
    const long k = std::lround(s);
    if (std::fabs(s - static_cast<double>(k)) > 1e-9 * std::max(1.0, std::fabs(s)) || k <= 0 || k >= n) return false;
  }
  return true;
}

std::vector<int> automatic_levels(const Problem& problem) {
  std::vector<int> down{problem.N};
  int n = problem.N;
  while (n > kAutoRatio * kAutoCoarseN) {
    int next = (n + kAutoRatio - 1) / kAutoRatio;
    while (next < n && !knots_on_grid(problem, next)) ++next;
    if (next >= n) break;
    down.push_back(next);
    n = next;
  }
  return std::vector<int>(down.rbegin(), down.rend());
}

namespace {

/** refinement_levels before its invariants are checked. */
std::vector<int> unchecked_levels(const Problem& problem, const Options& options, bool automatic) {
  std::vector<int> levels;
  const int N = problem.N;
  if (!problem.times.empty()) return {N};  // a given non-uniform grid has no coarser levels
  if (automatic && options.refine_start_N <= 0) return automatic_levels(problem);
  if (options.refine_start_N <= 0 || options.refine_start_N >= N) return {N};
  int n = options.refine_start_N;
  while (n < N && !knots_on_grid(problem, n)) ++n;
  while (n < N) {
    levels.push_back(n);
    int next = std::max(n + 1, static_cast<int>(std::ceil(n * options.refine_factor)));
    while (next < N && !knots_on_grid(problem, next)) ++next;
    n = next;
  }
  levels.push_back(N);
  return levels;
}

}  // namespace

std::vector<int> refinement_levels(const Problem& problem, const Options& options, bool automatic) {
  const std::vector<int> levels = unchecked_levels(problem, options, automatic);
  for (std::size_t l = 1; l < levels.size(); ++l)
    PARDEL_INVARIANT(levels[l - 1] < levels[l], "refinement levels grow from coarse to fine");
  PARDEL_INVARIANT(!levels.empty() && levels.back() == problem.N, "the last refinement level is the problem's grid");
  return levels;
}

Options resolved_options(const Options& requested, const Problem& problem, Summary& summary) {
  Options options = requested;
  if (options.method == Method::automatic) options.method = Method::newton;
  summary.method = options.method;
  summary.N = problem.N;
  summary.threads = resolve_threads(options.threads);
  return options;
}

long run_levels(const std::vector<int>& levels, std::size_t first, const SolverState* resume,
                const SolverState* warm, const LevelSteps& steps) {
  std::size_t l = first;
  if (warm)  // the first level at or above the state's N
    while (l + 1 < levels.size() && levels[l] < warm->N) ++l;
  const std::size_t first_level = l;
  for (l = resume ? static_cast<std::size_t>(resume->level) : l; l < levels.size(); ++l) {
    const bool last = l + 1 == levels.size();
    bool entered;
    if (resume && l == static_cast<std::size_t>(resume->level))
      entered = steps.resume();
    else if (warm && l == first_level)
      entered = steps.warm(levels[l]);
    else
      entered = steps.enter(levels[l]);
    if (!entered) return -1;
    if (steps.entered) steps.entered(last);
    if (!steps.run(last) || last) break;
    steps.settled();
  }
  return static_cast<long>(l);
}

Trajectory extrapolated_start(const Problem& problem, const Trajectory& coarse, const Trajectory& coarser, int N) {
  PARDEL_INVARIANT(coarser.N < coarse.N && coarse.N < N, "nested iteration extrapolates from two coarser grids");
  // The extrapolation at the coarse level's nodes, then one resampling to N: the correction
  // (q_c - q_cc) is smooth, and the fine grid, four times the coarse one, is resampled once.
  Trajectory start = resample(problem, coarser, coarse.N);
  const double p = problem.discretization->consistency_order;
  const double hf = std::pow(1.0 / N, p), hc = std::pow(1.0 / coarse.N, p), hcc = std::pow(1.0 / coarser.N, p);
  const double w = (hf - hc) / (hc - hcc);
  for (std::size_t i = 0; i < start.q.size(); ++i) start.q[i] = coarse.q[i] + w * (coarse.q[i] - start.q[i]);
  start.t = coarse.t;
  return resample(problem, start, N);
}

void note_stopped_level(const Problem& problem, Trajectory& trajectory, Summary& summary) {
  const int reached = trajectory.N;
  if (summary.termination == Termination::converged || reached == problem.N || reached < 1) return;
  // Over MPI ranks only rank 0 holds the gathered trajectory; every rank says the same.
  if (!trajectory.q.empty()) trajectory = resample(problem, trajectory, problem.N);
  summary.N = problem.N;
  summary.message += " (stopped at the refinement level N = " + std::to_string(reached) +
                     "; the trajectory returned is that level's iterate interpolated to the requested N = " +
                     std::to_string(problem.N) + ")";
}

namespace {

/** The state's iterate fits the problem at its N and is finite. */
bool check_iterate(const Problem& problem, const SolverState& st, std::string* error) {
  auto bad = [&](const std::string& msg) {
    *error = "resume: " + msg;
    return false;
  };
  if (st.N < 1) return bad("the saved grid has N = " + std::to_string(st.N));
  Problem at_level = problem;
  at_level.N = st.N;
  std::string why;
  if (!validate(at_level, st.trajectory, &why)) return bad("the saved trajectory does not fit the problem: " + why);
  for (double v : st.trajectory.q)
    if (!std::isfinite(v)) return bad("the saved trajectory has a non-finite value");
  for (double v : st.trajectory.t)
    if (!std::isfinite(v)) return bad("the saved node times have a non-finite value");
  if (st.iteration < 0 || st.next_record < 0) return bad("negative iteration counters");
  if (!(st.seconds >= 0 && st.seconds < 1e12)) return bad("the recorded wall time is not a duration in seconds");
  return true;
}

}  // namespace

bool check_state(const Problem& problem, const Options& options, const SolverState& st, const std::vector<int>& levels,
                 std::string* error) {
  auto bad = [&](const std::string& msg) {
    *error = "resume: " + msg;
    return false;
  };
  if (!st.valid) return bad("the solver state is empty (not captured from an interrupted solve)");
  if (options.warm_start) return check_iterate(problem, st, error);
  if (st.method != options.method)
    return bad(std::string("the state is of method ") + to_string(st.method) + ", the options ask for " +
               to_string(options.method) + " (a warm start continues from its iterate with another method)");
  if (st.level < 0 || st.level >= static_cast<int>(levels.size()) || levels[static_cast<std::size_t>(st.level)] != st.N)
    return bad("refinement level " + std::to_string(st.level) + " with N = " + std::to_string(st.N) +
               " is not a level of this problem and options (grid.N " + std::to_string(problem.N) + ", " +
               std::to_string(levels.size()) + " level(s) from N = " + std::to_string(levels.front()) + ")");
  if (st.iteration < 0 || st.level_iteration < 0 || st.level_iteration > st.iteration || st.since_clock_update < 0 ||
      st.next_record < 0 || st.best_iteration < 0 || st.best_iteration > st.iteration)
    return bad("inconsistent iteration counters (iteration " + std::to_string(st.iteration) + ", at this level " +
               std::to_string(st.level_iteration) + ")");
  if (!check_iterate(problem, st, error)) return false;
  std::string why;
  if (st.previous_level.N > 0) {
    Problem previous = problem;
    previous.N = st.previous_level.N;
    if (!validate(previous, st.previous_level, &why))
      return bad("the saved solution of the previous refinement level does not fit the problem: " + why);
  }
  return true;
}

std::string method_state_misfit(const SolverState& st) {
  return "resume: the solver state of method " + std::string(to_string(st.method)) + " has " +
         std::to_string(st.method_state.size()) + " values that do not fit it";
}

void note_warm_start(const SolverState& warm, Summary& summary) {
  summary.message += std::string(" (warm start from iteration ") + std::to_string(warm.iteration) + " of " +
                     to_string(warm.method) + " at N = " + std::to_string(warm.N) + ")";
}

}  // namespace pardel::detail
