// The pardel command line: list models, evaluate kernels, solve scenes and check certificates.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <new>
#include <optional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include "arguments.hpp"
#include "exit_codes.hpp"
#include "inspect_commands.hpp"
#include "pardel/app/checkpoint.hpp"
#include "pardel/app/outputs.hpp"
#include "pardel/app/scene.hpp"
#include "pardel/app/solve.hpp"
#include "pardel/app/trajectory_io.hpp"
#include "pardel/memory.hpp"
#include "pardel/mpi_session.hpp"
#include "pardel/pardel.hpp"
#ifdef PARDEL_HAVE_CUDA
#include "pardel/cuda.hpp"
#endif
#include "pardel/regular_file.hpp"
#include "pardel_cli/config.hpp"
#include "plot_runner.hpp"
#include "progress.hpp"
#include "signals.hpp"
#include "sweep_command.hpp"
#ifdef PARDEL_HAVE_MODEL_LOADER
#include "pardel/model_loader.hpp"
#endif

namespace {

using namespace pardel;
using namespace pardel::app;
using namespace pardel::cli;
namespace fs = std::filesystem;

const char* const kExitCodesHelp =
    "Exit codes: 0 converged (or success), 1 internal error (e.g. an output file or standard output\n"
    "cannot be written), 2 invalid input (bad scene, option or model), 3 max_iterations, 4 diverged,\n"
    "5 non_finite, 6 interrupted (Ctrl-C or SIGTERM; the outputs hold the last iterate; pardel check\n"
    "stops once the step under way is done, a second Ctrl-C at once),\n"
    "7 stalled (no progress at the round-off level of the problem: tol is unattainable).";

/** A signal stopped the compile of a .lag model (resolve_model_spec): the command ends interrupted. */
std::atomic<bool> g_compile_interrupted{false};

/** `text` as one word of a POSIX shell: as it is where it holds only characters no shell treats
 *  specially, else in single quotes (each ' written as '\''), so that a suggested command pastes
 *  as it is meant (a folder named with a blank or a line break). */
std::string shell_word(const std::string& text) {
  const bool plain = !text.empty() && std::all_of(text.begin(), text.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("/._-+,:=@%", c) != nullptr;
  });
  if (plain) return text;
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/** The message and status of a command whose model compile a signal stopped (`what`: the error
 *  that carried it out, which names the model). */
int compile_interrupted(const char* what) {
  std::fprintf(stderr, "pardel: %s (%s): stopped before any work\n", what,
               caught_signal() == SIGTERM ? "SIGTERM" : "Ctrl-C");
  return exit_code(Termination::interrupted);
}

/**
 * Where fd 0, 1 or 2 is closed when pardel starts (`pardel kernels ... >&-`), /dev/null opened on
 * it the wrong way round (stdout read-only), so that writing to stdout fails (EBADF) and is
 * reported, instead of the first file pardel opens taking fd 1 and receiving the output.
 */
void occupy_closed_standard_fds() {
  for (int fd = 0; fd <= 2; ++fd) {
    if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
    const int opened = ::open("/dev/null", fd == 0 ? O_WRONLY : O_RDONLY);
    if (opened >= 0 && opened != fd) ::close(opened);
  }
}

/**
 * `code` once stdout is flushed; where what a command printed there could not be written (a full
 * disk, a closed stdout), says so on stderr and returns the internal-error status (1) unless the
 * command already ended with another failure. The one check of stdout for every subcommand (the
 * JSON of kernels and check --json, the list of models, the reports of solve and sweep, --help).
 */
int checked_standard_output(int code) {
  errno = 0;
  std::cout.flush();  // synchronized with stdio: fflush(stdout), whose errno says why it failed
  int error = errno;
  const bool flushed = std::fflush(stdout) == 0;
  if (error == 0) error = errno;
  if (flushed && std::cout && std::ferror(stdout) == 0) return code;
  std::fprintf(stderr, "pardel: error: cannot write to standard output: %s\n",
               error != 0 ? std::strerror(error) : "a write failed; the output is incomplete");
  return code == 0 ? kExitInternal : code;
}

/** An empty value of an option whose absence means a default (--out '', --trajectory ''): refused
 *  (exit 2) rather than taken for that default. A CLI11 check: the message, or "" to accept. */
std::string refuse_empty(const std::string& text) {
  return text.empty() ? "must not be empty (leave the option out for its default)" : "";
}

/**
 * Where the command line names no subcommand but its first word is none (`pardel solv`), the
 * message that names the word and the nearest subcommand; "" otherwise (CLI11's own message then).
 */
std::string unknown_subcommand_message(const CLI::App& app, int argc, char** argv) {
  if (!app.get_subcommands().empty()) return "";
  std::vector<std::string> names;
  for (const CLI::App* command : app.get_subcommands({})) names.push_back(command->get_name());
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') continue;  // pardel's own options take no value
    if (std::find(names.begin(), names.end(), word) != names.end()) return "";
    const std::string suggestion = nearest_name(word, names);
    std::string all;
    for (const std::string& name : names) all += (all.empty() ? "" : ", ") + name;
    return fmt::format("pardel: error: unknown subcommand '{}'{} (the subcommands: {})", word,
                       suggestion.empty() ? "" : fmt::format("; did you mean '{}'?", suggestion), all);
  }
  return "";
}

bool looks_like_path(const std::string& spec) {
  return spec.find('/') != std::string::npos || (spec.size() > 4 && spec.compare(spec.size() - 4, 4, ".lag") == 0);
}

/** A bundled name (nullptr if unknown) or a .lag path (compiled on first use when the loader is
 *  linked). The generator's warnings about a .lag model (kept with its cache entry, so also when it
 *  was compiled by an earlier run) go to stderr, once per model, on rank 0 alone under mpirun. */
const pardel_model* resolve_model_spec(const std::string& spec) {
  if (!looks_like_path(spec)) return find_model(spec);
#ifdef PARDEL_HAVE_MODEL_LOADER
  // Ctrl-C or SIGTERM while a .lag compiles stops the compile (the loader polls interrupted(),
  // set_compile_interrupt in main) and ends the command with the interrupted status.
  static std::mutex resolving;
  std::lock_guard<std::mutex> lock(resolving);
  const pardel_model* model = nullptr;
  {
    CatchSignals catch_signals;
    try {
      model = pardel::resolve_model(spec);
    } catch (...) {
      if (interrupted().load()) g_compile_interrupted.store(true);
      throw;
    }
  }
  static std::vector<const pardel_model*> reported;
  if (model && std::find(reported.begin(), reported.end(), model) == reported.end()) {
    reported.push_back(model);
    const std::string warnings = pardel::model_warnings(model);
    if (!warnings.empty() && pardel::mpi::world_rank() == 0) std::cerr << warnings << "\n" << std::flush;
  }
  return model;
#else
  throw std::runtime_error("this build cannot load .lag files (no model loader); use a bundled model");
#endif
}

// ---------------------------------------------------------------------------------------------
// pardel solve / check

Scene load_scene_or_throw(const std::string& path, const std::vector<std::string>& sets) {
  try {
    return load_scene(path, sets, resolve_model_spec, bundled_model_names());
  } catch (const SceneError& error) {
    // An error at a line of the scene that an override made wrong (--set model=... whose model has
    // other coordinates than the scene's boundary values): the message says which overrides.
    const std::string message = error.what();
    if (sets.empty() || message.rfind("--set ", 0) == 0) throw;
    std::string joined;
    for (const std::string& set : sets) joined += (joined.empty() ? "" : " --set ") + set;
    throw SceneError(message + " (the scene as changed by --set " + joined + ")");
  }
}

struct SolveArgs {
  std::string scene;
  std::string out;
  std::vector<std::string> sets;
  int threads = -1;
  bool quiet = false;
  bool no_plot = false;
  std::string resume;  ///< output folder of an interrupted solve to continue
  bool no_memory_check = false;
  std::string device;  ///< --device: appended to the overrides as solver.device
  std::string certificate = "inertia";  ///< "full": also the seed's certificate (pardel check's)
};

/** Refuses a scene with --resume, a --set that changes a resumed problem, and neither. */
void check_scene_or_resume(const SolveArgs& args) {
  if (!args.resume.empty()) {
    if (!args.scene.empty())
      throw UsageError("--resume: give no scene; the solve continues with the scene and overrides recorded in " +
                       (fs::path(args.resume) / checkpoint_file_name()).string());
    // --resume with --set solver.KEY=VALUE: a warm start from the checkpoint's iterate with other
    // solver options (another method, say) instead of the exact continuation.
    for (const std::string& set : args.sets)
      if (set.rfind("solver.", 0) != 0)
        throw UsageError("--resume: only --set solver.KEY=VALUE may change a resumed solve (a warm start from its "
                         "iterate); '" + set + "' changes the problem");
  } else if (args.scene.empty()) {
    throw UsageError("solve: a scene file is required (or --resume OUTPUT_DIR)");
  }
}

int run_solve_unguarded(const SolveArgs& args) {
  check_scene_or_resume(args);
  const bool resume = !args.resume.empty();
  std::optional<Resumed> resumed;
  if (resume) {
    resumed = resume_scene(args.resume, args.sets, resolve_model_spec, bundled_model_names());
    if (!resumed->warning.empty() && pardel::mpi::world_rank() == 0)
      std::fprintf(stderr, "%s\n", resumed->warning.c_str());
  }
  Scene scene = resume ? resumed->scene : load_scene_or_throw(args.scene, args.sets);
  const std::string scene_path = resume ? resumed->checkpoint.scene_path : args.scene;
  const int threads = args.threads >= 0 ? args.threads : resume ? resumed->checkpoint.threads : -1;
  if (threads >= 0) scene.options.threads = threads;

  std::string out_dir = args.out;
  if (out_dir.empty() && resume) out_dir = args.resume;
  if (out_dir.empty()) out_dir = scene.output_dir;
  if (out_dir.empty()) out_dir = (fs::path("out") / fs::path(args.scene).stem()).string();
  std::error_code ec;
  SolveRequest request;
  if (resume) {
    request = resume_request(*resumed, out_dir, threads);
  } else {
    request.checkpoint.dir = out_dir;
    request.checkpoint.scene_file = fs::absolute(scene_path, ec).lexically_normal().string();
    request.checkpoint.overrides = args.sets;
    request.checkpoint.threads = threads;
  }
  request.check_memory = !args.no_memory_check;
  request.full_certificate = args.certificate == "full";
  // Under mpirun with more than one rank, one solve decomposed over the ranks: every rank solves,
  // rank 0 alone creates the output folder (once the memory check passed), writes the outputs and
  // reports (so that it alone knows whether it created the folder, and removes it again when the
  // solve is refused).
  const int ranks = pardel::mpi::world_size();
  const bool root = pardel::mpi::world_rank() == 0;
  const bool created_out_dir = root && !fs::exists(out_dir, ec);
  request.prepare = [&out_dir, root] {
    if (root) create_output_folder(out_dir);
  };
  ProgressLine progress(root && !args.quiet, scene.options.tol);
  request.on_iteration = [&progress, root](const IterationRecord& record) {
    if (root) progress.update(record);
    return !interrupted().load();
  };
  request.keep_going = [] { return !interrupted().load(); };
  request.stopped_by = [] { return signal_name(caught_signal()); };
  // Ctrl-C and SIGTERM stop the solve (it ends interrupted, with a checkpoint); once it has
  // ended they have their usual effect again, also while the outputs are written.
  CatchSignals catch_signals;
  // The outputs (rank 0) are written before the checkpoint, which comes last.
  SolveOutputs outputs;
  request.outputs = [&](const Summary& summary, const Trajectory& trajectory) {
    catch_signals.restore();
    progress.finish();
    if (!root) return;
    nlohmann::ordered_json extra = nlohmann::ordered_json::object();
    if (ranks > 1) extra["ranks"] = ranks;
    outputs = write_solve_outputs(scene, summary, trajectory, out_dir, extra, args.certificate == "full");
  };
  if (root) {
    const std::string refusal = disk_refusal(scene, out_dir);
    if (!refusal.empty()) throw UsageError(refusal);
  }
  Trajectory trajectory;  // empty: the scene's initial guess (or the resumed state)
  SolveRun run;
  try {
    run = run_solve(scene, trajectory, request);
  } catch (const MemoryRefused& refused) {
    throw UsageError(fmt::format("{}: {} (--no-memory-check skips this check)", scene_path, refused.reason()));
  }
  catch_signals.restore();
  progress.finish();
  const Summary& summary = run.summary;
  // A checkpoint that does not fit is refused before anything in the folder is overwritten (under
  // mpirun, by rank 0 alone).
  if (resume && summary.termination == Termination::invalid_input) {
    if (!root) return exit_code(summary.termination);
    throw CheckpointError(fmt::format("{}: error: {}", resumed->checkpoint_path, summary.message));
  }
  // Input the runtime refused (a degenerate model, a method this build lacks, fewer nodes than the
  // ranks need, ...): an error, and nothing is written.
  if (summary.termination == Termination::invalid_input) {
    if (!root) return exit_code(summary.termination);
    if (created_out_dir) fs::remove(out_dir, ec);  // still empty: nothing was written
    std::fprintf(stderr, "%s: error: %s\n", scene_path.c_str(), summary.message.c_str());
    return exit_code(summary.termination);
  }
  if (!root) return exit_code(summary.termination);

  if (!args.no_plot && outputs.have_trajectory) run_plot_script(config::plot_script, out_dir, "plots");
  if (!args.quiet) {
    print_solve_report(scene, summary, trajectory, outputs.certificate, out_dir,
                       ranks > 1 ? fmt::format("ranks: {} (nodes split into contiguous ranges, halos exchanged every "
                                               "iteration)",
                                               ranks)
                                 : "");
  }
  if (!summary.converged()) {
    std::fprintf(stderr, "pardel solve: %s: %s\n", to_string(summary.termination), summary.message.c_str());
  }
  if (run.checkpoint_written) {
    std::fprintf(stderr, "pardel solve: checkpoint written; continue with: pardel solve --resume %s\n",
                 shell_word(out_dir).c_str());
  }
  return exit_code(summary.termination);
}

/** run_solve_unguarded with running out of memory turned into a usage error naming the scene. */
int run_solve(const SolveArgs& args) {
  try {
    return run_solve_unguarded(args);
  } catch (const OutOfMemory& error) {
    throw UsageError(error.what());
  } catch (const std::bad_alloc&) {
    throw UsageError("out of memory (std::bad_alloc) while reading the scene; lower grid.N or free memory");
  }
}

struct CheckArgs {
  std::string scene;
  std::string trajectory;
  std::vector<std::string> sets;
  bool json = false;
};

/** Whether a signal came (CatchSignals) before or during `step` of pardel check; if so, says so on
 *  stderr: check then ends with the interrupted status and prints nothing. */
bool check_stopped(const char* step) {
  if (!interrupted().load()) return false;
  std::fprintf(stderr, "pardel check: stopped by %s %s; nothing printed\n", signal_name(caught_signal()).c_str(),
               step);
  return true;
}

int run_check(const CheckArgs& args) {
  // None of check's steps polls a stop: Ctrl-C or SIGTERM ends it after the step under way (the
  // certificate of a large grid takes seconds) with the interrupted status and a message; the same
  // signal a second time ends it at once. A .lag compile stops at once (resolve_model_spec).
  CatchSignals catch_signals(CatchSignals::Again::ends_process);
  Scene scene = load_scene_or_throw(args.scene, args.sets);
  if (check_stopped("while reading the scene")) return exit_code(Termination::interrupted);
  Trajectory trajectory;
  if (args.trajectory.empty()) {
    trajectory = make_initial_guess(scene);
  } else {
    try {
      trajectory = read_trajectory_csv(args.trajectory, *scene.model);
    } catch (const std::runtime_error& error) {
      throw UsageError(fmt::format("--trajectory: {}", error.what()));
    }
    const std::string mismatch = fit_to_path(scene, trajectory);
    if (!mismatch.empty()) throw UsageError(fmt::format("--trajectory {}: {}", args.trajectory, mismatch));
  }
  if (check_stopped("while reading the trajectory")) return exit_code(Termination::interrupted);
  const Certificate certificate = certify(scene.problem, trajectory, scene.options.threads);
  if (check_stopped("while computing the certificate")) return exit_code(Termination::interrupted);
  const double residual = residual_norm(scene.problem, trajectory);
  const double action = discrete_action(scene.problem, trajectory);
  if (check_stopped("while computing the residual and the action")) return exit_code(Termination::interrupted);
  catch_signals.restore();
  if (args.json) {
    nlohmann::ordered_json j;
    j["trajectory"] = args.trajectory.empty() ? "initial guess" : args.trajectory;
    j["N"] = trajectory.N;
    j["residual"] = residual;
    j["action"] = action;
    j["certificate"] = certificate_json(certificate, static_cast<std::size_t>(-1));
    // A --trajectory path that is not UTF-8 is printed with U+FFFD for its invalid bytes.
    std::cout << j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) << "\n";
  } else {
    std::cout << fmt::format("trajectory: {} (N = {})\nresidual: {}\naction: {}\n",
                             args.trajectory.empty() ? "initial guess" : args.trajectory, trajectory.N,
                             format_double(residual), format_double(action));
    std::cout << certificate.report();
    if (!certificate.report().empty() && certificate.report().back() != '\n') std::cout << "\n";
  }
  return 0;
}

/**
 * The text of --threads (of `solve` and `sweep`), checked as the scene reader checks solver.threads:
 * an integer within option_bound("threads"), else a SceneError (exit code 2) in the words of a
 * --set of that key: "--threads 5000: error: --threads must be between 0 (all cores) and 4096, got
 * 5000". A CLI11 transform: returns the text unchanged.
 */
std::string checked_threads_text(const std::string& text) {
  const pardel::OptionBound& bound = *pardel::option_bound("threads");
  const auto error = [&text](const std::string& what) {
    return SceneError(fmt::format("--threads {}: error: --threads {}, got {}", text, what, text));
  };
  long long value = 0;
  const char* end = text.data() + text.size();
  const auto [stop, code] = std::from_chars(text.data(), end, value);
  if (stop != end || (code != std::errc() && code != std::errc::result_out_of_range)) throw error("must be an integer");
  if (code == std::errc::result_out_of_range || !bound.accepts(static_cast<double>(value))) throw error(bound.rule);
  return text;
}

/**
 * The text of a --set (of `solve`, `check` and `sweep`): an override is one line of TOML, so text
 * after a line break would be dropped unseen; refused with a SceneError (exit code 2) quoting
 * the override with its line break written as \n. A CLI11 transform: returns the text unchanged.
 */
std::string checked_set_text(const std::string& text) {
  if (text.find_first_of("\n\r") == std::string::npos) return text;
  std::string shown;
  for (const char c : text) shown += c == '\n' ? std::string("\\n") : c == '\r' ? std::string("\\r") : std::string(1, c);
  throw SceneError(fmt::format("--set {}: error: the override holds a line break; give each KEY=VALUE its own --set, "
                               "on one line",
                               shown));
}

}  // namespace

/**
 * OpenMP threads that finish their share of a loop spin by default until the others arrive. Where
 * another process keeps a core busy, the spinning thread holds the free core while its partner
 * waits for the busy one, and every parallel region costs a scheduler quantum: on 2 cores with one
 * busy, a 2-thread solve of rb_kepler at N = 2·10⁴ took 112–130 ms spinning and 15–18 ms waiting
 * passively (one thread: 16 ms; docs/benchmarks.md). So pardel waits passively unless the user
 * chose: OpenMP reads OMP_WAIT_POLICY when its library is loaded, before main, so the command sets
 * it and runs itself again (nothing happens where it cannot).
 */
void prefer_passive_openmp_wait(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 0) != 0) return;
  execv("/proc/self/exe", argv);
}

namespace {

/** The `solve` subcommand with its arguments into `s`. */
CLI::App* add_solve_command(CLI::App& app, SolveArgs& s) {
  CLI::App* solve_cmd = app.add_subcommand("solve", "Solve a scene and write trajectory, convergence, summary and plots");
  solve_cmd->footer(kExitCodesHelp);
  solve_cmd->add_option("scene", s.scene, "Scene file (TOML); not with --resume");
  solve_cmd->add_option("--out", s.out, "Output folder (default: [output].dir, else out/<scene-stem>)");
  solve_cmd->add_option("--set", s.sets, "KEY=VALUE: override a scene key, e.g. solver.method=newton (repeatable)")
      ->allow_extra_args(false);
  // Checked as solver.threads is: checked_threads_text, attached in main() with sweep's --threads.
  solve_cmd->add_option("--threads", s.threads, "Threads (0: all cores); overrides solver.threads");
  solve_cmd->add_option("--device", s.device, "cpu or cuda: where to solve; overrides solver.device (docs/gpu.md)")
      ->check(CLI::IsMember(pardel::device_names()));
  solve_cmd->add_flag("--quiet", s.quiet, "No progress line and no report on stdout");
  solve_cmd->add_flag("--no-plot", s.no_plot, "Do not draw trajectory.png and convergence.png");
  solve_cmd->add_option("--certificate", s.certificate,
                        "inertia (default: the point assessment from the solve's factorization) or full (also the "
                        "interval-by-interval test and the Jacobi spectral radius of pardel check)")
      ->check(CLI::IsMember({"inertia", "full"}));
  solve_cmd->add_option("--resume", s.resume,
                        "Continue the interrupted solve whose outputs (and checkpoint.json) are in this folder; "
                        "with --set solver.KEY=VALUE, a warm start from its iterate with those solver options");
  solve_cmd->add_flag("--no-memory-check", s.no_memory_check,
                      "Solve even when the memory estimate exceeds what the machine has");
  return solve_cmd;
}

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  occupy_closed_standard_fds();
#ifdef PARDEL_HAVE_CUDA
  pardel::enable_cuda();  // solver.device = "cuda"
#endif
  const pardel::mpi::Session mpi_session(&argc, &argv);
  CLI::App app{"pardel: solve the boundary-value problems of variational integrators"};
  app.footer(kExitCodesHelp);
  app.set_version_flag("--version", std::string("pardel ") + pardel::cli::config::version,
                       "Print pardel's version and exit");
  app.require_subcommand(1);

  bool models_json = false;
  auto* models = app.add_subcommand("models", "List the bundled models: coords, order, params, discretizations");
  models->add_flag("--json", models_json, "Print JSON");

  KernelArgs k;
  auto* kernels = app.add_subcommand("kernels", "Evaluate a discrete Lagrangian and its derivatives (JSON)");
  kernels->add_option("--model", k.model, "A bundled model's name or a path to a .lag file")->required();
  kernels->add_option("--disc", k.disc, "Discretization, e.g. trapezoid or trapezoid(alpha=1)")->required();
  kernels->add_option("--h", k.h, "Step h (a finite number > 0)")->required();
  kernels->add_option("--t0", k.t0, "Time of the first node")->required();
  kernels->add_option("--t1", k.t1, "Time of the second node")->required();
  kernels->add_option("--q0", k.q0, "First node: order*ncoords values a,b,... [coords, coords', ...]")->required();
  kernels->add_option("--q1", k.q1, "Second node, same layout")->required();
  kernels->add_option("--param", k.params, "NAME=VALUE, overrides a param's default (repeatable, once per param)")
      ->allow_extra_args(false);

  SolveArgs s;
  CLI::App* solve_cmd = add_solve_command(app, s);

  CheckArgs c;
  auto* check = app.add_subcommand("check", "Print the convergence certificate at the initial guess or a trajectory");
  check->add_option("scene", c.scene, "Scene file (TOML)")->required();
  check->add_option("--trajectory", c.trajectory, "A trajectory.csv (default: the scene's initial guess)");
  check->add_option("--set", c.sets, "KEY=VALUE: override a scene key (repeatable)")->allow_extra_args(false);
  check->add_flag("--json", c.json, "Print JSON");

  const SweepCommand sweep_cmd(app);
  for (CLI::App* command : {solve_cmd, app.get_subcommand("sweep")}) {
    command->get_option("--threads")->transform(checked_threads_text);
  }
  for (CLI::App* command : {solve_cmd, check, app.get_subcommand("sweep")}) {
    command->get_option("--set")->transform(checked_set_text);
  }
  for (CLI::Option* option : {solve_cmd->get_option("--out"), solve_cmd->get_option("--resume"),
                              check->get_option("--trajectory"), app.get_subcommand("sweep")->get_option("--out")}) {
    option->check(refuse_empty);
  }

  // Under mpirun with more than one rank, an error seen by some ranks only would leave the others
  // waiting for them: every error ends the whole job (the message is printed first).
  const auto fail = [](int code) {
    if (pardel::mpi::world_size() > 1) pardel::mpi::abort_job(code);
    return code;
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const std::string unknown = unknown_subcommand_message(app, argc, argv);
    if (!unknown.empty()) {
      std::fprintf(stderr, "%s\n", unknown.c_str());
      return fail(kExitUsage);
    }
    if (app.exit(error) != 0) return fail(kExitUsage);
    const int checked = checked_standard_output(0);  // --help and --version print to stdout
    return checked == 0 ? 0 : fail(checked);
  } catch (const SceneError& error) {  // a value checked as its scene key is (--threads)
    std::fprintf(stderr, "%s\n", error.what());
    return fail(kExitUsage);
  }

#ifdef PARDEL_HAVE_MODEL_LOADER
  pardel::set_compile_interrupt([] { return interrupted().load(); });
  // A .lag file's first use compiles it (seconds, minutes for a large model under a high-order
  // discretization): said on a terminal, as the progress line is, unless --quiet.
  const bool quiet = (*solve_cmd && s.quiet) || (sweep_cmd.parsed() && sweep_cmd.quiet());
  if (!quiet && pardel::mpi::world_rank() == 0 && ::isatty(STDERR_FILENO))
    pardel::set_compile_notice([](const std::string& path) {
      std::cerr << "pardel: compiling " << path << " (its first use; later runs load it from the model cache) ...\n"
                << std::flush;
    });
#endif
  // The command; then its output on stdout, checked once for every command.
  const auto run_command = [&]() -> int {
    try {
      if (*models) return run_models(models_json);
      if (*kernels) return run_kernels(k, resolve_model_spec);
      if (*solve_cmd) {
        if (!s.device.empty()) s.sets.push_back("solver.device=" + s.device);
        return run_solve(s);
      }
      if (*check) return run_check(c);
      if (sweep_cmd.parsed()) {
        const int code = sweep_cmd.run(resolve_model_spec, bundled_model_names());
        // The sweep reported a model whose compile a signal stopped ("interrupted while compiling").
        return g_compile_interrupted.load() ? fail(exit_code(Termination::interrupted)) : code;
      }
    } catch (const UsageError& error) {
      if (g_compile_interrupted.load()) return fail(compile_interrupted(error.what()));
      std::fprintf(stderr, "pardel: error: %s\n", error.what());
      return fail(kExitUsage);
    } catch (const SceneError& error) {
      if (g_compile_interrupted.load()) return fail(compile_interrupted(error.what()));
      std::fprintf(stderr, "%s\n", error.what());
      return fail(kExitUsage);
    } catch (const CheckpointWriteError& error) {  // the outputs are written; the checkpoint could not be
      std::fprintf(stderr, "%s\n", error.what());
      return fail(kExitInternal);
    } catch (const CheckpointError& error) {
      std::fprintf(stderr, "%s\n", error.what());
      return fail(kExitUsage);
    } catch (const std::bad_alloc&) {
      std::fprintf(stderr, "pardel: error: out of memory (std::bad_alloc)\n");
      return fail(kExitInternal);
    } catch (const std::exception& error) {
      if (g_compile_interrupted.load()) return fail(compile_interrupted(error.what()));
      std::fprintf(stderr, "pardel: error: %s\n", error.what());
      return fail(kExitInternal);
    }
    return fail(kExitUsage);
  };
  const int code = run_command();
  const int checked = checked_standard_output(code);
  return checked == code ? code : fail(checked);
}
