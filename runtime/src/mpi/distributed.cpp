/**
 * @file distributed.cpp
 * The domain-decomposed solve (distributed.hpp): pardel::solve's solve (solve.cpp, written once
 * over a topology) over the RankTopology of rank_topology.hpp. Each rank builds a solve context
 * over its own nodes plus one halo node per neighbour (the halos are fixed in that context, so the
 * seed's Jacobi methods run on it unchanged), and the iteration of iteration.hpp takes every
 * decision from values reduced over all ranks: the residual and its round-off level by max
 * (order-independent), the action by a sum in node order, failures by the lowest failing node or
 * rank. Node times under a clock are prefix sums carried from rank to rank (rank_times.cpp).
 * Newton's block-tridiagonal solves (also those of hybrid) are distributed by the
 * Schur-complement split of schur_solver.hpp (distributed_newton.cpp). The levels of
 * coarse-to-fine refinement and of the automatic method's grid sequencing are the one-process
 * solve's, from the first on which every rank owns 3 nodes: each level but the last is set up
 * from the whole start trajectory, which every rank holds, and its solution is gathered on every
 * rank to start the next; the last level releases the whole trajectory before it iterates. An
 * interrupted solve's state (SolverState) is the one-process state, gathered on rank 0; a resumed
 * state (of one process or of any number of ranks) is checked as in one process (levels.hpp) and
 * each rank sets up its own nodes at the state's level from it.
 */
#include "pardel/distributed.hpp"

#include <string>

#ifdef PARDEL_HAVE_MPI
#include <mpi.h>

#include <cstdio>
#include <exception>
#include <memory>

#include "../topology.hpp"
#include "rank_topology.hpp"
#endif

namespace pardel::mpi {

NodeRange owned_nodes(int N, int ranks, int rank) {
  const long nodes = static_cast<long>(N) + 1;
  NodeRange range;
  range.first = static_cast<int>(nodes * rank / ranks);
  range.last = static_cast<int>(nodes * (rank + 1) / ranks) - 1;
  return range;
}

namespace detail {

bool fits_ranks(int N, int ranks) { return static_cast<long>(N) + 1 >= 3L * ranks; }

}  // namespace detail

bool distributed_supported(const Problem& problem, const Options& options, int ranks, std::string* message) {
  if (ranks <= 1) return true;
  auto fail = [&](std::string text) {
    if (message) *message = std::move(text);
    return false;
  };
  if (options.method == Method::stationary_newton)
    return fail("solver.method = \"stationary-newton\" runs in one process only: its indefinite block "
                "factorization has no counterpart in the distributed Schur-complement solver (run it without "
                "mpirun, or use \"newton\" or \"auto\" over ranks)");
  if (!problem.times.empty() || options.accuracy > 0)
    return fail("a given non-uniform grid (problem.times) and an adaptive grid (grid.accuracy) run in one process "
                "only: the distributed solver places its nodes uniformly (run it without mpirun)");
  if (!detail::fits_ranks(problem.N, ranks))
    return fail("grid.N = " + std::to_string(problem.N) + " is too small for " + std::to_string(ranks) +
                " ranks: every rank needs at least 3 nodes (N + 1 >= 3 ranks)");
  return true;
}

#ifndef PARDEL_HAVE_MPI

Summary solve_distributed(const Problem& problem, const Options& options, Trajectory& trajectory) {
  return solve(problem, options, trajectory);
}

#else

Summary solve_distributed(const Problem& problem, const Options& options, Trajectory& trajectory) {
  int initialized = 0;
  MPI_Initialized(&initialized);
  int ranks = 1, rank = 0;
  if (initialized) {
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  }
  if (ranks <= 1) return solve(problem, options, trajectory);
  if (options.device != Device::cpu) {
    Summary refused;
    refused.method = options.method;
    refused.N = problem.N;
    refused.message = std::string("device ") + to_string(options.device) + ": a solve over " + std::to_string(ranks) +
                      " MPI ranks runs on their CPU cores; solve on the device in one process";
    return refused;
  }
  try {
    return pardel::detail::solve_over(problem, options, trajectory, [ranks, rank] {
      return std::make_unique<detail::RankTopology>(MPI_COMM_WORLD, ranks, rank);
    });
  } catch (const std::exception& error) {
    // A rank that cannot go on must not leave the others waiting in a collective.
    std::fprintf(stderr, "pardel: rank %d: distributed solve failed: %s; aborting all ranks\n", rank, error.what());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return Summary{};
}

#endif  // PARDEL_HAVE_MPI

}  // namespace pardel::mpi
