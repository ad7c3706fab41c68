/**
 * @file solve.cpp
 * pardel.solve_scene and pardel.resume: one scene solved through pardel::app's solve service with
 * the GIL released, calling the Python callback and stopping at Ctrl-C, with the checkpoint of an
 * interrupted solve (the files, checks and messages of `pardel solve` and `pardel solve --resume`).
 */
#include "bindings.hpp"

#include <fmt/format.h>

#include <chrono>
#include <exception>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "pardel/app/checkpoint.hpp"
#include "pardel/app/outputs.hpp"
#include "pardel/app/solve.hpp"
#include "pardel/model_loader.hpp"

namespace pardel::python {

namespace {

/** Makes the checkpoint folder (with its parents) before the solve, so that a folder that cannot
 *  be made is reported before the work; CheckpointError naming it otherwise. */
void make_checkpoint_folder(const std::string& dir) {
  try {
    app::create_output_folder(dir);
  } catch (const std::exception& error) {
    std::string message = error.what();
    const std::string output = "cannot create output folder";
    const std::size_t at = message.find(output);
    if (at != std::string::npos) message.replace(at, output.size(), "cannot create the checkpoint folder");
    throw app::CheckpointError(message);
  }
}

/**
 * Solves a scene in this process with the GIL released through pardel::app's solve service
 * (app::run_solve, as `pardel solve`), from `trajectory` or, with request.resume_from, from an
 * interrupted solve's state (`checkpoint_path` names its checkpoint in messages). Every recorded
 * iteration calls `on_iteration` (with the GIL) when given, and at most every 50 ms checks Python's
 * signals; a pending exception (KeyboardInterrupt from Ctrl-C, or one raised by on_iteration)
 * stops the solve, which ends `interrupted`. With request.checkpoint.dir (made before the solve),
 * an interrupted solve writes its checkpoint there and any other end removes it. The service's
 * memory refusal is a PardelError, running out of memory a MemoryError. The result dictionary (result_dict) holds besides
 * "checkpoint_written" and "pending": the exception that stopped the solve (None if none), which
 * the package raises, with "pending_trace" its traceback.
 */
py::dict run_solve(const Scene& scene, Trajectory trajectory, const py::object& on_iteration,
                   app::SolveRequest request, const std::string& checkpoint_path) {
  // The runtime continues no adaptive solve from a state: a checkpoint of one could not be resumed.
  if (!request.checkpoint.dir.empty() && scene.options.accuracy > 0 && !request.resume_from)
    throw app::CheckpointError("checkpoint: an adaptive solve (accuracy) cannot be resumed from a state, so it takes "
                               "no checkpoint; solve without checkpoint");
  if (!request.checkpoint.dir.empty()) {
    const std::string dir = request.checkpoint.dir;
    request.prepare = [dir] { make_checkpoint_folder(dir); };
  }
  request.over_ranks = false;

  std::unique_ptr<py::error_already_set> pending;
  bool stopped_by_callback = false;
  bool by_ctrl_c = false;  // a signal raised KeyboardInterrupt: the message names it, not on_iteration
  request.stopped_by = [&by_ctrl_c] { return by_ctrl_c ? std::string(kStoppedByCtrlC) : std::string(); };
  auto last_check = std::chrono::steady_clock::now();
  request.on_iteration = [&](const IterationRecord& record) {
    const auto now = std::chrono::steady_clock::now();
    if (on_iteration.is_none() && now - last_check < kSignalCheckPeriod) return true;
    last_check = now;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) {
      by_ctrl_c = PyErr_ExceptionMatches(PyExc_KeyboardInterrupt) != 0;
      pending = std::make_unique<py::error_already_set>();
      return false;
    }
    if (!on_iteration.is_none()) {
      try {
        const py::object answer = on_iteration(record.iteration, record.N, record.residual, record.action);
        // bool(answer) as Python takes it; an answer without a truth value (an array) raises its error
        const int truth = answer.is_none() ? 1 : PyObject_IsTrue(answer.ptr());
        if (truth < 0) throw py::error_already_set();
        if (truth == 0) {
          stopped_by_callback = true;
          return false;
        }
      } catch (py::error_already_set& error) {
        pending = std::make_unique<py::error_already_set>(std::move(error));
        return false;
      }
    }
    return true;
  };
  // The point assessment of a converged solve records no iteration: it polls Python's signals
  // through keep_going, so that Ctrl-C stops it too.
  request.keep_going = [&]() {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_check < kSignalCheckPeriod) return true;
    last_check = now;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return true;
    by_ctrl_c = PyErr_ExceptionMatches(PyExc_KeyboardInterrupt) != 0;
    pending = std::make_unique<py::error_already_set>();
    return false;
  };
  app::SolveRun run;
  try {
    py::gil_scoped_release release;
    run = app::run_solve(scene, trajectory, request);
  } catch (const app::MemoryRefused& refused) {
    throw InputError(refused.what());
  } catch (const app::OutOfMemory& error) {
    PyErr_SetString(PyExc_MemoryError, error.what());
    throw py::error_already_set();
  }
  const Summary& summary = run.summary;
  if (summary.termination == Termination::invalid_input) {
    if (pending) throw std::move(*pending);
    // A state that does not fit the scene: the checkpoint's fault, named as `pardel solve --resume` names it.
    if (request.resume_from) throw app::CheckpointError(fmt::format("{}: error: {}", checkpoint_path, summary.message));
    throw InputError(fmt::format("{}: error: {}", scene.path, summary.message));
  }
  py::dict result = result_dict(scene, summary, trajectory, stopped_by_callback);
  result["checkpoint_written"] = run.checkpoint_written;
  result["pending"] = pending && pending->value() ? pending->value() : py::none();
  result["pending_trace"] = pending && pending->trace() ? pending->trace() : py::none();
  return result;
}

/** The coordinate names of a scene's model (for pardel.Result). */
std::vector<std::string> scene_coords(const Scene& scene) {
  return std::vector<std::string>(scene.model->coords, scene.model->coords + scene.model->ncoords);
}

}  // namespace

/**
 * pardel.solve_scene: solves a scene from `guess` (None: the scene's guess). `checkpoint` (None:
 * none) names the folder of the checkpoint an interrupted solve writes; it records `scene_text`
 * (pardel.solve's scene, written beside it) when given, else the scene file `scene_file` read with
 * `overrides`, and `threads`.
 */
py::dict solve_scene(Scene scene, const py::object& guess, const py::object& guess_t, const py::object& on_iteration,
                     const py::object& threads, const py::object& checkpoint, const py::object& scene_text,
                     const py::object& scene_file, const std::vector<std::string>& overrides) {
  if (!threads.is_none()) scene.options.threads = threads.cast<int>();
  app::SolveRequest request;
  app::CheckpointPlan& plan = request.checkpoint;
  if (!checkpoint.is_none()) {
    plan.dir = checkpoint.cast<std::string>();
    if (plan.dir.empty()) throw app::CheckpointError("checkpoint: an empty path was given; name a folder");
    if (!scene_text.is_none()) {
      plan.scene_text = scene_text.cast<std::string>();
    } else {
      plan.scene_file = scene_file.cast<std::string>();
      plan.overrides = overrides;
    }
    plan.threads = threads.is_none() ? -1 : threads.cast<int>();
  }
  Trajectory trajectory = initial_trajectory(scene, guess, guess_t);
  return run_solve(scene, std::move(trajectory), on_iteration, std::move(request), "");
}

/**
 * pardel.resume: continues the interrupted solve whose checkpoint is DIR/checkpoint.json, as
 * `pardel solve --resume DIR` does: the scene is read again from its recorded path with its
 * recorded overrides, checked against the checkpoint (app::check_resumable; a checkpoint without
 * the model's digest issues its warning as a UserWarning), and solved from the recorded state with
 * the recorded threads unless `threads` is given. Solver `options` (pardel.solve's names) make it a
 * warm start from the recorded iterate with those options, as `--resume DIR --set solver.KEY=VALUE`
 * does; the checkpoint an interruption writes then records them too. An interruption writes the
 * checkpoint again into DIR; any other end removes it. The result dictionary also holds "coords",
 * the model's.
 */
py::dict resume_checkpoint(const std::string& dir, const py::object& threads, const py::object& on_iteration,
                           const py::dict& options) {
  if (dir.empty()) throw app::CheckpointError("checkpoint: an empty path was given; name a folder");
  const std::vector<std::string> warm = warm_start_overrides(options);
  app::Resumed resumed = app::resume_scene(dir, warm, resolve_spec, bundled_model_names());
  if (!resumed.warning.empty() && PyErr_WarnEx(PyExc_UserWarning, resumed.warning.c_str(), 1) != 0)
    throw py::error_already_set();
  const int recorded_threads = threads.is_none() ? resumed.checkpoint.threads : threads.cast<int>();
  if (recorded_threads >= 0) resumed.scene.options.threads = recorded_threads;
  py::dict result = run_solve(resumed.scene, Trajectory{}, on_iteration,
                              app::resume_request(resumed, dir, recorded_threads), resumed.checkpoint_path);
  result["coords"] = scene_coords(resumed.scene);
  return result;
}

}  // namespace pardel::python
