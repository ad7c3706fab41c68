// `pardel solve` over the ranks of an MPI run: the distributed solve, outputs written by rank 0 alone.
#include "distributed_solve.hpp"

#include <fmt/format.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "outputs.hpp"
#include "pardel/distributed.hpp"
#include "pardel/mpi_session.hpp"
#include "progress.hpp"
#include "trajectory_io.hpp"

namespace pardel::cli {
namespace {

std::atomic<bool> g_distributed_interrupted{false};
extern "C" void on_distributed_signal(int) { g_distributed_interrupted.store(true); }

}  // namespace

int run_distributed_solve(Scene& scene, Trajectory& trajectory, const DistributedSolveOutput& output) {
  namespace fs = std::filesystem;
  const int rank = mpi::world_rank(), ranks = mpi::world_size();
  const bool root = rank == 0;
  ProgressLine progress(root && !output.quiet, scene.options.tol);
  scene.options.on_iteration = [&progress, root](const IterationRecord& record) {
    if (root) progress.update(record);
    return !g_distributed_interrupted.load();
  };
  g_distributed_interrupted.store(false);
  auto previous_int = std::signal(SIGINT, on_distributed_signal);
  auto previous_term = std::signal(SIGTERM, on_distributed_signal);
  const Summary summary = mpi::solve_distributed(scene.problem, scene.options, trajectory);
  std::signal(SIGINT, previous_int);
  std::signal(SIGTERM, previous_term);
  progress.finish();
  scene.options.on_iteration = nullptr;
  if (!root) return exit_code(summary.termination);

  Certificate certificate;
  Problem final_problem = scene.problem;
  final_problem.N = trajectory.N;
  const bool have_trajectory = trajectory.N >= 2 && static_cast<int>(trajectory.t.size()) == trajectory.N + 1;
  if (have_trajectory) certificate = certify(final_problem, trajectory, scene.options.threads);
  nlohmann::ordered_json summary_doc = summary_json(scene, summary, trajectory, certificate, output.model_source);
  summary_doc["ranks"] = ranks;
  write_file_atomic((fs::path(output.out_dir) / "summary.json").string(), summary_doc.dump(2) + "\n");
  if (have_trajectory) {
    write_file_atomic((fs::path(output.out_dir) / "trajectory.csv").string(), trajectory_csv(*scene.model, trajectory));
  }
  write_file_atomic((fs::path(output.out_dir) / "convergence.csv").string(), convergence_csv(summary));
  if (output.plot && have_trajectory && output.draw_plots) output.draw_plots(output.out_dir);

  if (!output.quiet) {
    const PhysicalCost cost = physical_cost(scene, summary, trajectory);
    std::cout << summary.brief_report() << "\n";
    std::cout << fmt::format("ranks: {} (nodes split into contiguous ranges, halos exchanged every iteration)\n",
                             ranks);
    std::cout << fmt::format("{} = {} ({})\n", cost.name, format_double(cost.value), cost.definition);
    std::cout << fmt::format("certificate: theorem {}, Hessian {} (inertia +{} -{} 0:{}), Jacobi spectral radius {}\n",
                             certificate.theorem_holds ? "holds" : "does not hold",
                             certificate.hessian_positive_definite ? "positive definite" : "not positive definite",
                             certificate.inertia_positive, certificate.inertia_negative, certificate.inertia_zero,
                             format_double(certificate.jacobi_spectral_radius));
    std::cout << "output: " << output.out_dir << "\n";
  }
  if (!summary.converged()) {
    std::fprintf(stderr, "pardel solve: %s: %s\n", to_string(summary.termination), summary.message.c_str());
  }
  return exit_code(summary.termination);
}

}  // namespace pardel::cli
