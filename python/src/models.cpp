/**
 * @file models.cpp
 * Models for pardel._pardel: a bundled name or a .lag file compiled on first use, resolved with the
 * GIL released so that Ctrl-C stops the wait for a compile (which then finishes in the background),
 * and the generator's warnings issued as pardel.ModelWarning.
 */
#include "bindings.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "pardel/app/scene.hpp"
#include "pardel/model_loader.hpp"

namespace pardel::python {

/** pardel.ModelWarning (a UserWarning), set when the module is initialized (module.cpp). */
PyObject* g_model_warning = nullptr;

/** The Python exception (KeyboardInterrupt) that stopped the wait for a model compile, kept until
 *  the entry point that called the resolver raises it (the scene reader turns whatever its
 *  resolver throws into a SceneError); guarded by the GIL. Never freed (freeing a Python object
 *  after the interpreter is gone would crash at exit). */
std::unique_ptr<py::error_already_set>& interrupted_compile() {
  static auto* pending = new std::unique_ptr<py::error_already_set>;
  return *pending;
}

namespace {

/** Compiles left to finish in the background after Ctrl-C; joined at exit (atexit). Never freed:
 *  a std::thread still joinable when destroyed would end the process. */
std::vector<std::thread>& background_compiles() {
  static auto* threads = new std::vector<std::thread>;
  return *threads;
}

}  // namespace

void join_background_compiles() {
  std::vector<std::thread> threads;
  threads.swap(background_compiles());
  py::gil_scoped_release release;
  for (std::thread& t : threads) t.join();
}

namespace {

/** Raised where the wait for a compile was interrupted; the entry point raises the Python
 *  exception kept in interrupted_compile() instead. */
struct CompileInterrupted : std::runtime_error {
  CompileInterrupted() : std::runtime_error("interrupted while compiling a model") {}
};

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

}  // namespace

/** A bundled name, or a .lag path compiled on first use (the CLI's resolver) with the GIL
 *  released. The generator's warnings about a .lag model (model_warnings: kept with its cache
 *  entry, so also when an earlier process compiled it) are issued as a pardel.ModelWarning, once
 *  per model and process. Every caller holds the GIL (models are resolved before a solve or sweep
 *  releases it) and is an entry point wrapped in raising_interrupts. */
const pardel_model* resolve_spec(const std::string& spec) {
  const pardel_model* model = resolve_releasing_gil(spec);
  static std::vector<const pardel_model*> reported;
  if (model && std::find(reported.begin(), reported.end(), model) == reported.end()) {
    const std::string warnings = pardel::model_warnings(model);
    // -1: a warnings filter made it an exception, which propagates (a scene reports it as its
    // error); the model then counts as not reported, so that a later use raises it again.
    if (!warnings.empty() && PyErr_WarnEx(g_model_warning, warnings.c_str(), 1) != 0) throw py::error_already_set();
    reported.push_back(model);
  }
  return model;
}

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

}  // namespace pardel::python
