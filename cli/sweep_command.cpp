// `pardel sweep`: the subcommand's options, its signals, progress and exit status; the sweep itself,
// spread over MPI ranks, is pardel::app's (see sweep_command.hpp).
#include "sweep_command.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <thread>

#include "exit_codes.hpp"
#include "pardel/app/sweep.hpp"
#include "pardel/mpi_session.hpp"
#include "pardel_cli/config.hpp"
#include "plot_runner.hpp"
#include "signals.hpp"

#ifdef PARDEL_HAVE_MPI
#include <mpi.h>
#endif

namespace pardel::cli {

namespace fs = std::filesystem;
using namespace pardel::app;

namespace {

const char* const kSweepExitCodesHelp =
    "Exit codes: 0 at least one variant converged (sweep.json counts the failures), 1 internal error\n"
    "(e.g. an output file cannot be written), 2 invalid input (bad sweep file, scene or option, or\n"
    "every variant refused as invalid input),\n"
    "6 interrupted (Ctrl-C or SIGTERM; the outputs hold the variants done), 8 no variant converged.";

/** Threads per variant: --threads when given (0: all cores); under several ranks on a node, the
 *  scene's "all cores" (0) becomes the node's cores shared among its ranks. -1 keeps the scene's
 *  value. */
int threads_per_variant(const SweepArgs& args, const Sweep& sweep, int size) {
  if (args.threads >= 0) return args.threads;
  if (size <= 1 || sweep.configurations.front().options.threads != 0) return -1;
  int local = size;
  for (const char* name : {"OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS"}) {
    if (const char* value = std::getenv(name)) {
      const int n = std::atoi(value);
      if (n > 0) {
        local = n;
        break;
      }
    }
  }
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, cores / local);
}

int broadcast_code(int code) {
#ifdef PARDEL_HAVE_MPI
  if (pardel::mpi::world_size() > 1) MPI_Bcast(&code, 1, MPI_INT, 0, MPI_COMM_WORLD);
#endif
  return code;
}

}  // namespace

SweepCommand::SweepCommand(CLI::App& app) {
  command_ = app.add_subcommand("sweep", "Solve many variants of a scene (guesses, params) and list the distinct "
                                         "local solutions; spreads over MPI ranks under mpirun");
  command_->footer(kSweepExitCodesHelp);
  command_->add_option("sweep", args_.sweep, "Sweep file (TOML, see docs/sweeps.md)")->required();
  command_->add_option("--out", args_.out, "Output folder (default: [output].dir, else out/<sweep-stem>)");
  command_->add_option("--set", args_.sets, "KEY=VALUE: override a key of the base scene for every variant (repeatable)")
      ->allow_extra_args(false);
  // Checked as solver.threads is by the transform that pardel's main attaches (checked_threads_text).
  command_->add_option("--threads", args_.threads, "Threads per variant (0: all cores); overrides solver.threads");
  command_->add_flag("--quiet", args_.quiet, "Nothing on stdout");
  command_->add_flag("--no-plot", args_.no_plot, "Do not draw sweep.png");
  command_->add_flag("--no-memory-check", args_.no_memory_check,
                     "Solve a variant even when its memory estimate exceeds what the machine has");
}

int SweepCommand::run(const app::ModelResolver& resolve, const std::vector<std::string>& model_names) const {
  const int rank = pardel::mpi::world_rank();
  const int size = pardel::mpi::world_size();
  Sweep sweep;
  try {
    sweep = load_sweep(args_.sweep, args_.sets, resolve, model_names);
  } catch (const SceneError& error) {
    // Every rank reads the same file and fails alike; one message is enough.
    if (rank == 0) std::fprintf(stderr, "%s\n", error.what());
    return 2;
  }
  sweep.memory_check = !args_.no_memory_check;
  const int threads = threads_per_variant(args_, sweep, size);
  const auto start = std::chrono::steady_clock::now();
  const bool show_progress = !args_.quiet && rank == 0 && ::isatty(STDERR_FILENO);
  CatchSignals catch_signals;
  std::vector<VariantResult> results = run_variants_over_ranks(
      sweep, threads, rank, size,
      [show_progress, size](int done, int mine) {
        if (!show_progress) return;
        std::fprintf(stderr, "\rsweep: %d of %d variants%s", done, mine, size > 1 ? " on rank 0" : "");
        if (done == mine) std::fprintf(stderr, "\n");
      },
      &interrupted(), /*keep_trajectories=*/false);
  catch_signals.restore();
  int code = 0;
  if (rank == 0) {
    try {
      SweepRunInfo info;
      info.ranks = size;
      info.threads = threads >= 0 ? threads : sweep.configurations.front().options.threads;
      info.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::vector<int> solution_of;
      const std::vector<Solution> solutions = group_solutions(results, sweep.grouping, &solution_of);
      std::string out_dir = args_.out;
      if (out_dir.empty()) out_dir = sweep.output_dir;
      if (out_dir.empty()) out_dir = (fs::path("out") / fs::path(args_.sweep).stem()).string();
      write_sweep_outputs(sweep, results, solutions, solution_of, info, out_dir);
      if (!args_.no_plot && sweep.plot && !solutions.empty()) {
        run_plot_script((fs::path(config::plot_script).parent_path() / "plot_sweep.py").string(), out_dir,
                        "sweep.png");
      }
      if (!args_.quiet) print_sweep_report(sweep, results, solutions, info, out_dir);
      // Variants that could not be solved (refused by the memory estimate or as invalid input, an
      // exception): each reason once on stderr, with how many variants it stopped and the first.
      std::map<std::string, std::pair<int, int>> errors;  // message -> (count, first variant)
      const std::string invalid = to_string(Termination::invalid_input);
      for (const VariantResult& r : results) {
        if (r.status != "error" && r.status != invalid) continue;
        const auto it = errors.try_emplace(r.message, 0, r.id).first;
        ++it->second.first;
      }
      for (const auto& [message, seen] : errors) {
        std::fprintf(stderr, "pardel sweep: %d variant%s not solved (first: variant %d): %s\n", seen.first,
                     seen.first == 1 ? "" : "s", seen.second, message.c_str());
      }
      const bool stopped =
          results.size() < static_cast<std::size_t>(sweep.variant_count()) ||
          std::any_of(results.begin(), results.end(),
                      [](const VariantResult& r) { return r.status == to_string(Termination::interrupted); });
      if (stopped) {
        const std::size_t total = static_cast<std::size_t>(sweep.variant_count());
        std::fprintf(stderr, "pardel sweep: interrupted; %s holds the variants done (%zu of %zu; %zu not started)\n",
                     out_dir.c_str(), results.size(), total, total - std::min(results.size(), total));
        code = kSweepExitInterrupted;
      } else if (!results.empty() && std::all_of(results.begin(), results.end(), [&invalid](const VariantResult& r) {
                   return r.status == invalid;
                 })) {
        // Every variant refused as invalid input (an option the scene's solve refuses): the
        // sweep's input is what is wrong, as for `pardel solve`.
        std::fprintf(stderr, "pardel sweep: every variant is invalid input (see above and %s/variants.csv)\n",
                     out_dir.c_str());
        code = kExitUsage;
      } else if (solutions.empty()) {
        std::fprintf(stderr, "pardel sweep: no variant converged (see %s/variants.csv)\n", out_dir.c_str());
        code = kSweepExitNoSolution;
      }
    } catch (const std::exception& error) {
      std::fprintf(stderr, "pardel sweep: error: %s\n", error.what());
      code = 1;
    }
  }
  return broadcast_code(code);
}

}  // namespace pardel::cli
