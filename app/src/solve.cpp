// Solving a scene: the service that the command line, the Python module and sweeps share (see
// solve.hpp): memory check, the solve in one process or over MPI ranks, running out of memory
// named, the checkpoint of an interrupted solve; and resuming one from its checkpoint.
#include "pardel/app/solve.hpp"

#include <filesystem>
#include <new>

#include <fmt/format.h>

#include "pardel/app/trajectory_io.hpp"
#include "pardel/distributed.hpp"
#include "pardel/mpi_session.hpp"

namespace pardel::app {
namespace {

/** The name of the scene file a checkpoint of a scene given as text records, beside checkpoint.json. */
constexpr const char* kCheckpointScene = "scene.toml";

/** Writes or removes the checkpoint of `plan` after a solve that ended with `summary`. */
bool write_checkpoint_of(const CheckpointPlan& plan, const Scene& scene, const Summary& summary,
                         const std::string& digest) {
  const std::filesystem::path file = std::filesystem::path(plan.dir) / checkpoint_file_name();
  try {
    std::string scene_file = plan.scene_file;
    if (!plan.scene_text.empty()) {
      std::error_code ec;
      scene_file = std::filesystem::absolute(std::filesystem::path(plan.dir) / kCheckpointScene, ec)
                       .lexically_normal()
                       .string();
      if (summary.termination == Termination::interrupted && summary.state.valid)
        write_file_atomic(scene_file, plan.scene_text);
    }
    return update_checkpoint(plan.dir, summary, scene_file, plan.overrides, plan.threads, *scene.model, digest);
  } catch (const CheckpointError&) {
    throw;
  } catch (const std::exception& error) {
    throw CheckpointWriteError(
        fmt::format("{}: error: the checkpoint could not be written: {}", file.string(), error.what()));
  }
}

}  // namespace

SolveRun run_solve(const Scene& scene, Trajectory& trajectory, const SolveRequest& request) {
  SolveRun run;
  run.memory = estimate_solve_memory(scene.problem, scene.options, request.full_certificate);
  if (request.check_memory) {
    const std::string refusal = memory_refusal(scene.problem, scene.options, run.memory, machine_memory(run.memory.peak));
    if (!refusal.empty()) throw MemoryRefused(scene.path, refusal);
  }
  // Taken before the solve: what a checkpoint of this solve records of its model.
  const CheckpointPlan& plan = request.checkpoint;
  std::string digest = plan.model_digest;
  if (!plan.dir.empty() && digest.empty()) digest = model_digest(*scene.model, scene.model_path);

  const auto out_of_memory = [&scene, &run] {
    return OutOfMemory(fmt::format(
        "out of memory (std::bad_alloc) while solving {} with grid.N = {} (method {}, model dim {}; estimated "
        "need {}); lower grid.N or free memory",
        scene.path, scene.problem.N, to_string(scene.options.method), scene.model->dim,
        format_bytes(run.memory.peak)));
  };
  // The guess before prepare: a guess file that cannot be read leaves no output folder behind.
  try {
    if (trajectory.N == 0 && !request.resume_from) trajectory = make_initial_guess(scene);
  } catch (const std::bad_alloc&) {
    throw out_of_memory();
  }
  if (request.prepare) request.prepare();

  Options options = scene.options;
  if (request.on_iteration) options.on_iteration = request.on_iteration;
  if (request.keep_going) options.keep_going = request.keep_going;
  options.resume_from = request.resume_from;
  options.warm_start = request.resume_from && request.warm_start;
  try {
    run.summary = request.over_ranks && mpi::world_size() > 1
                      ? mpi::solve_distributed(scene.problem, options, trajectory)
                      : solve(scene.problem, options, trajectory);
  } catch (const std::bad_alloc&) {
    throw out_of_memory();
  }
  if (run.summary.termination == Termination::invalid_input) return run;
  if (run.summary.termination == Termination::interrupted && request.stopped_by)
    name_interruption(run.summary, request.stopped_by());
  if (request.outputs) request.outputs(run.summary, trajectory);
  if (!request.checkpoint.dir.empty() && mpi::world_rank() == 0)
    run.checkpoint_written = write_checkpoint_of(request.checkpoint, scene, run.summary, digest);
  return run;
}

void name_interruption(Summary& summary, const std::string& who) {
  if (summary.termination != Termination::interrupted || who.empty()) return;
  const std::string runtime_words = "by on_iteration";
  const std::size_t at = summary.message.find(runtime_words);
  if (at != std::string::npos) summary.message.replace(at, runtime_words.size(), "by " + who);
}

Summary solve_scene(const Scene& scene, Trajectory& trajectory) {
  return run_solve(scene, trajectory, SolveRequest{}).summary;
}

Resumed resume_scene(const std::string& dir, const std::vector<std::string>& solver_sets, const ModelResolver& resolve,
                     const std::vector<std::string>& model_names) {
  Resumed resumed;
  resumed.checkpoint_path = (std::filesystem::path(dir) / checkpoint_file_name()).string();
  resumed.checkpoint = read_checkpoint(dir);
  resumed.overrides = resumed.checkpoint.overrides;
  resumed.overrides.insert(resumed.overrides.end(), solver_sets.begin(), solver_sets.end());
  resumed.warm_start = !solver_sets.empty();
  resumed.scene = load_scene(resumed.checkpoint.scene_path, resumed.overrides, resolve, model_names);
  resumed.model_digest = model_digest(*resumed.scene.model, resumed.scene.model_path);
  resumed.warning = check_resumable(resumed.checkpoint, resumed.checkpoint_path, resumed.scene, resumed.model_digest);
  return resumed;
}

SolveRequest resume_request(const Resumed& resumed, const std::string& dir, int threads) {
  SolveRequest request;
  request.resume_from = &resumed.checkpoint.state;
  request.warm_start = resumed.warm_start;
  request.checkpoint.dir = dir;
  request.checkpoint.scene_file = resumed.checkpoint.scene_path;
  request.checkpoint.overrides = resumed.overrides;
  request.checkpoint.threads = threads;
  request.checkpoint.model_digest = resumed.model_digest;
  return request;
}

}  // namespace pardel::app
