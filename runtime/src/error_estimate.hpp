/**
 * @file error_estimate.hpp
 * Internal: Richardson's estimate of the discretization error of a converged solve
 * (Options::error_estimate, Summary::error_estimate) from the solution on a coarser nested grid,
 * and the Richardson-extrapolated node values (Options::extrapolate). solve.cpp makes the coarse
 * solve; this part decides which coarse grid can be used and compares the two solutions.
 */
#ifndef PARDEL_RUNTIME_ERROR_ESTIMATE_HPP
#define PARDEL_RUNTIME_ERROR_ESTIMATE_HPP

#include <string>

#include "pardel/pardel.hpp"

namespace pardel::detail {

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

/**
 * Richardson's estimate from the converged solutions on the fine grid and on every ratio-th of its
 * nodes: e_k = (x_fine,k - x_coarse,k/ratio) / (ratio^p - 1) at the common nodes, p the
 * discretization's consistency order, over the coordinates (the first ncoords components of a
 * node). Fills summary.error_estimate (max |e|), error_by_coordinate and error_coarse_N. With
 * `extrapolate`, replaces `fine` by the extrapolated values (every component, and the node times
 * under a clock): fine + e at the common nodes, fine + the cubic interpolation of e in the node
 * index at the others.
 */
void richardson(const Problem& problem, const Trajectory& coarse, int ratio, bool extrapolate, Trajectory& fine,
                Summary& summary);

/** Sets the summary's estimate to "not estimated" with the reason (`why`, after "not estimated: "). */
void not_estimated(Summary& summary, const std::string& why);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ERROR_ESTIMATE_HPP
