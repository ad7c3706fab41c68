/**
 * @file levels.cpp
 * The grid levels shared by the one-process and the distributed solve (levels.hpp): refinement
 * and grid-sequencing levels, nested iteration's extrapolated start.
 */
#include "levels.hpp"

#include <algorithm>
#include <cmath>

namespace pardel::detail {

bool knots_on_grid(const Problem& problem, int n) {
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

std::vector<int> refinement_levels(const Problem& problem, const Options& options, bool automatic) {
  std::vector<int> levels;
  const int N = problem.N;
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

Trajectory extrapolated_start(const Problem& problem, const Trajectory& coarse, const Trajectory& coarser, int N) {
  Trajectory start = resample(problem, coarse, N);
  const Trajectory other = resample(problem, coarser, N);
  const double p = problem.discretization->consistency_order;
  const double hf = std::pow(1.0 / N, p), hc = std::pow(1.0 / coarse.N, p), hcc = std::pow(1.0 / coarser.N, p);
  const double w = (hf - hc) / (hc - hcc);
  for (std::size_t i = 0; i < start.q.size(); ++i) start.q[i] += w * (start.q[i] - other.q[i]);
  return start;
}

void note_stopped_level(const Problem& problem, int reached, Summary& summary) {
  if (summary.termination != Termination::converged && reached != problem.N)
    summary.message += " (stopped at the refinement level N = " + std::to_string(reached) + ")";
}

}  // namespace pardel::detail
