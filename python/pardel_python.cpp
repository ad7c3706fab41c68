/**
 * @file pardel_python.cpp
 * The compiled part of the Python module `pardel` (pardel._pardel): a translation layer over the
 * runtime (pardel::runtime), the model loader (pardel::model_loader) and the application library
 * (pardel::app: the scene reader, summary.json, sweeps). Keyword arguments of pardel.solve are
 * written as a scene (a TOML table) and read by the scene reader, so their checks and messages are
 * those of `pardel solve` (the package checks the arguments' types before); solves and .lag
 * compiles run with the GIL released and stop at Ctrl-C (solves through Options::on_iteration);
 * results come back as NumPy arrays and summary.json's dictionary (as text).
 * Sweeps are pardel::app's (`pardel sweep` without its command line): the variants run on a worker
 * thread while the calling thread watches for Ctrl-C. Checkpoints are pardel::app's too (the files,
 * checks and messages of `pardel solve` and `pardel solve --resume`).
 */
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <new>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "pardel/memory.hpp"
#include "pardel/app/checkpoint.hpp"
#include "pardel/app/outputs.hpp"
#include "pardel/model_loader.hpp"
#include "pardel/pardel.hpp"
#ifdef PARDEL_HAVE_CUDA
#include "pardel/cuda.hpp"
#endif
#include "pardel/app/scene.hpp"
#include "pardel/app/solve.hpp"
#include "pardel/app/sweep.hpp"
#include "pardel/app/trajectory_io.hpp"

namespace py = pybind11;
using namespace pardel;
using pardel::app::Scene;
using pardel::app::SceneError;

namespace {

/** Raised for input the runtime or the scene reader refuses (Python: pardel.PardelError). */
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** pardel.ModelWarning (a UserWarning), set when the module is initialized. */
PyObject* g_model_warning = nullptr;

/** How often, at most, a solve, a sweep or a model compile looks at Python's signals. */
constexpr std::chrono::milliseconds kSignalCheckPeriod(50);

/** The Python exception (KeyboardInterrupt) that stopped the wait for a model compile, kept until
 *  the entry point that called the resolver raises it (the scene reader turns whatever its
 *  resolver throws into a SceneError); guarded by the GIL. Never freed (freeing a Python object
 *  after the interpreter is gone would crash at exit). */
std::unique_ptr<py::error_already_set>& interrupted_compile() {
  static auto* pending = new std::unique_ptr<py::error_already_set>;
  return *pending;
}

/** Compiles left to finish in the background after Ctrl-C; joined at exit (atexit). Never freed:
 *  a std::thread still joinable when destroyed would end the process. */
std::vector<std::thread>& background_compiles() {
  static auto* threads = new std::vector<std::thread>;
  return *threads;
}

void join_background_compiles() {
  std::vector<std::thread> threads;
  threads.swap(background_compiles());
  py::gil_scoped_release release;
  for (std::thread& t : threads) t.join();
}

/** Raised where the wait for a compile was interrupted; the entry point raises the Python
 *  exception kept in interrupted_compile() instead. */
struct CompileInterrupted : std::runtime_error {
  CompileInterrupted() : std::runtime_error("interrupted while compiling a model") {}
};

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

/** pardel::resolve_model with the GIL released: a .lag file is compiled (seconds) on a worker
 *  thread while this one checks Python's signals every 50 ms, so other Python threads run during
 *  the compile and Ctrl-C stops the wait at once (KeyboardInterrupt); the compile then finishes in
 *  the background and its cache entry is complete for the next load. A bundled name is found at
 *  once, with the GIL. */
const pardel_model* resolve_releasing_gil(const std::string& spec) {
  const bool path = spec.find('/') != std::string::npos ||
                    (spec.size() >= 4 && spec.compare(spec.size() - 4, 4, ".lag") == 0);
  if (!path) return pardel::resolve_model(spec);
  struct Job {
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    const pardel_model* model = nullptr;
    std::exception_ptr failure;
  };
  auto job = std::make_shared<Job>();
  std::thread worker([job, spec] {
    const pardel_model* model = nullptr;
    std::exception_ptr failure;
    try {
      model = pardel::resolve_model(spec);
    } catch (...) {
      failure = std::current_exception();
    }
    {
      const std::lock_guard<std::mutex> lock(job->mutex);
      job->model = model;
      job->failure = failure;
      job->done = true;
    }
    job->finished.notify_all();
  });
  std::unique_ptr<py::error_already_set> pending;
  {
    py::gil_scoped_release release;
    std::unique_lock<std::mutex> lock(job->mutex);
    while (!job->finished.wait_for(lock, kSignalCheckPeriod, [&job] { return job->done; })) {
      lock.unlock();
      {
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) pending = std::make_unique<py::error_already_set>();
      }
      if (pending) break;
      lock.lock();
    }
  }
  if (pending) {
    background_compiles().push_back(std::move(worker));
    interrupted_compile() = std::move(pending);
    throw CompileInterrupted();
  }
  worker.join();
  if (job->failure) std::rethrow_exception(job->failure);
  return job->model;
}

/** A bundled name, or a .lag path compiled on first use (the CLI's resolver) with the GIL
 *  released. The generator's warnings about a .lag model (model_warnings: kept with its cache
 *  entry, so also when an earlier process compiled it) are issued as a pardel.ModelWarning, once
 *  per model and process. Every caller holds the GIL (models are resolved before a solve or sweep
 *  releases it) and is an entry point wrapped in raising_interrupts. */
const pardel_model* resolve_spec(const std::string& spec) {
  const pardel_model* model = resolve_releasing_gil(spec);
  static std::vector<const pardel_model*> reported;
  if (model && std::find(reported.begin(), reported.end(), model) == reported.end()) {
    reported.push_back(model);
    const std::string warnings = pardel::model_warnings(model);
    // -1: a warnings filter made it an exception, which propagates (a scene reports it as its error)
    if (!warnings.empty() && PyErr_WarnEx(g_model_warning, warnings.c_str(), 1) != 0) throw py::error_already_set();
  }
  return model;
}

/** A compiled model as Python sees it; the pointer lives as long as the process. */
struct ModelHandle {
  const pardel_model* model = nullptr;
};

ModelHandle load_model(const std::string& spec) {
  const pardel_model* model = resolve_spec(spec);
  if (!model) {
    std::string message = fmt::format("unknown model '{}'", spec);
    const std::string suggestion = app::nearest_name(spec, bundled_model_names());
    if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
    throw InputError(message);
  }
  return {model};
}

// ---------------------------------------------------------------------------------------------
// Keyword arguments -> scene

/** The keyword arguments pardel.solve passes on, with the scene key each one becomes ("" when it
 *  is an option outside the scene schema, set on pardel::Options directly). */
const std::vector<std::pair<std::string, std::string>> kArguments = {
    {"discretization", "discretization"},
    {"params", "params"},
    {"t0", "grid.t0"},
    {"T", "grid.T"},
    {"N", "grid.N"},
    {"q0", "boundary"},
    {"qN", "boundary"},
    {"knots", "knots"},
    {"polyline", "guess.points"},
    {"clock", "solver.clock"},
    {"method", "solver.method"},
    {"tol", "solver.tol"},
    {"rtol", "solver.rtol"},
    {"max_iterations", "solver.max_iterations"},
    {"damping", "solver.damping"},
    {"newton_substeps", "solver.newton_substeps"},
    {"newton_shift", "solver.newton_shift"},
    {"linear_solver", "solver.linear_solver"},
    {"device", "solver.device"},
    {"threads", "solver.threads"},
    {"refine_start_N", "solver.refine.start_N"},
    {"refine_factor", "solver.refine.factor"},
    {"clock_update_every", "solver.clock_update_every"},
    {"error_estimate", "solver.error_estimate"},
    {"extrapolate", "solver.extrapolate"},
    {"accuracy", "grid.accuracy"},
    {"accuracy_max_N", "grid.accuracy_max_N"},
    {"history_every", ""},
    {"refine_settle", ""},
    {"divergence_factor", ""},
};

/** The scene keys under which a checkpoint's scene records the options that kArguments keeps
 *  outside the scene schema (scene_text's complete text; pardel.resume's warm start). */
const std::vector<std::pair<std::string, std::string>> kRecordedArguments = {
    {"history_every", "solver.history_every"},
    {"divergence_factor", "solver.divergence_factor"},
    {"refine_settle", "solver.refine.settle"}};

std::vector<std::string> argument_names() {
  std::vector<std::string> names;
  for (const auto& a : kArguments) names.push_back(a.first);
  return names;
}

/** A TOML array from a Python sequence or NumPy array of numbers, strings or sequences
 *  (booleans refused). */
/** Whether a Python value is a number (int, float or a NumPy scalar; not a bool). */
bool is_number(const py::handle& value) {
  return !py::isinstance<py::bool_>(value) && !py::isinstance<py::str>(value) &&
         !py::isinstance<py::sequence>(value) && py::hasattr(value, "__float__");
}

std::string type_name(const py::handle& value) {
  return py::str(py::type::handle_of(value).attr("__name__")).cast<std::string>();
}

toml::array to_toml_array(const py::handle& value, const std::string& name) {
  if (py::isinstance<py::str>(value) || !py::isinstance<py::sequence>(value))
    throw InputError(fmt::format("{}: a sequence was expected, got {}", name, type_name(value)));
  toml::array array;
  const py::sequence seq = py::reinterpret_borrow<py::sequence>(value);
  for (std::size_t i = 0; i < seq.size(); ++i) {
    const py::object item = seq[i];
    if (is_number(item)) {
      array.push_back(item.attr("__float__")().cast<double>());
    } else if (py::isinstance<py::str>(item)) {
      array.push_back(item.cast<std::string>());
    } else if (py::isinstance<py::sequence>(item)) {
      array.push_back(to_toml_array(item, fmt::format("{}[{}]", name, i)));
    } else {
      throw InputError(fmt::format("{}[{}]: a number was expected, got {}", name, i, type_name(item)));
    }
  }
  return array;
}

/** Inserts a Python value under `key`: integers stay integers (grid.N, solver.threads, ...). */
void insert(toml::table& table, const std::string& key, const py::handle& value, const std::string& name) {
  if (py::isinstance<py::bool_>(value)) throw InputError(fmt::format("{}: a number was expected, got a bool", name));
  if (py::isinstance<py::str>(value)) {
    table.insert_or_assign(key, value.cast<std::string>());
  } else if (py::isinstance<py::int_>(value) || (is_number(value) && py::hasattr(value, "__index__"))) {
    table.insert_or_assign(key, value.attr("__index__")().cast<long long>());
  } else if (is_number(value)) {
    table.insert_or_assign(key, value.attr("__float__")().cast<double>());
  } else if (py::isinstance<py::sequence>(value)) {
    table.insert_or_assign(key, to_toml_array(value, name));
  } else {
    throw InputError(fmt::format("{}: cannot use a value of type {}", name, type_name(value)));
  }
}

toml::table& subtable(toml::table& root, const std::string& key) {
  if (!root.contains(key)) root.insert(key, toml::table{});
  return *root.get_as<toml::table>(key);
}

/** The table under `root` that holds the dotted scene key `key` ([solver.refine] for
 *  solver.refine.start_N), made where missing; `key` is left as its last part. */
toml::table& dotted_table(toml::table& root, std::string& key) {
  toml::table* table = &root;
  for (std::size_t dot; (dot = key.find('.')) != std::string::npos; key = key.substr(dot + 1))
    table = &subtable(*table, key.substr(0, dot));
  return *table;
}

/** Splits a boundary vector (dim values: coords, then derivatives) into the scene's keys
 *  (q0, v0, a0, ...); a vector of another size goes to q0 whole, where the reader reports it. */
void insert_boundary(toml::table& boundary, const pardel_model& model, const py::handle& value, const char* end,
                     const std::string& name) {
  toml::array values = to_toml_array(value, name);
  const std::size_t nc = static_cast<std::size_t>(model.ncoords);
  if (values.size() != static_cast<std::size_t>(model.dim) || model.order == 1) {
    boundary.insert_or_assign(std::string("q") + end, std::move(values));
    return;
  }
  for (int d = 0; d < model.order; ++d) {
    toml::array part;
    for (std::size_t i = 0; i < nc; ++i) part.push_back(*values.get(d * nc + i));
    boundary.insert_or_assign(app::boundary_prefix(d) + end, std::move(part));
  }
}

/** The scene reader's message with the position inside the generated text left out: that text is
 *  not the user's (the key names the argument). */
std::string without_generated_position(const std::string& message, const std::string& source) {
  const std::string prefix = source + ":";
  if (message.rfind(prefix, 0) != 0) return message;
  static const std::regex position("^[0-9]+:[0-9]+: ");
  const std::string rest = message.substr(prefix.size());
  return source + ": " + std::regex_replace(rest, position, "", std::regex_constants::format_first_only);
}

/** The scene text (TOML) of pardel.solve's arguments: the model (a bundled name or a .lag path),
 *  then the keyword arguments of kArguments (None values are left out). `complete`: the options
 *  outside kArguments' scene keys are written as scene keys too (solver.history_every,
 *  solver.divergence_factor, solver.refine.settle), so that the text alone gives the solve's
 *  options (what a checkpoint records); solver.refine.settle needs solver.refine.start_N. */
std::string scene_text(const std::string& model_spec, const py::dict& arguments, bool complete,
                       const ModelHandle* loaded = nullptr) {
  const std::vector<std::string> names = argument_names();
  for (const auto& item : arguments) {
    const std::string key = py::str(item.first).cast<std::string>();
    bool known = false;
    for (const auto& n : names) known = known || n == key;
    if (!known) {
      std::string message = fmt::format("unknown option '{}'", key);
      const std::string suggestion = app::nearest_name(key, names);
      if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
      message += " (options: " + fmt::format("{}", fmt::join(names, ", ")) + ")";
      throw InputError(message);
    }
  }
  const ModelHandle handle = loaded ? *loaded : load_model(model_spec);
  const pardel_model& model = *handle.model;

  toml::table root;
  root.insert("model", model_spec);
  for (const auto& a : kArguments) {
    const std::string& name = a.first;
    if (!arguments.contains(name.c_str())) continue;
    const py::object value = arguments[name.c_str()];
    if (value.is_none() || a.second.empty()) continue;
    if (name == "params") {
      toml::table& params = subtable(root, "params");
      if (py::isinstance<py::dict>(value)) {
        for (const auto& p : py::reinterpret_borrow<py::dict>(value)) {
          const std::string pname = py::str(p.first).cast<std::string>();
          insert(params, pname, p.second, "params." + pname);
        }
      } else {
        const toml::array list = to_toml_array(value, "params");
        if (list.size() != static_cast<std::size_t>(model.nparams))
          throw InputError(fmt::format("params: {} values given; model {} has {} params (give a dict to name them)",
                                       list.size(), model.name, model.nparams));
        for (int i = 0; i < model.nparams; ++i) params.insert_or_assign(model.param_names[i], *list.get(i));
      }
    } else if (name == "q0" || name == "qN") {
      insert_boundary(subtable(root, "boundary"), model, value, name == "q0" ? "0" : "N", name);
    } else if (name == "knots") {
      toml::array knots;
      py::sequence seq = py::reinterpret_borrow<py::sequence>(value);
      for (std::size_t i = 0; i < seq.size(); ++i) {
        const std::string kname = fmt::format("knots[{}]", i);
        py::sequence pair = seq[i];
        if (pair.size() != 2) throw InputError(fmt::format("{}: a pair (t, q) was expected", kname));
        toml::table knot;
        insert(knot, "t", pair[0], kname + ".t");
        insert(knot, "q", pair[1], kname + ".q");
        knots.push_back(std::move(knot));
      }
      root.insert_or_assign("knots", std::move(knots));
    } else if (name == "polyline") {
      toml::table& guess = subtable(root, "guess");
      guess.insert_or_assign("kind", "polyline");
      insert(guess, "points", value, "polyline");
    } else {
      // a dotted scene key: [grid] T, [solver] tol, [solver.refine] start_N, ...
      std::string key = a.second;
      toml::table& table = dotted_table(root, key);
      if ((name == "error_estimate" || name == "extrapolate") && py::isinstance<py::bool_>(value))
        table.insert_or_assign(key, value.cast<bool>());  // the scene's true or false
      else
        insert(table, key, value, name);
    }
  }
  if (complete) {
    const auto given = [&arguments](const char* name) {
      return arguments.contains(name) && !arguments[name].is_none();
    };
    if (given("refine_settle") && !given("refine_start_N"))
      throw InputError("checkpoint: refine_settle is recorded in a checkpoint's scene as solver.refine.settle, "
                       "which needs refine_start_N; give refine_start_N too, or no checkpoint");
    for (const auto& r : kRecordedArguments) {
      if (!given(r.first.c_str())) continue;
      std::string key = r.second;
      toml::table& table = dotted_table(root, key);
      insert(table, key, arguments[r.first.c_str()], r.first);
    }
  }
  std::ostringstream text;
  text << root;
  return text.str();
}

/** Parses scene text made by scene_text (named "pardel.solve" in messages, without positions in
 *  the generated text); `loaded`, when given, is the model the text names as `model_spec`. */
Scene parse_generated_scene(const std::string& text, const std::string& model_spec = {},
                            const ModelHandle* loaded = nullptr) {
  const std::string source = "pardel.solve";
  const app::ModelResolver resolve = [&](const std::string& spec) {
    return loaded && spec == model_spec ? loaded->model : resolve_spec(spec);
  };
  try {
    return app::parse_scene(text, source, {}, resolve, bundled_model_names());
  } catch (const SceneError& error) {
    throw SceneError(without_generated_position(error.what(), source));
  }
}

/** A scene from pardel.solve's arguments (scene_text, then the options outside the scene schema).
 *  `loaded`: the model a pardel.Model holds for model_spec, used instead of resolving the spec again
 *  (for a .lag path that is reading, hashing and checking the file and its cached library: about
 *  0.5 ms a call). */
Scene scene_from_arguments(const std::string& model_spec, const py::dict& arguments,
                           const ModelHandle* loaded = nullptr) {
  Scene scene = parse_generated_scene(scene_text(model_spec, arguments, false, loaded), model_spec, loaded);
  // Options outside the scene schema.
  auto number = [&arguments](const char* name, auto* target) {
    if (arguments.contains(name) && !arguments[name].is_none())
      *target = arguments[name].cast<std::remove_pointer_t<decltype(target)>>();
  };
  number("history_every", &scene.options.history_every);
  number("refine_settle", &scene.options.refine_settle);
  number("divergence_factor", &scene.options.divergence_factor);
  std::string error;
  if (!scene.options.is_valid(&error)) throw InputError(error);
  return scene;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  return app::load_scene(path, overrides, resolve_spec, bundled_model_names());
}

// ---------------------------------------------------------------------------------------------
// Solving

py::array_t<double> matrix(const std::vector<double>& values, std::size_t rows, std::size_t cols) {
  py::array_t<double> out({rows, cols});
  std::copy(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rows * cols), out.mutable_data());
  return out;
}

py::array_t<double> vector(const std::vector<double>& values) {
  py::array_t<double> out(values.size());
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}

/** The initial trajectory: the scene's guess, or `guess` ((M+1) x dim rows, resampled to the
 *  scene's N when M differs; node times `guess_t` when given, else uniform). */
Trajectory initial_trajectory(const Scene& scene, const py::object& guess, const py::object& guess_t) {
  if (guess.is_none()) return app::make_initial_guess(scene);
  const Problem& problem = scene.problem;
  const int dim = scene.model->dim;
  const auto q = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(guess);
  if (!q) throw InputError("guess: a 2-D array of numbers was expected");
  if (q.ndim() != 2 || q.shape(1) != dim || q.shape(0) < 2)
    throw InputError(fmt::format("guess: shape ({}) given; expected (N+1, {}) (model {} has dim {}: {})",
                                 fmt::join(std::vector<py::ssize_t>(q.shape(), q.shape() + q.ndim()), ", "), dim,
                                 scene.model->name, dim, scene.model->order == 1 ? "its coords" : "coords, then derivatives"));
  Trajectory from;
  from.N = static_cast<int>(q.shape(0) - 1);
  from.dim = dim;
  from.q.assign(q.data(), q.data() + q.size());
  from.t.resize(static_cast<std::size_t>(from.N) + 1);
  if (!guess_t.is_none()) {
    const auto t = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(guess_t);
    if (!t || t.ndim() != 1 || t.shape(0) != from.N + 1)
      throw InputError(fmt::format("guess_t: {} node times were expected", from.N + 1));
    from.t.assign(t.data(), t.data() + t.size());
  } else {
    for (int k = 0; k <= from.N; ++k) from.t[static_cast<std::size_t>(k)] = problem.t0 + problem.T * k / from.N;
  }
  if (from.N == problem.N) return from;
  return resample(problem, from, problem.N);
}

/** What pardel.Result is made of: summary.json's dictionary (as text), the trajectory, the
 *  boundary momenta and the history as arrays. */
py::dict result_dict(const Scene& scene, const Summary& summary, const Trajectory& trajectory, bool stopped_by_callback) {
  py::dict result;
  const std::string model_source = app::scene_model_source(scene);
  // Paths that are not UTF-8 are written with U+FFFD for their invalid bytes, as in summary.json.
  result["summary"] = app::summary_json(scene, summary, trajectory, Certificate{}, model_source)
                          .dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  result["stopped_by_callback"] = stopped_by_callback;
  result["t"] = vector(trajectory.t);
  result["q"] = matrix(trajectory.q, static_cast<std::size_t>(trajectory.N) + 1, static_cast<std::size_t>(trajectory.dim));
  const BoundaryMomenta momenta = app::momenta_on_trajectory_grid(scene.problem, trajectory);
  result["p0"] = vector(momenta.p0);
  result["pN"] = vector(momenta.pN);
  const std::size_t n = summary.history.size();
  std::vector<double> it(n), N(n), res(n), act(n), sec(n);
  for (std::size_t i = 0; i < n; ++i) {
    it[i] = static_cast<double>(summary.history[i].iteration);
    N[i] = summary.history[i].N;
    res[i] = summary.history[i].residual;
    act[i] = summary.history[i].action;
    sec[i] = summary.history[i].seconds;
  }
  py::dict history;
  history["iteration"] = vector(it).attr("astype")("int64");
  history["N"] = vector(N).attr("astype")("int64");
  history["residual"] = vector(res);
  history["action"] = vector(act);
  history["seconds"] = vector(sec);
  result["history"] = history;
  return result;
}

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
  auto last_check = std::chrono::steady_clock::now();
  request.on_iteration = [&](const IterationRecord& record) {
    const auto now = std::chrono::steady_clock::now();
    if (on_iteration.is_none() && now - last_check < kSignalCheckPeriod) return true;
    last_check = now;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) {
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

/** pardel.resume's solver options as `pardel solve --resume DIR --set solver.KEY=VALUE` overrides
 *  (their scene keys from kArguments and kRecordedArguments). An option of the problem (T, N, q0, params, ...) is refused:
 *  a warm start keeps the recorded problem and changes how it is solved. */
std::vector<std::string> warm_start_overrides(const py::dict& options) {
  std::vector<std::string> names, out;
  for (const auto& a : kArguments)
    if (a.first != "threads") names.push_back(a.first);
  for (const auto& item : options) {
    const std::string name = py::str(item.first).cast<std::string>();
    if (item.second.is_none()) continue;
    std::string key;
    for (const auto& a : kArguments)
      if (a.first == name && name != "threads") key = a.second;
    for (const auto& r : kRecordedArguments)
      if (r.first == name) key = r.second;
    if (key.empty()) {
      std::string message = fmt::format("unknown option '{}'", name);
      const std::string suggestion = app::nearest_name(name, names);
      if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
      throw InputError(message);
    }
    if (key.rfind("solver.", 0) != 0)
      throw InputError(fmt::format("{}: changes the problem (scene key {}); only solver options may change a "
                                   "resumed solve (a warm start from its iterate)",
                                   name, key));
    toml::table value;
    if ((name == "error_estimate" || name == "extrapolate") && py::isinstance<py::bool_>(item.second))
      value.insert_or_assign("v", item.second.cast<bool>());
    else
      insert(value, "v", item.second, name);
    std::ostringstream text;
    text << value["v"];
    out.push_back(key + "=" + text.str());
  }
  return out;
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

/**
 * Runs `work` on a worker thread with the GIL released while this thread checks Python's signals
 * every 50 ms; a pending exception (KeyboardInterrupt) sets `stop`, and is returned once the work
 * has ended (nullptr when none). An exception of the work is rethrown here.
 */
std::unique_ptr<py::error_already_set> watching_signals(const std::function<void()>& work, std::atomic<bool>& stop) {
  std::exception_ptr failure;
  std::unique_ptr<py::error_already_set> pending;
  {
    py::gil_scoped_release release;
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    std::thread worker([&] {
      try {
        work();
      } catch (...) {
        failure = std::current_exception();
      }
      {
        const std::lock_guard<std::mutex> lock(mutex);
        done = true;
      }
      finished.notify_one();
    });
    std::unique_lock<std::mutex> lock(mutex);
    while (!finished.wait_for(lock, kSignalCheckPeriod, [&done] { return done; })) {
      if (pending) continue;
      lock.unlock();
      {
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
          pending = std::make_unique<py::error_already_set>();
          stop.store(true);
        }
      }
      lock.lock();
    }
    lock.unlock();
    worker.join();
  }
  if (failure) std::rethrow_exception(failure);
  return pending;
}

/** A 2-D (rows x cols) or 3-D array argument of pardel.solve_batch as float64, its shape checked
 *  against `expected` (-1: any), the message naming the argument. */
py::array_t<double, py::array::c_style | py::array::forcecast> batch_array(const py::object& value, const char* name,
                                                                          std::vector<py::ssize_t> expected,
                                                                          const std::string& what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  bool fits = a && a.ndim() == static_cast<py::ssize_t>(expected.size());
  for (std::size_t i = 0; fits && i < expected.size(); ++i) fits = expected[i] < 0 || a.shape(i) == expected[i];
  if (!fits) {
    const std::string shape = a ? fmt::format("({})", fmt::join(std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim()), ", "))
                                : "no array";
    throw InputError(fmt::format("{}: shape {} given; expected {}", name, shape, what));
  }
  return a;
}

/**
 * pardel.solve_batch: B problems that differ from `scene` in q0, qN (B x dim), params (B x nparams,
 * or None: the scene's) and guess (B x (M+1) x dim, resampled to N as solve_scene does; None: the
 * scene's guess), solved by pardel::solve_batch with the GIL released while this thread watches for
 * Ctrl-C (which stops the batch and is raised once it has stopped). `threads`: problems at once.
 * A batch refused as a whole (memory) raises PardelError; each problem's result is solve_scene's,
 * a problem never started (interrupted) holding its initial guess.
 */
py::dict solve_batch_scene(Scene scene, const py::object& q0, const py::object& qN, const py::object& params,
                           const py::object& guess, const py::object& threads) {
  if (!threads.is_none()) scene.options.threads = threads.cast<int>();
  const pardel_model& model = *scene.model;
  const py::ssize_t dim = model.dim, np = model.nparams;
  const auto q0s = batch_array(q0, "q0", {-1, dim}, fmt::format("(B, {}) (model {} has dim {})", dim, model.name, dim));
  const py::ssize_t B = q0s.shape(0);
  const auto qNs = batch_array(qN, "qN", {B, dim}, fmt::format("({}, {}), as q0", B, dim));
  std::vector<BatchProblem> problems(static_cast<std::size_t>(B));
  std::vector<Scene> scenes(static_cast<std::size_t>(B), scene);
  py::array_t<double, py::array::c_style | py::array::forcecast> ps;
  if (!params.is_none()) ps = batch_array(params, "params", {B, np}, fmt::format("({}, {}) (model {} has {} params)", B, np, model.name, np));
  py::array_t<double, py::array::c_style | py::array::forcecast> gs;
  if (!guess.is_none()) gs = batch_array(guess, "guess", {B, -1, dim}, fmt::format("({}, M+1, {})", B, dim));
  const bool have_params = !params.is_none(), have_guess = !guess.is_none();
  if (have_guess && gs.shape(1) < 2) throw InputError("guess: at least 2 nodes per problem were expected");
  for (py::ssize_t i = 0; i < B; ++i) {
    Problem& problem = scenes[static_cast<std::size_t>(i)].problem;
    problem.q0.assign(q0s.data(i, 0), q0s.data(i, 0) + dim);
    problem.qN.assign(qNs.data(i, 0), qNs.data(i, 0) + dim);
    if (have_params) problem.params.assign(ps.data(i, 0), ps.data(i, 0) + np);
    BatchProblem& b = problems[static_cast<std::size_t>(i)];
    b.q0 = problem.q0;
    b.qN = problem.qN;
    b.params = problem.params;
    if (have_guess)
      b.guess = initial_trajectory(scenes[static_cast<std::size_t>(i)], py::array(gs[py::int_(i)]), py::none());
    else if (scene.guess.kind != app::GuessKind::linear)
      b.guess = app::make_initial_guess(scenes[static_cast<std::size_t>(i)]);
  }
  std::atomic<bool> stop{false};
  scene.options.on_iteration = nullptr;
  scene.options.keep_going = [&stop] { return !stop.load(std::memory_order_relaxed); };
  BatchSummary batch;
  std::unique_ptr<py::error_already_set> pending =
      watching_signals([&] { batch = pardel::solve_batch(scene.problem, scene.options, problems); }, stop);
  if (pending) throw std::move(*pending);
  if (!batch.refusal.empty()) throw InputError(fmt::format("{}: {}", scene.path, batch.refusal));
  py::list results;
  for (py::ssize_t i = 0; i < B; ++i) {
    BatchEntry& e = batch.entries[static_cast<std::size_t>(i)];
    const Scene& s = scenes[static_cast<std::size_t>(i)];
    if (e.trajectory.N == 0) {  // never started: its initial guess
      const BatchProblem& b = problems[static_cast<std::size_t>(i)];
      e.trajectory = b.guess.N > 0 ? b.guess : linear_guess(s.problem);
    }
    results.append(result_dict(s, e.summary, e.trajectory, false));
  }
  py::dict out;
  out["results"] = results;
  out["threads"] = batch.threads;
  out["wall_seconds"] = batch.wall_seconds;
  return out;
}

/** `pardel check`: the certificate, residual and action at a trajectory (the scene's guess when
 *  q is None), as JSON text in the layout of `pardel check --json` (app::certificate_json, every
 *  member of pardel::Certificate), the certificate dictionary with one more key: report (the text
 *  `pardel check` prints). */
std::string check_scene(Scene scene, const py::object& q, const py::object& t) {
  Trajectory trajectory = initial_trajectory(scene, q, t);
  if (!q.is_none()) scene.problem.N = trajectory.N;
  Certificate certificate;
  double residual = 0, action = 0;
  {
    py::gil_scoped_release release;
    certificate = certify(scene.problem, trajectory, scene.options.threads);
    residual = residual_norm(scene.problem, trajectory);
    action = discrete_action(scene.problem, trajectory);
  }
  nlohmann::ordered_json j;
  j["trajectory"] = q.is_none() ? "initial guess" : "given";
  j["N"] = trajectory.N;
  j["residual"] = residual;
  j["action"] = action;
  nlohmann::ordered_json c = app::certificate_json(certificate, static_cast<std::size_t>(-1));
  c["report"] = certificate.report();
  j["certificate"] = std::move(c);
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

// ---------------------------------------------------------------------------------------------
// Sweeps

/**
 * `pardel sweep` without its command line: reads the sweep file (`overrides` as --set), solves
 * every variant with pardel::app's run_variants_over_ranks (one rank) on a worker thread, the GIL
 * released, while this thread checks Python's signals every 50 ms; a pending exception
 * (KeyboardInterrupt) stops the running solve, the variants not yet started end "interrupted", and
 * it is raised once the results are grouped (and written to `out` when given). The results come
 * back as plain values, sweep.json's dictionary as text, and the trajectories of the converged
 * variants as arrays.
 */
py::dict run_sweep(const std::string& path, const std::vector<std::string>& overrides, int threads,
                   const std::string& out) {
  const app::Sweep sweep = app::load_sweep(path, overrides, resolve_spec, bundled_model_names());
  std::atomic<bool> stop{false};
  std::vector<app::VariantResult> results;
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<py::error_already_set> pending =
      watching_signals([&] { results = app::run_variants_over_ranks(sweep, threads, 0, 1, {}, &stop); }, stop);

  app::SweepRunInfo info;
  info.ranks = 1;
  info.threads = threads > 0 ? threads : sweep.configurations.front().options.threads;
  info.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::vector<int> solution_of;
  const std::vector<app::Solution> solutions = app::group_solutions(results, sweep.grouping, &solution_of);
  if (!out.empty()) app::write_sweep_outputs(sweep, results, solutions, solution_of, info, out);
  if (pending) throw std::move(*pending);

  py::list variants;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const app::VariantResult& r = results[i];
    const app::Variant v = app::make_variant(sweep, r.id);
    py::dict d;
    d["id"] = r.id;
    d["configuration"] = r.configuration;
    d["guess"] = v.guess_label;
    d["guess_points"] = v.points;
    d["status"] = r.status;
    d["message"] = r.message;
    d["iterations"] = r.iterations;
    d["residual"] = r.residual;
    d["action"] = r.action;
    d["cost"] = r.cost;
    d["seconds"] = r.seconds;
    d["certificate"] = r.converged() ? py::object(py::str(app::certificate_verdict(r))) : py::object(py::none());
    d["solution"] = i < solution_of.size() && solution_of[i] > 0 ? py::object(py::int_(solution_of[i])) : py::none();
    if (r.converged()) {
      d["t"] = vector(r.trajectory.t);
      d["q"] = matrix(r.trajectory.q, static_cast<std::size_t>(r.trajectory.N) + 1,
                      static_cast<std::size_t>(r.trajectory.dim));
    } else {
      d["t"] = py::none();
      d["q"] = py::none();
    }
    variants.append(d);
  }
  py::list groups;
  for (const app::Solution& s : solutions) {
    py::dict d;
    d["id"] = s.id;
    d["configuration"] = s.configuration;
    d["rank"] = s.rank;
    d["first_variant"] = s.first_variant;
    d["variants"] = s.variants;
    d["cost"] = s.cost;
    d["action"] = s.action;
    d["residual"] = s.residual;
    groups.append(d);
  }
  py::dict result;
  result["summary"] =
      app::sweep_json(sweep, results, solutions, info).dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  result["axes"] = [&sweep] {
    std::vector<std::string> keys;
    for (const auto& axis : sweep.axes) keys.push_back(axis.key);
    return keys;
  }();
  result["configuration_values"] = sweep.configuration_values;
  result["variants"] = variants;
  result["solutions"] = groups;
  return result;
}

/** The kernels of a model at one interval (what `pardel kernels` prints). */
py::dict kernels(const ModelHandle& handle, const std::string& discretization, double h, double t0, double t1,
                 const std::vector<double>& q0, const std::vector<double>& q1, const std::vector<double>& params) {
  const pardel_model& model = *handle.model;
  const pardel_discretization* disc = find_discretization(model, discretization);
  if (!disc) throw InputError(fmt::format("unknown discretization '{}' for model {}", discretization, model.name));
  const std::size_t m = static_cast<std::size_t>(model.dim);
  if (q0.size() != m || q1.size() != m)
    throw InputError(fmt::format("q0 and q1 need {} values each (model {} has dim {})", m, model.name, m));
  if (params.size() != static_cast<std::size_t>(model.nparams))
    throw InputError(fmt::format("params: {} values given; model {} has {}", params.size(), model.name, model.nparams));
  double Ld = 0;
  std::vector<double> D1(m), D2(m), D11(m * m), D12(m * m), D22(m * m);
  disc->full(h, t0, t1, q0.data(), q1.data(), params.data(), &Ld, D1.data(), D2.data(), D11.data(), D12.data(),
             D22.data());
  py::dict out;
  out["Ld"] = Ld;
  out["D1"] = vector(D1);
  out["D2"] = vector(D2);
  out["D11"] = matrix(D11, m, m);
  out["D12"] = matrix(D12, m, m);
  out["D22"] = matrix(D22, m, m);
  return out;
}

/** A file path as os.fsdecode gives it: bytes that are not UTF-8 become lone surrogates, so that
 *  os.fsencode gives the path's bytes back. */
py::str path_str(const std::string& path) {
  PyObject* text = PyUnicode_DecodeFSDefaultAndSize(path.data(), static_cast<Py_ssize_t>(path.size()));
  if (!text) throw py::error_already_set();
  return py::reinterpret_steal<py::str>(text);
}

/** Raises `type` with `message`, whose bytes that are not UTF-8 (of a path) are shown as \xNN
 *  rather than making the message itself fail to decode. */
void raise_message(const py::object& type, const char* message) {
  PyObject* text = PyUnicode_DecodeUTF8(message, static_cast<Py_ssize_t>(std::strlen(message)), "backslashreplace");
  if (!text) return;  // the decoding error is the one set
  PyErr_SetObject(type.ptr(), text);
  Py_DECREF(text);
}

py::dict model_info(const ModelHandle& handle) {
  const pardel_model& m = *handle.model;
  py::dict out;
  out["name"] = m.name;
  out["source"] = path_str(m.source ? m.source : "");
  out["order"] = m.order;
  out["ncoords"] = m.ncoords;
  out["dim"] = m.dim;
  out["coords"] = std::vector<std::string>(m.coords, m.coords + m.ncoords);
  py::dict params;
  for (int i = 0; i < m.nparams; ++i) params[py::str(m.param_names[i])] = m.param_defaults[i];
  out["params"] = params;
  std::vector<std::string> discs;
  for (int i = 0; i < m.ndiscretizations; ++i) discs.push_back(m.discretizations[i].name);
  out["discretizations"] = discs;
  out["has_clock"] = m.clock != nullptr;
  out["time_dependent"] = m.time_dependent != 0;
  return out;
}

py::dict scene_info(const Scene& s) {
  py::dict out;
  out["path"] = path_str(s.path);
  out["model"] = ModelHandle{s.model};
  out["model_spec"] = s.model_spec;
  out["discretization"] = s.discretization;
  std::vector<double> params = s.problem.params;
  py::dict named;
  for (int i = 0; i < s.model->nparams && static_cast<std::size_t>(i) < params.size(); ++i)
    named[py::str(s.model->param_names[i])] = params[static_cast<std::size_t>(i)];
  out["params"] = named;
  out["t0"] = s.problem.t0;
  out["T"] = s.problem.T;
  out["N"] = s.problem.N;
  out["q0"] = vector(s.problem.q0);
  out["qN"] = vector(s.problem.qN);
  py::list knots;
  for (const Knot& k : s.problem.knots) knots.append(py::make_tuple(k.t, vector(k.q)));
  out["knots"] = knots;
  out["clock"] = to_string(s.problem.clock);
  out["method"] = to_string(s.options.method);
  out["tol"] = s.options.tol;
  out["rtol"] = s.options.rtol;
  out["max_iterations"] = s.options.max_iterations;
  out["threads"] = s.options.threads;
  out["output_dir"] = s.output_dir;
  return out;
}

}  // namespace

PYBIND11_MODULE(_pardel, m) {
  m.doc() = "pardel's compiled core: models, scenes and solves (use the package `pardel`)";
  // project(pardel VERSION ...) of the top-level CMakeLists.txt, as `pardel --version` says it.
  m.attr("__version__") = PARDEL_VERSION;
#ifdef PARDEL_HAVE_CUDA
  pardel::enable_cuda();  // device = "cuda"
#endif

  static py::exception<InputError> input_error(m, "PardelError", PyExc_ValueError);
  static py::exception<SceneError> scene_error(m, "SceneError", input_error.ptr());
  static py::exception<ModelLoadError> model_error(m, "ModelError", input_error.ptr());
  static py::exception<app::CheckpointError> checkpoint_error(m, "CheckpointError", input_error.ptr());
  g_model_warning = PyErr_NewExceptionWithDoc(
      "pardel.ModelWarning",
      "A warning of the generator about a model compiled from a .lag file (a W = d2L/dq'dq' singular "
      "on part of the domain, a discretization that is not regular, ...), as pardel-gen prints it.",
      PyExc_UserWarning, nullptr);
  if (!g_model_warning) throw py::error_already_set();
  m.attr("ModelWarning") = py::reinterpret_borrow<py::object>(g_model_warning);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const SceneError& e) {
      raise_message(scene_error, e.what());
    } catch (const ModelLoadError& e) {
      raise_message(model_error, e.what());
    } catch (const app::CheckpointError& e) {
      raise_message(checkpoint_error, e.what());
    } catch (const InputError& e) {
      raise_message(input_error, e.what());
    }
  });

  py::class_<ModelHandle>(m, "Model")
      .def_property_readonly("name", [](const ModelHandle& h) { return std::string(h.model->name); })
      .def("info", &model_info)
      .def("__eq__", [](const ModelHandle& a, const ModelHandle& b) { return a.model == b.model; })
      .def("__hash__", [](const ModelHandle& h) { return std::hash<const void*>()(h.model); });

  py::class_<Scene>(m, "Scene").def("info", &scene_info);

  // The upper bound of pardel::Options::threads (option_bound), for the checks of pardel.sweep.
  m.attr("max_threads") = static_cast<int>(pardel::option_bound("threads")->high);
  m.def("bundled_models", &bundled_model_names, "The names of the models compiled into this module.");
  m.def("can_compile_lag_files", &pardel::can_compile_lag_files);
  m.def("loader_toolchain", [] {
    const LoaderToolchain t = loader_toolchain();
    py::dict out;
    out["generator"] = t.generator;
    out["python"] = t.python;
    out["render_script"] = t.render_script;
    out["compiler"] = t.compiler;
    out["abi_include"] = t.abi_include;
    return out;
  });
  m.def(
      "set_loader_toolchain",
      [](std::string generator, std::string python, std::string render_script, std::string compiler,
         std::string abi_include) {
        set_loader_toolchain({std::move(generator), std::move(python), std::move(render_script), std::move(compiler),
                              std::move(abi_include)});
      },
      py::arg("generator"), py::arg("python"), py::arg("render_script"), py::arg("compiler"), py::arg("abi_include"));
  // The bounds of the numeric options (pardel::option_bound), by name: (low, low included, high,
  // high included, 0 also valid, rule), for the argument checks of the package.
  py::dict bounds;
  for (const char* name : {"tol", "rtol", "max_iterations", "damping", "newton_substeps", "threads", "refine_start_N",
                           "refine_factor", "clock_update_every", "history_every", "refine_settle",
                           "divergence_factor", "accuracy", "accuracy_max_N"}) {
    const OptionBound* b = pardel::option_bound(name);
    bounds[name] = py::make_tuple(b->low, b->low_included, b->high, b->high_included, b->zero_allowed, b->rule);
  }
  m.attr("option_bounds") = bounds;
  // Compiles left running by Ctrl-C finish before the process exits.
  py::module_::import("atexit").attr("register")(py::cpp_function(&join_background_compiles));
  m.def(
      "load_model", [](const std::string& spec) { return raising_interrupts([&] { return load_model(spec); }); },
      py::arg("spec"));
  m.def(
      "scene_from_arguments",
      [](const std::string& model, const py::dict& arguments, const ModelHandle* loaded) {
        return raising_interrupts([&] { return scene_from_arguments(model, arguments, loaded); });
      },
      py::arg("model"), py::arg("arguments"), py::arg("loaded") = nullptr);
  m.def(
      "load_scene",
      [](const std::string& path, const std::vector<std::string>& overrides) {
        return raising_interrupts([&] { return load_scene(path, overrides); });
      },
      py::arg("path"), py::arg("overrides"));
  m.def(
      "scene_text_from_arguments",
      [](const std::string& model, const py::dict& arguments) {
        return raising_interrupts([&] { return scene_text(model, arguments, true); });
      },
      py::arg("model"), py::arg("arguments"));
  m.def(
      "scene_from_text",
      [](const std::string& text) {
        return raising_interrupts([&] {
          Scene scene = parse_generated_scene(text);
          std::string error;
          if (!scene.options.is_valid(&error)) throw InputError(error);
          return scene;
        });
      },
      py::arg("text"));
  m.def("solve_scene", &solve_scene, py::arg("scene"), py::arg("guess"), py::arg("guess_t"), py::arg("on_iteration"),
        py::arg("threads"), py::arg("checkpoint"), py::arg("scene_text"), py::arg("scene_file"), py::arg("overrides"));
  m.def(
      "resume",
      [](const std::string& path, const py::object& threads, const py::object& on_iteration, const py::dict& options) {
        return raising_interrupts([&] { return resume_checkpoint(path, threads, on_iteration, options); });
      },
      py::arg("path"), py::arg("threads"), py::arg("on_iteration"), py::arg("options") = py::dict());
  m.def(
      "run_sweep",
      [](const std::string& path, const std::vector<std::string>& overrides, int threads, const std::string& out) {
        return raising_interrupts([&] { return run_sweep(path, overrides, threads, out); });
      },
      py::arg("path"), py::arg("overrides"), py::arg("threads"), py::arg("out"));
  m.def("solve_batch_scene", &solve_batch_scene, py::arg("scene"), py::arg("q0"), py::arg("qN"), py::arg("params"),
        py::arg("guess"), py::arg("threads"));
  m.def("check_scene", &check_scene, py::arg("scene"), py::arg("q"), py::arg("t"));
  m.def("kernels", &kernels, py::arg("model"), py::arg("discretization"), py::arg("h"), py::arg("t0"), py::arg("t1"),
        py::arg("q0"), py::arg("q1"), py::arg("params"));
}
