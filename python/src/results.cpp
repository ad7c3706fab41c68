/**
 * @file results.cpp
 * Between NumPy arrays and the runtime's trajectories: arrays of values, the initial trajectory of
 * a solve (the scene's guess or one given as an array), JSON values as Python values, and the
 * result dictionary that pardel.Result is made of.
 */
#include "bindings.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstddef>
#include <string>
#include <vector>

#include "pardel/app/outputs.hpp"

namespace pardel::python {

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

/** A JSON string as Python's json.loads reads the text nlohmann dumps with error_handler_t::replace
 *  (summary.json's): bytes that are not UTF-8 become U+FFFD as that dump writes them. */
py::str json_string(const std::string& text) {
  PyObject* decoded = PyUnicode_DecodeUTF8(text.data(), static_cast<Py_ssize_t>(text.size()), nullptr);
  if (decoded) return py::reinterpret_steal<py::str>(decoded);
  PyErr_Clear();
  const auto replace = nlohmann::ordered_json::error_handler_t::replace;
  return py::str(nlohmann::ordered_json::parse(nlohmann::ordered_json(text).dump(-1, ' ', false, replace))
                     .get_ref<const std::string&>());
}

/** A JSON value as the Python value json.loads makes of its dumped text: objects as dicts (in
 *  order), arrays as lists, a number that is not finite as None (the dump writes it as null). */
py::object json_value(const nlohmann::ordered_json& value) {
  using Type = nlohmann::ordered_json::value_t;
  switch (value.type()) {
    case Type::boolean: return py::bool_(value.get<bool>());
    case Type::number_integer: return py::int_(value.get<std::int64_t>());
    case Type::number_unsigned: return py::int_(value.get<std::uint64_t>());
    case Type::number_float: {
      const double number = value.get<double>();
      return std::isfinite(number) ? py::object(py::float_(number)) : py::object(py::none());
    }
    case Type::string: return json_string(value.get_ref<const std::string&>());
    case Type::array: {
      py::list out;
      for (const auto& item : value) out.append(json_value(item));
      return out;
    }
    case Type::object: {
      py::dict out;
      for (const auto& item : value.items()) out[json_string(item.key())] = json_value(item.value());
      return out;
    }
    default: return py::none();  // null (binary and discarded values are not in pardel's JSON)
  }
}

/** The initial trajectory: the scene's guess, or `guess` ((M+1) x dim rows, resampled to the
 *  scene's N when M differs; node times `guess_t` when given, else uniform); `name` is the
 *  argument's name in the messages. */
Trajectory initial_trajectory(const Scene& scene, const py::object& guess, const py::object& guess_t,
                              const char* name) {
  if (guess.is_none()) return app::make_initial_guess(scene);
  const Problem& problem = scene.problem;
  const int dim = scene.model->dim;
  const auto q = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(guess);
  if (!q) throw InputError(fmt::format("{}: a 2-D array of numbers was expected", name));
  if (q.ndim() != 2 || q.shape(1) != dim || q.shape(0) < 2)
    throw InputError(fmt::format("{}: shape ({}) given; expected (N+1, {}) (model {} has dim {}: {})", name,
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
      throw InputError(fmt::format("{}'s node times: {} were expected", name, from.N + 1));
    from.t.assign(t.data(), t.data() + t.size());
  } else {
    for (int k = 0; k <= from.N; ++k) from.t[static_cast<std::size_t>(k)] = problem.t0 + problem.T * k / from.N;
  }
  if (from.N == problem.N) return from;
  return resample(problem, from, problem.N);
}

/** What pardel.Result is made of: summary.json's dictionary, the trajectory, the boundary momenta
 *  and the history as arrays. */
py::dict result_dict(const Scene& scene, const Summary& summary, const Trajectory& trajectory, bool stopped_by_callback) {
  py::dict result;
  const std::string model_source = app::scene_model_source(scene);
  const nlohmann::ordered_json doc = app::summary_json(scene, summary, trajectory, Certificate{}, model_source);
  // Paths that are not UTF-8 have U+FFFD for their invalid bytes, as in summary.json.
  result["summary"] = json_value(doc);
  result["stopped_by_callback"] = stopped_by_callback;
  result["t"] = vector(trajectory.t);
  result["q"] = matrix(trajectory.q, static_cast<std::size_t>(trajectory.N) + 1, static_cast<std::size_t>(trajectory.dim));
  // The boundary momenta the summary holds (app::momenta_on_trajectory_grid; null: none), not
  // computed twice.
  const nlohmann::ordered_json& momenta = doc.at("boundary_momenta");
  result["p0"] = vector(momenta.is_null() ? std::vector<double>{} : momenta.at("p0").get<std::vector<double>>());
  result["pN"] = vector(momenta.is_null() ? std::vector<double>{} : momenta.at("pN").get<std::vector<double>>());
  const std::size_t n = summary.history.size();
  py::array_t<std::int64_t> it(n), N(n);
  std::vector<double> res(n), act(n), sec(n);
  for (std::size_t i = 0; i < n; ++i) {
    it.mutable_data()[i] = summary.history[i].iteration;
    N.mutable_data()[i] = summary.history[i].N;
    res[i] = summary.history[i].residual;
    act[i] = summary.history[i].action;
    sec[i] = summary.history[i].seconds;
  }
  py::dict history;
  history["iteration"] = it;
  history["N"] = N;
  history["residual"] = vector(res);
  history["action"] = vector(act);
  history["seconds"] = vector(sec);
  result["history"] = history;
  return result;
}

}  // namespace pardel::python
