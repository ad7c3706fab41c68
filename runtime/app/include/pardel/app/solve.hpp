/**
 * @file distributed_solve.hpp
 * `pardel solve` under mpirun with more than one rank: the domain-decomposed solve of
 * pardel/distributed.hpp, with rank 0 alone writing the outputs and reporting.
 */
#ifndef PARDEL_CLI_DISTRIBUTED_SOLVE_HPP
#define PARDEL_CLI_DISTRIBUTED_SOLVE_HPP

#include <string>

#include "pardel/pardel.hpp"
#include "scene.hpp"

namespace pardel::cli {

struct DistributedSolveOutput {
  std::string out_dir;  ///< the output folder (already created)
  bool quiet = false;   ///< no progress line and no report
  bool plot = true;     ///< draw trajectory.png and convergence.png
};

/**
 * Solves the scene over all ranks of the MPI run (every rank calls it with the same scene and
 * initial guess). Rank 0 gathers the trajectory and writes summary.json (with "ranks"),
 * trajectory.csv, convergence.csv and the plots, and prints the report; the other ranks write and
 * print nothing. Returns the exit code of `pardel solve`, the same on every rank.
 */
int run_distributed_solve(Scene& scene, Trajectory& trajectory, const DistributedSolveOutput& output);

}  // namespace pardel::cli

#endif  // PARDEL_CLI_DISTRIBUTED_SOLVE_HPP
