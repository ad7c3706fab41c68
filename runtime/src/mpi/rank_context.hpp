/**
 * @file rank_context.hpp
 * Internals of the solve over MPI ranks: what a rank holds (its layout, its local context with
 * one halo node per neighbour, the true constraint pattern of its nodes), how it is set up from a
 * whole trajectory, gathered back, and the reductions of the residual and the action over the
 * ranks (rank_context.cpp), and the node times under a clock (rank_times.cpp).
 */
#ifndef PARDEL_RUNTIME_MPI_RANK_CONTEXT_HPP
#define PARDEL_RUNTIME_MPI_RANK_CONTEXT_HPP

#include <mpi.h>

#include <string>
#include <vector>

#include "../engine.hpp"
#include "decomposition.hpp"

namespace pardel::mpi::detail {

using pardel::detail::Context;

/** Everything a rank holds: its layout, its local context and the true constraint pattern of its
 *  nodes (the context marks the halo nodes fixed; `global_free` says which of their components are
 *  unknowns of the whole problem). */
struct Local {
  Layout layout;
  MPI_Comm comm = MPI_COMM_WORLD;
  Context ctx;
  std::vector<unsigned char> global_free;  ///< (hi-lo+1)*dim
  std::vector<double> interval_scratch;    ///< one value per owned interval
  int u0 = 0, u1 = -1;                     ///< owned unknown nodes (global), u0 >= 1, u1 <= N-1
  std::vector<double> reduce_buffer;       ///< the residual reduction's in and out (globalize_residual)

  int owned_intervals() const { return layout.last_interval() - layout.first_interval() + 1; }
  int owned_unknowns() const { return u1 - u0 + 1; }
};

/** Builds the local context of `local.layout` (a grid of N intervals, a level of the solve) from
 *  the full initial guess on that grid; false with `message` for a knot off the grid (the same
 *  test and text as the one-process constraints). */
bool setup_local(const Problem& problem, int N, int threads, const Trajectory& guess, Local& local,
                 std::string* message);

/** The owned nodes' values of `values`, an array in the local node layout with `per_node` values
 *  a node, in node order over all ranks ((N+1) per_node values): in `out` on every rank
 *  (`everywhere`) or on rank 0 alone, the other ranks' `out` emptied. Collective. */
void gather_nodes(const Local& local, const double* values, int per_node, bool everywhere, std::vector<double>& out);

/** The whole iterate of the current level and its node times in `out`, from the owned nodes of
 *  every rank: on every rank (`everywhere`) or on rank 0 alone, the other ranks' `out` emptied.
 *  Collective. */
void gather_trajectory(const Local& local, bool everywhere, Trajectory& out);

/** The discrete action at the local iterate through the action kernel, summed in node order over all ranks. */
double global_action(Local& local, const std::vector<double>& q);

/** The sum of the Ld array over the owned intervals in node order over all ranks (after a full or grad evaluation). */
double global_sum_Ld(const Local& local);

/** Residual of the whole problem after a local evaluation: the lowest global node with a
 *  non-finite residual (or -1), with ctx.residual and ctx.residual_floor set to the global values. */
int globalize_residual(Local& local, int local_bad);

/** The one-process check that the Lagrangian is regular (assessment.hpp lagrangian_regular) at the
 *  current iterate and node times of the ranks: made on rank 0 from the whole level gathered
 *  there (for the length of the check), its verdict and message sent to every rank. Collective. */
bool lagrangian_regular_over_ranks(const Problem& problem, const Local& local, std::string* message);

/** Node times from the model's clock over the ranks (rank_times.cpp): engine.cpp's update_times,
 *  the same bit for bit. Collective. */
void update_times_distributed(Local& local, pardel::detail::Positions positions);

}  // namespace pardel::mpi::detail

#endif  // PARDEL_RUNTIME_MPI_RANK_CONTEXT_HPP
