// The package test's program for pardel::app: reads projectile.toml (the model resolved to this
// project's own kernels), solves it and writes summary.json, trajectory.csv and convergence.csv
// into OUTPUT_DIR, then reads trajectory.csv back and checks the nodes against the exact path
// x = 2t, y = b t - g t^2/2 (b = (1 + 2g)/2). Exits 1 on any mismatch.
//   projectile_scene projectile.toml OUTPUT_DIR
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "pardel/app/outputs.hpp"
#include "pardel/app/scene.hpp"
#include "pardel/app/solve.hpp"
#include "pardel/app/trajectory_io.hpp"
#include "projectile.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: projectile_scene SCENE.toml OUTPUT_DIR\n");
    return 2;
  }
  const auto resolve = [](const std::string& name) -> const pardel_model* {
    return name == "projectile" ? &projectile_model : pardel::find_model(name);
  };
  try {
    pardel::app::Scene scene = pardel::app::load_scene(argv[1], {}, resolve);
    pardel::Trajectory trajectory = pardel::app::make_initial_guess(scene);
    const pardel::Summary summary = pardel::app::solve_scene(scene, trajectory);
    std::filesystem::create_directories(argv[2]);
    pardel::app::write_solve_outputs(scene, summary, trajectory, argv[2]);
    std::printf("%s\n", summary.brief_report().c_str());
    if (!summary.converged()) return 1;

    const pardel::Trajectory written =
        pardel::app::read_trajectory_csv((std::filesystem::path(argv[2]) / "trajectory.csv").string(), projectile_model);
    const double g = 3.7, b = (1 + 2 * g) / 2;
    for (int k = 0; k <= written.N; ++k) {
      const double t = written.t[k];
      if (std::fabs(written.node(k)[0] - 2 * t) > 1e-9 || std::fabs(written.node(k)[1] - (b * t - g * t * t / 2)) > 1e-9) {
        std::fprintf(stderr, "mismatch at node %d of %s/trajectory.csv\n", k, argv[2]);
        return 1;
      }
    }
    if (!std::filesystem::exists(std::filesystem::path(argv[2]) / "summary.json")) {
      std::fprintf(stderr, "no summary.json in %s\n", argv[2]);
      return 1;
    }
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
  std::printf("projectile scene: solved through pardel::app; trajectory.csv matches the exact path\n");
  return 0;
}
