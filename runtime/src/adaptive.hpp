/**
 * @file adaptive.hpp
 * Internal: the adaptive-grid solve (Options::accuracy > 0), called by pardel::solve.
 */
#ifndef PARDEL_RUNTIME_ADAPTIVE_HPP
#define PARDEL_RUNTIME_ADAPTIVE_HPP

#include "pardel/pardel.hpp"

namespace pardel::detail {

/** Solves on a sequence of grids until Richardson's estimate of the error at the nodes is at most
 *  options.accuracy (Summary::grid_sizes, grid_note); `trajectory` holds the guess on entry (on
 *  problem's grid) and the solution on the last grid, with its node times, on return. */
Summary solve_adaptive(const Problem& problem, const Options& options, Trajectory& trajectory);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ADAPTIVE_HPP
