// Reads a scene, solves it and writes its outputs with pardel::app: a front end in a few lines
// (docs/library.md). Under mpirun the solve is spread over the ranks; rank 0 writes.
//   solve_scene SCENE.toml OUTPUT_DIR
#include <cstdio>
#include <filesystem>
#include <string>

#include "pardel/app/outputs.hpp"
#include "pardel/app/scene.hpp"
#include "pardel/app/solve.hpp"
#include "pardel/mpi_session.hpp"

int main(int argc, char** argv) {
  const pardel::mpi::Session mpi_session(&argc, &argv);
  if (argc != 3) {
    std::fprintf(stderr, "usage: solve_scene SCENE.toml OUTPUT_DIR\n");
    return 2;
  }
  try {
    // Model names resolve to the bundled models (pardel::bundled_models).
    pardel::app::Scene scene = pardel::app::load_scene(
        argv[1], {}, [](const std::string& name) { return pardel::find_model(name); });
    pardel::Trajectory trajectory;  // empty: the scene's own guess, made after the memory check
    const pardel::Summary summary = pardel::app::solve_scene(scene, trajectory);
    if (pardel::mpi::world_rank() == 0) {
      std::filesystem::create_directories(argv[2]);
      // summary.json, trajectory.csv and convergence.csv, as `pardel solve` writes them.
      pardel::app::write_solve_outputs(scene, summary, trajectory, argv[2]);
      pardel::app::print_solve_report(scene, summary, trajectory, pardel::Certificate{}, argv[2]);
    }
    return summary.converged() ? 0 : 1;
  } catch (const pardel::app::SceneError& error) {  // FILE:LINE:COL: error: ...
    std::fprintf(stderr, "%s\n", error.what());
    return 2;
  } catch (const pardel::app::MemoryRefused& error) {  // SCENE: the estimate against the machine's memory
    std::fprintf(stderr, "%s\n", error.what());
    return 2;
  } catch (const pardel::app::OutOfMemory& error) {  // ran out of memory anyway, named
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
}
