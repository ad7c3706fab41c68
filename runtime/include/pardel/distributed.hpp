/**
 * @file distributed.hpp
 * Domain-decomposed solves over MPI: the nodes 0..N are split into one contiguous range per rank
 * of MPI_COMM_WORLD; each rank keeps its range plus one halo node per neighbour, exchanges the
 * halos once per iteration and agrees with the others on every decision through reductions.
 *
 *  - jacobi and jacobi-newton give the same iterates as the one-process pardel::solve, bit for
 *    bit: the residual is a max norm (order-independent) and the action a sum in the node order
 *    (carried from rank to rank);
 *  - newton solves its block-tridiagonal systems by a Schur-complement split (each rank
 *    eliminates its interior, the P-1 interface blocks form a small block-tridiagonal system that
 *    every rank solves redundantly after an Allgather) with the globalization of the one-process
 *    Newton, so it agrees with it to the tolerance (the linear algebra differs in rounding only);
 *  - hybrid switches from Jacobi-Newton to that Newton when the distributed factorization
 *    certifies a positive definite Hessian.
 *
 * Node times under a clock (free_final_time, fixed_total_time) are prefix sums carried from rank to
 * rank, with the one-process order of additions. Without MPI in the build, or with one rank,
 * solve_distributed is pardel::solve.
 */
#ifndef PARDEL_DISTRIBUTED_HPP
#define PARDEL_DISTRIBUTED_HPP

#include <string>

#include "pardel/pardel.hpp"

namespace pardel::mpi {

/** A rank's nodes: first..last of 0..N (inclusive). */
struct NodeRange {
  int first = 0;
  int last = -1;
};

/** The contiguous range of nodes 0..N that `rank` of `ranks` owns: node k belongs to the rank r
 *  with floor(r (N+1) / ranks) <= k < floor((r+1) (N+1) / ranks). */
NodeRange owned_nodes(int N, int ranks, int rank);

/**
 * Whether solve_distributed can run this problem with these options on `ranks` ranks (always true
 * for one rank). On false, `message` names the scene key or option that cannot be distributed
 * (solver.method, or grid.N too small for the ranks). Refinement levels and the automatic
 * method's grid sequencing are distributed; levels too small for the ranks are skipped (the solve
 * starts at the first level on which every rank owns 3 nodes). A resumed state is checked by the
 * solve (a level too small for the ranks is refused there).
 */
bool distributed_supported(const Problem& problem, const Options& options, int ranks, std::string* message);

/**
 * Solves the problem over all ranks of MPI_COMM_WORLD; every rank must call it with the same
 * problem, options and initial guess (`trajectory`, on the problem's grid). Every rank holds the
 * guess and the coarser levels' solutions until the finest level starts; there they are released,
 * so a rank holds O(N / ranks) values while it iterates on the finest grid. On return rank 0
 * holds the whole final iterate in `trajectory` (gathered), the other ranks an empty trajectory
 * (N and dim set, no values); the Summary is the same on every rank. Options::on_iteration is
 * called on every rank; the solve is interrupted when it returns false on any of them.
 * Unsupported combinations end as invalid_input on every rank with the message of
 * distributed_supported; a failure on any rank (a non-finite value, a singular block) ends the
 * solve on all ranks with that status.
 */
Summary solve_distributed(const Problem& problem, const Options& options, Trajectory& trajectory);

}  // namespace pardel::mpi

#endif  // PARDEL_DISTRIBUTED_HPP
