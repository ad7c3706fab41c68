/**
 * @file solve.hpp
 * Solving a scene: pardel::solve in one process, and under mpirun with more than one rank the
 * domain-decomposed solve of pardel/distributed.hpp over all ranks (a build without MPI is one
 * rank of one), so that a front end needs no branch of its own for either.
 */
#ifndef PARDEL_APP_SOLVE_HPP
#define PARDEL_APP_SOLVE_HPP

#include "pardel/app/scene.hpp"
#include "pardel/pardel.hpp"

namespace pardel::app {

/**
 * Solves the scene's problem with its options, from `trajectory` (the initial guess; on return the
 * solve's trajectory). With pardel::mpi::world_size() > 1, every rank calls it with the same scene
 * and guess; the nodes are split into contiguous ranges, one per rank, and the trajectory is
 * gathered on rank 0 (the other ranks get an empty one, N and dim set); the summary is the same
 * on every rank (pardel::mpi::solve_distributed).
 */
Summary solve_scene(const Scene& scene, Trajectory& trajectory);

}  // namespace pardel::app

#endif  // PARDEL_APP_SOLVE_HPP
