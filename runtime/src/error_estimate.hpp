/**
 * @file error_estimate.hpp
 * Internal: Richardson's estimate of the discretization error of a converged solve
 * (Options::error_estimate, Summary::error_estimate) from the solution on a coarser nested grid,
 * and the Richardson-extrapolated node values (Options::extrapolate). solve.cpp makes the coarse
 * solve (and a third, coarser one that checks the order the error falls with); this part decides
 * which coarse grid can be used and compares the solutions.
 */
#ifndef PARDEL_RUNTIME_ERROR_ESTIMATE_HPP
#define PARDEL_RUNTIME_ERROR_ESTIMATE_HPP

#include <string>
#include <vector>

#include "pardel/pardel.hpp"

namespace pardel::detail {

/** The time of node m of the grid level `level`: its own where it has node times, else uniform
 *  over `problem`'s span. */
double level_time(const Problem& problem, const Trajectory& level, int m);

/** How close a node's time must be to a fixed time (an end, a knot) to be that time:
 *  1e-9 max(1, |T|). */
double time_tolerance(const Problem& problem);

/** Why a converged solve on problem.N cannot be compared with a solve on the grid of every other
 *  node (N < 4, N odd, a knot on an odd node); "" when it can. */
std::string coarse_grid_refusal(const Problem& problem);

/** The nodes 0, ratio, 2 ratio, ... of `fine` (with their times): a trajectory on fine.N / ratio
 *  intervals (fine.N a multiple of ratio). */
Trajectory every_other_node(const Trajectory& fine, int ratio);

/** Whether `coarse` (a converged grid level of the same solve) lies on every ratio-th node of
 *  `fine`: fine.N = ratio * coarse.N with ratio >= 2 and, without a clock, the same node times
 *  there. On true, *ratio is set. */
bool nested_level(const Problem& problem, const Trajectory& fine, const Trajectory& coarse, int* ratio);

/** A third grid level for the check of the observed order: `level` lies on every ratio-th node of
 *  the coarse grid; where there is none, `level` is null and `why_not` says why. */
struct ThirdLevel {
  const Trajectory* level = nullptr;
  int ratio = 0;
  std::string why_not;
};

/**
 * Richardson's estimate from the converged solutions on the fine grid and on every ratio-th of its
 * nodes: e_k = (x_fine,k - x_coarse,k/ratio) / (ratio^p - 1) at the common nodes over the
 * coordinates (the first ncoords components of a node), p the discretization's consistency order,
 * checked against `third`: where the error falls from the third level to the fine one with an
 * observed order too low for that p to give an estimate within a factor 3 of the error, the
 * estimate uses the observed order (clamped to [1, p]) and is marked unreliable. Fills
 * summary.error_estimate (max |e|), error_by_coordinate, error_coarse_N, error_observed_order and
 * error_reliable. With `extrapolate`, replaces `fine` by the extrapolated values (every component,
 * and the node times under a clock): fine + e at the common nodes, fine + the cubic interpolation
 * of e in the node index at the others.
 */
void richardson(const Problem& problem, const Trajectory& coarse, int ratio, const ThirdLevel& third, bool extrapolate,
                Trajectory& fine, Summary& summary);

/** Summary::solve_error and solve_error_by_coordinate from the Newton correction `delta` (the
 *  unknowns of the interior nodes, dim components each, the first ncoords of them coordinates);
 *  NaN where a value is not finite. */
void record_solve_error(const std::vector<double>& delta, int dim, int ncoords, Summary& summary);

/** Adds Summary::solve_error to the estimate (where both are numbers): each coordinate's to its
 *  coordinate, the estimate their largest; and says so in the note. */
void include_solve_error(Summary& summary);

/** Marks an agreement of the grid levels to round-off where L depends on t (Summary::
 *  error_at_round_off, left unconfirmed by richardson) as confirmed by the solve on a grid of
 *  `other_N` intervals whose nodes shared by its three levels lie midway between this grid's and
 *  whose levels agree to round-off too (solve_adaptive): error_reliable, and the note says so in place of "not confirmed". */
void confirm_round_off(Summary& summary, int other_N);

/** Sets the summary's estimate to "not estimated" with the reason (`why`, after "not estimated: "). */
void not_estimated(Summary& summary, const std::string& why);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ERROR_ESTIMATE_HPP
