/**
 * @file bindings.hpp
 * What the sources of pardel's compiled Python core (pardel._pardel, the .cpp files of python/src/)
 * share: the error raised for refused input, model resolution with the GIL released, the scene made
 * from pardel.solve's keyword arguments, the conversions to NumPy arrays and Python values, and the entry points that
 * module.cpp binds. Internal to the module (not installed).
 */
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>  // in every file, so that all of them convert std::vector alike

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "pardel/app/scene.hpp"
#include "pardel/pardel.hpp"

namespace py = pybind11;

namespace pardel::python {

using app::Scene;
using app::SceneError;

/** Raised for input the runtime or the scene reader refuses (Python: pardel.PardelError). */
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** pardel.ModelWarning (a UserWarning), set when the module is initialized. */
extern PyObject* g_model_warning;

/** How often, at most, a solve, a sweep or a model compile looks at Python's signals. */
constexpr std::chrono::milliseconds kSignalCheckPeriod(50);

/** What stopped a solve that Ctrl-C (a KeyboardInterrupt) stopped, in the words of its message
 *  (app::name_interruption). */
constexpr const char* kStoppedByCtrlC = "Ctrl-C (KeyboardInterrupt)";

// ---------------------------------------------------------------------------------------------
// Models (models.cpp)

/** A compiled model as Python sees it; the pointer lives as long as the process. */
struct ModelHandle {
  const pardel_model* model = nullptr;
};

/** The Python exception (KeyboardInterrupt) that stopped the wait for a model compile, kept until
 *  the entry point that called the resolver raises it (the scene reader turns whatever its
 *  resolver throws into a SceneError); guarded by the GIL. */
std::unique_ptr<py::error_already_set>& interrupted_compile();

/** Joins the compiles left to finish in the background after Ctrl-C (registered with atexit). */
void join_background_compiles();

/** Runs `body` (an entry point that may resolve models) and raises a KeyboardInterrupt that
 *  stopped a compile inside it as itself, whatever the scene reader made of it. */
template <class Body>
auto raising_interrupts(Body&& body) -> decltype(body()) {
  try {
    return body();
  } catch (...) {
    if (interrupted_compile()) {
      std::unique_ptr<py::error_already_set> pending = std::move(interrupted_compile());
      throw std::move(*pending);
    }
    throw;
  }
}

/** A bundled name, or a .lag path compiled on first use with the GIL released; the generator's
 *  warnings are issued as a pardel.ModelWarning. Callers hold the GIL and are entry points wrapped
 *  in raising_interrupts. */
const pardel_model* resolve_spec(const std::string& spec);

/** The model `spec` names; InputError (with the nearest bundled name) for an unknown one. */
ModelHandle load_model(const std::string& spec);

// ---------------------------------------------------------------------------------------------
// Keyword arguments -> scene (scene_arguments.cpp)

/** The scene text (TOML) of pardel.solve's arguments; `complete`: the options outside the scene
 *  schema are written as scene keys too (what a checkpoint records). */
std::string scene_text(const std::string& model_spec, const py::dict& arguments, bool complete,
                       const ModelHandle* loaded = nullptr);

/** Parses scene text made by scene_text (named "pardel.solve" in messages). */
Scene parse_generated_scene(const std::string& text, const std::string& model_spec = {},
                            const ModelHandle* loaded = nullptr);

/** A scene from pardel.solve's arguments (their TOML table read by the scene reader, then the
 *  options outside the scene schema); `where` names the calling function in messages. */
Scene scene_from_arguments(const std::string& model_spec, const py::dict& arguments,
                           const ModelHandle* loaded = nullptr, const std::string& where = "pardel.solve");

/** A scene file read with `overrides` (as --set). */
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides);

/** pardel.resume's solver options as `--set solver.KEY=VALUE` overrides of a warm start. */
std::vector<std::string> warm_start_overrides(const py::dict& options);

// ---------------------------------------------------------------------------------------------
// Arrays and results (results.cpp)

py::array_t<double> matrix(const std::vector<double>& values, std::size_t rows, std::size_t cols);
py::array_t<double> vector(const std::vector<double>& values);

/** A JSON value (summary.json's) as the Python value json.loads makes of its text. */
py::object json_value(const nlohmann::ordered_json& value);

/** The initial trajectory: the scene's guess, or `guess` resampled to the scene's N. */
Trajectory initial_trajectory(const Scene& scene, const py::object& guess, const py::object& guess_t,
                              const char* name = "guess");

/** What pardel.Result is made of: summary.json's dictionary and the arrays. */
py::dict result_dict(const Scene& scene, const Summary& summary, const Trajectory& trajectory, bool stopped_by_callback);


// ---------------------------------------------------------------------------------------------
// Work on a worker thread (signals.cpp)

/** Runs `work` on a worker thread with the GIL released while this thread checks Python's
 *  signals; returns the pending exception that set `stop` (nullptr when none). */
std::unique_ptr<py::error_already_set> watching_signals(const std::function<void()>& work, std::atomic<bool>& stop);

// ---------------------------------------------------------------------------------------------
// Entry points (solve.cpp, batch.cpp, check.cpp, sweep.cpp, info.cpp)

py::dict solve_scene(Scene scene, const py::object& guess, const py::object& guess_t, const py::object& on_iteration,
                     const py::object& threads, const py::object& checkpoint, const py::object& scene_text,
                     const py::object& scene_file, const std::vector<std::string>& overrides);
py::dict resume_checkpoint(const std::string& dir, const py::object& threads, const py::object& on_iteration,
                           const py::dict& options);
py::dict solve_batch_scene(Scene scene, const py::object& q0, const py::object& qN, const py::object& params,
                           const py::object& guess, const py::object& threads);
py::object check_scene(Scene scene, const py::object& q, const py::object& t);
py::dict kernels(const ModelHandle& handle, const std::string& discretization, double h, double t0, double t1,
                 const std::vector<double>& q0, const std::vector<double>& q1, const std::vector<double>& params);
py::dict run_sweep(const std::string& path, const std::vector<std::string>& overrides, int threads,
                   const std::string& out);
py::dict model_info(const ModelHandle& handle);
py::dict scene_info(const Scene& scene);

}  // namespace pardel::python
