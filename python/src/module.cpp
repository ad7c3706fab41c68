/**
 * @file module.cpp
 * The module pardel._pardel, the compiled part of the Python module `pardel`: a translation layer
 * over the runtime (pardel::runtime), the model loader (pardel::model_loader) and the application
 * library (pardel::app: the scene reader, summary.json, sweeps, checkpoints). This file defines the
 * module's functions and classes and turns the C++ exceptions into pardel's Python exceptions; the
 * other files of python/src/ hold what the functions do (bindings.hpp names them). Keyword
 * arguments of pardel.solve are made into a scene (a TOML table) and read by the scene reader, so
 * their checks and messages are those of `pardel solve` (the package checks the arguments' types
 * before); solves and .lag compiles run with the GIL released and stop at Ctrl-C; results come back
 * as NumPy arrays and summary.json's dictionary (a dict, not JSON text).
 */
#include "bindings.hpp"

#include <cstring>
#include <exception>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pardel/app/checkpoint.hpp"
#include "pardel/model_loader.hpp"
#ifdef PARDEL_HAVE_CUDA
#include "pardel/cuda.hpp"
#endif

namespace pardel::python {

namespace {

/** Raises `type` with `message`, whose bytes that are not UTF-8 (of a path) are shown as \xNN
 *  rather than making the message itself fail to decode. */
void raise_message(const py::object& type, const char* message) {
  PyObject* text = PyUnicode_DecodeUTF8(message, static_cast<Py_ssize_t>(std::strlen(message)), "backslashreplace");
  if (!text) return;  // the decoding error is the one set
  PyErr_SetObject(type.ptr(), text);
  Py_DECREF(text);
}

/** pardel.PardelError and its subclasses, pardel.ModelWarning, and the translation of the C++
 *  exceptions into them. */
void define_exceptions(py::module_& m) {
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
}

/** The classes Model and Scene, the model loader's toolchain and the bounds of the options. */
void define_models_and_options(py::module_& m) {
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
}

/** The functions that load models and scenes, solve, check and sweep; those that may resolve a
 *  model raise a KeyboardInterrupt that stopped its compile as itself (raising_interrupts). */
void define_entry_points(py::module_& m) {
  m.def(
      "load_model", [](const std::string& spec) { return raising_interrupts([&] { return load_model(spec); }); },
      py::arg("spec"));
  m.def(
      "scene_from_arguments",
      [](const std::string& model, const py::dict& arguments, const ModelHandle* loaded, const std::string& where) {
        return raising_interrupts([&] { return scene_from_arguments(model, arguments, loaded, where); });
      },
      py::arg("model"), py::arg("arguments"), py::arg("loaded") = nullptr, py::arg("where") = "pardel.solve");
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

}  // namespace

}  // namespace pardel::python

PYBIND11_MODULE(_pardel, m) {
  using namespace pardel::python;
  m.doc() = "pardel's compiled core: models, scenes and solves (use the package `pardel`)";
  // project(pardel VERSION ...) of the top-level CMakeLists.txt, as `pardel --version` says it.
  m.attr("__version__") = PARDEL_VERSION;
#ifdef PARDEL_HAVE_CUDA
  pardel::enable_cuda();  // device = "cuda"
#endif
  define_exceptions(m);
  define_models_and_options(m);
  // Compiles left running by Ctrl-C finish before the process exits.
  py::module_::import("atexit").attr("register")(py::cpp_function(&join_background_compiles));
  define_entry_points(m);
}
