// Solving a scene in one process or over the ranks of an MPI run (see solve.hpp).
#include "pardel/app/solve.hpp"

#include "pardel/distributed.hpp"
#include "pardel/mpi_session.hpp"

namespace pardel::app {

Summary solve_scene(const Scene& scene, Trajectory& trajectory) {
  if (mpi::world_size() > 1) return mpi::solve_distributed(scene.problem, scene.options, trajectory);
  return solve(scene.problem, scene.options, trajectory);
}

}  // namespace pardel::app
