/**
 * @file sweep_command.hpp
 * The `pardel sweep SWEEP.toml` subcommand: registers its options on the command line and runs a
 * sweep, spreading the variants over MPI ranks when started by mpirun (rank r solves variants
 * r, r+P, ...; OpenMP inside each rank) and gathering the results on rank 0, which groups,
 * writes and prints them. Without a launcher one process solves every variant; the outputs are
 * the same.
 */
#ifndef PARDEL_CLI_SWEEP_COMMAND_HPP
#define PARDEL_CLI_SWEEP_COMMAND_HPP

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "pardel/app/scene.hpp"

namespace pardel::cli {

/** The options of `pardel sweep`. */
struct SweepArgs {
  std::string sweep;
  std::string out;
  std::vector<std::string> sets;
  int threads = -1;  ///< -1: the scene's solver.threads (shared among the ranks of a node under MPI)
  bool quiet = false;
  bool no_plot = false;
  bool no_memory_check = false;  ///< solve variants whose memory estimate exceeds the machine's memory
};

/** Exit status of `pardel sweep` when no variant converged. */
constexpr int kSweepExitNoSolution = 8;
/** Exit status of `pardel sweep` after Ctrl-C or SIGTERM (the outputs hold the variants done). */
constexpr int kSweepExitInterrupted = 6;

/** The `sweep` subcommand, registered on `app` by the constructor. */
class SweepCommand {
 public:
  explicit SweepCommand(CLI::App& app);
  /** Whether the command line chose `sweep`. */
  bool parsed() const { return command_->parsed(); }
  /** Whether --quiet was given. */
  bool quiet() const { return args_.quiet; }
  /**
   * Runs the sweep on every rank; returns the exit status (the same on every rank): 0 when at
   * least one variant converged, 2 for a bad sweep file, scene or option (the message printed by
   * rank 0), 1 when outputs cannot be written, kSweepExitInterrupted after SIGINT or SIGTERM,
   * kSweepExitNoSolution when no variant converged.
   */
  int run(const app::ModelResolver& resolve, const std::vector<std::string>& model_names) const;

 private:
  CLI::App* command_ = nullptr;
  SweepArgs args_;
};

}  // namespace pardel::cli

#endif  // PARDEL_CLI_SWEEP_COMMAND_HPP
