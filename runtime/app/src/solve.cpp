// `pardel solve` over the ranks of an MPI run: the distributed solve, outputs written by rank 0 alone.
#include "distributed_solve.hpp"

#include <fmt/format.h>

#include <atomic>
#include <csignal>
#include <cstdio>

#include "outputs.hpp"
#include "pardel/distributed.hpp"
#include "pardel/mpi_session.hpp"
#include "pardel_cli/config.hpp"
#include "progress.hpp"

namespace pardel::cli {
namespace {

std::atomic<bool> g_distributed_interrupted{false};
extern "C" void on_distributed_signal(int) { g_distributed_interrupted.store(true); }

}  // namespace

int run_distributed_solve(Scene& scene, Trajectory& trajectory, const DistributedSolveOutput& output) {
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
  // Input the solve refused (e.g. fewer nodes than ranks need): an error on rank 0, no outputs,
  // as in the one-process solve.
  if (summary.termination == Termination::invalid_input) {
    if (root) std::fprintf(stderr, "%s: error: %s\n", scene.path.c_str(), summary.message.c_str());
    return exit_code(summary.termination);
  }
  if (!root) return exit_code(summary.termination);

  const SolveOutputs outputs = write_solve_outputs(scene, summary, trajectory, output.out_dir, {{"ranks", ranks}});
  if (output.plot && outputs.have_trajectory) run_plot_script(config::plot_script, output.out_dir, "plots");
  if (!output.quiet) {
    print_solve_report(scene, summary, trajectory, outputs.certificate, output.out_dir,
                       fmt::format("ranks: {} (nodes split into contiguous ranges, halos exchanged every iteration)",
                                   ranks));
  }
  if (!summary.converged()) {
    std::fprintf(stderr, "pardel solve: %s: %s\n", to_string(summary.termination), summary.message.c_str());
  }
  return exit_code(summary.termination);
}

}  // namespace pardel::cli
