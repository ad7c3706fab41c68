/**
 * @file decomposition.hpp
 * Internals of the distributed solve: where a rank's nodes lie in its local arrays (its owned
 * range plus one halo node per neighbour), the halo exchange, and the reductions whose results
 * do not depend on the number of ranks (max norms, sums taken in the node order).
 */
#ifndef PARDEL_RUNTIME_MPI_DECOMPOSITION_HPP
#define PARDEL_RUNTIME_MPI_DECOMPOSITION_HPP

#include <mpi.h>

#include <string>

#include "pardel/distributed.hpp"

namespace pardel::mpi::detail {

/** A rank's share of nodes 0..N: owned first..last, local arrays over nodes lo..hi (halos). */
struct Layout {
  int N = 0, ranks = 1, rank = 0;
  int first = 0, last = -1;  ///< owned nodes (global numbers)
  int lo = 0, hi = -1;       ///< local nodes: lo = first - 1 with a left neighbour, hi = last + 1 with a right one
  bool has_left() const { return rank > 0; }
  bool has_right() const { return rank + 1 < ranks; }
  int local_intervals() const { return hi - lo; }  ///< the local grid has nodes 0..local_intervals()
  int local(int global_node) const { return global_node - lo; }
  /** Intervals [k, k+1] owned by this rank: those whose left node it owns (k < N). */
  int first_interval() const { return first; }
  int last_interval() const { return last < N ? last : N - 1; }
};

Layout make_layout(int N, int ranks, int rank);

/**
 * Sends the first and last owned nodes (dim values each, node layout) to the neighbours and
 * receives their values into the halo nodes of `local` (nodes lo..hi, dim values each).
 */
void exchange_halos(const Layout& layout, double* local, int dim, MPI_Comm comm);

/**
 * The sum of values[0..n) of every rank, taken in rank order and within a rank in index order,
 * starting from 0 on rank 0: the same rounding as one sequential loop over all values. Every rank
 * receives the result. Ranks wait for their predecessor, so use it for cheap, ordered sums.
 */
double ordered_sum(const Layout& layout, const double* values, int n, MPI_Comm comm);

double max_all(double value, MPI_Comm comm);
int min_all(int value, MPI_Comm comm);
bool all_true(bool value, MPI_Comm comm);
/** `text` of rank `root` on every rank (a message all ranks report). Collective. */
void broadcast_text(std::string& text, int root, MPI_Comm comm);

}  // namespace pardel::mpi::detail

#endif  // PARDEL_RUNTIME_MPI_DECOMPOSITION_HPP
