/**
 * @file solve.hpp
 * Solving a scene, the one service that the command line, the Python module and sweeps call: the
 * memory check before anything of size N is allocated, the solve in one process or, under mpirun
 * with more than one rank, decomposed over all ranks (pardel/distributed.hpp; a build without MPI
 * is one rank of one), running out of memory turned into a message, and the checkpoint of an
 * interrupted solve written or removed. Resuming an interrupted solve (read the checkpoint, load
 * its scene again, check that it still fits) is resume_scene. What stays with a front end is its
 * own words: arguments, exit codes or exceptions, signals, progress, where outputs go.
 */
#ifndef PARDEL_APP_SOLVE_HPP
#define PARDEL_APP_SOLVE_HPP

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "pardel/app/checkpoint.hpp"
#include "pardel/app/scene.hpp"
#include "pardel/memory.hpp"
#include "pardel/pardel.hpp"

namespace pardel::app {

/** A solve refused before it started because it would not fit in memory; what() is
 *  "SCENE: REASON", reason() the REASON alone (memory_refusal's words). */
class MemoryRefused : public std::runtime_error {
 public:
  MemoryRefused(const std::string& scene, const std::string& reason)
      : std::runtime_error(scene + ": " + reason), reason_(reason) {}
  const std::string& reason() const { return reason_; }

 private:
  std::string reason_;
};

/** A solve that ran out of memory (std::bad_alloc) anyway; what() names the scene, grid.N, the
 *  method, the model's dim and the estimated need, and what to do. */
class OutOfMemory : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** Where the checkpoint of an interrupted solve goes and what it records to be resumed. */
struct CheckpointPlan {
  std::string dir;                      ///< the folder of checkpoint.json; "" for no checkpoint
  std::string scene_file;               ///< the scene file it records (an absolute path), unless
  std::string scene_text;               ///< the scene as text: written to DIR/scene.toml, which it records
  std::vector<std::string> overrides;   ///< the --set KEY=VALUE strings it records
  int threads = -1;                     ///< the thread count it records (-1: not given)
  /** The model's digest (model_digest) it records, where the caller took it already before the
   *  solve (resume_scene does, to check the checkpoint); "": run_solve takes it before the solve. */
  std::string model_digest;
};

/** What a front end asks of a scene's solve besides the scene and its initial guess. */
struct SolveRequest {
  /** Refuse (MemoryRefused) a solve whose estimated need exceeds the machine's memory. */
  bool check_memory = true;
  /** The estimate also counts the seed's full certificate (`pardel solve --certificate full`). */
  bool full_certificate = false;
  /** Under mpirun with more than one rank, decompose this solve over all ranks; false solves it
   *  in this process alone (a sweep's variant, a Python call). */
  bool over_ranks = true;
  /** Called once the memory check passed and the initial guess is made, before the solve (a
   *  front end creates its output folder there, so that a refused solve leaves none). */
  std::function<void()> prepare;
  /** Continue from this state of an interrupted solve (the trajectory is then ignored). */
  const SolverState* resume_from = nullptr;
  /** With resume_from: from its iterate, with the scene's (other) solver options. */
  bool warm_start = false;
  /** Called after every recorded iteration (Options::on_iteration); false stops the solve. */
  std::function<bool(const IterationRecord&)> on_iteration;
  /** Polled where no iteration is recorded (Options::keep_going); false stops the solve. */
  std::function<bool()> keep_going;
  /** What stopped an interrupted solve, in words ("SIGINT (Ctrl-C)"), for its message in place of
   *  the runtime's "on_iteration"; "" (or unset) keeps the runtime's words. */
  std::function<std::string()> stopped_by;
  /** Called after a solve that did not end invalid_input, with its summary and trajectory,
   *  before the checkpoint is updated (a front end writes its outputs there: the checkpoint comes
   *  last, so that a process killed in between leaves complete outputs and the previous state). */
  std::function<void(const Summary&, const Trajectory&)> outputs;
  /** The checkpoint that an interruption writes (on rank 0) and any other end removes. */
  CheckpointPlan checkpoint;
};

/** What run_solve returns besides the trajectory, which it leaves in the caller's. */
struct SolveRun {
  Summary summary;
  MemoryEstimate memory;            ///< the estimate the memory check used
  bool checkpoint_written = false;  ///< DIR/checkpoint.json was written (an interrupted solve)
};

/**
 * Solves the scene's problem with its options from `trajectory` (the initial guess; an empty one,
 * N = 0, stands for the scene's own, make_initial_guess, made after the memory check, whose errors
 * come before request.prepare; on return the solve's trajectory) as `request` asks: MemoryRefused
 * before anything else when it would not fit; then request.prepare;
 * OutOfMemory when it ran out anyway; a solve that ended `invalid_input` (the runtime refused the
 * problem or the resumed state) leaves the checkpoint folder untouched; any other end calls
 * request.outputs, then updates the checkpoint (update_checkpoint; on rank 0 alone), whose failure throws CheckpointError naming
 * DIR/checkpoint.json. The request's callbacks, where given, replace the scene's for this solve;
 * the scene is not changed. Over ranks, every rank
 * calls it with the same scene and guess; the nodes are split into contiguous ranges, one per
 * rank, and the trajectory is gathered on rank 0 (the other ranks get an empty one, N and dim
 * set); the summary is the same on every rank.
 */
SolveRun run_solve(const Scene& scene, Trajectory& trajectory, const SolveRequest& request);

/** An interrupted solve's message with the runtime's words for its stop, "by on_iteration", made
 *  "by WHO" (what stopped it: "Ctrl-C (KeyboardInterrupt)"); unchanged where `who` is empty, the
 *  summary did not end interrupted, or the message does not hold those words. run_solve applies
 *  it with request.stopped_by; a front end that calls the runtime itself (a batch) applies it to
 *  each of its summaries. */
void name_interruption(Summary& summary, const std::string& who);

/** run_solve with the default request (the memory check, the scene's own callbacks, no
 *  checkpoint), returning the summary. */
Summary solve_scene(const Scene& scene, Trajectory& trajectory);

/** An interrupted solve to continue: its checkpoint, and its scene loaded again and checked. */
struct Resumed {
  std::string checkpoint_path;          ///< DIR/checkpoint.json
  Checkpoint checkpoint;                ///< as read
  Scene scene;                          ///< from the recorded path with the recorded overrides, then `solver_sets`
  std::vector<std::string> overrides;   ///< the recorded overrides followed by `solver_sets`
  std::string warning;                  ///< check_resumable's warning, or ""
  std::string model_digest;             ///< the scene's model digest, taken for check_resumable
  bool warm_start = false;              ///< `solver_sets` were given: a warm start from the iterate
};

/**
 * Reads DIR/checkpoint.json, loads its scene again from the recorded path with the recorded
 * overrides followed by `solver_sets` (KEY=VALUE strings of solver options: a warm start from the
 * recorded iterate; the front end has checked that they are solver options), and checks that the
 * checkpoint continues it (check_resumable). Throws CheckpointError or SceneError.
 */
Resumed resume_scene(const std::string& dir, const std::vector<std::string>& solver_sets, const ModelResolver& resolve,
                     const std::vector<std::string>& model_names = {});

/** The SolveRequest that continues `resumed` (resume_from, warm_start, and its checkpoint in
 *  DIR recording the scene file, the overrides, `threads` and the model digest already taken). */
SolveRequest resume_request(const Resumed& resumed, const std::string& dir, int threads);

}  // namespace pardel::app

#endif  // PARDEL_APP_SOLVE_HPP
