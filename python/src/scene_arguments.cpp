/**
 * @file scene_arguments.cpp
 * pardel.solve's keyword arguments as a scene: built as a TOML table and read by the scene reader
 * (app::read_scene_table), so that their checks and messages are those of `pardel solve`, or written
 * as scene text for a checkpoint to record; the options outside the scene schema; and
 * pardel.resume's solver options as the overrides of a warm start.
 */
#include "bindings.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <regex>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "pardel/app/scene_table.hpp"
#include "pardel/model_loader.hpp"

namespace pardel::python {

namespace {

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
    {"iterative_refinement", "solver.iterative_refinement"},
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

/** The name of a scene made from pardel.solve's arguments in the scene reader's messages. */
const std::string kGeneratedSource = "pardel.solve";

std::vector<std::string> argument_names() {
  std::vector<std::string> names;
  for (const auto& a : kArguments) names.push_back(a.first);
  return names;
}

/** Whether a Python value is a number (int, float or a NumPy scalar; not a bool). */
bool is_number(const py::handle& value) {
  return !py::isinstance<py::bool_>(value) && !py::isinstance<py::str>(value) &&
         !py::isinstance<py::sequence>(value) && py::hasattr(value, "__float__");
}

std::string type_name(const py::handle& value) {
  return py::str(py::type::handle_of(value).attr("__name__")).cast<std::string>();
}

/** A TOML array from a Python sequence or NumPy array of numbers, strings or sequences
 *  (booleans refused). */
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

/** The scene (a TOML table) of pardel.solve's arguments: the model (a bundled name or a .lag path),
 *  then the keyword arguments of kArguments (None values are left out). `complete`: the options
 *  outside kArguments' scene keys are written as scene keys too (solver.history_every,
 *  solver.divergence_factor, solver.refine.settle), so that the scene alone gives the solve's
 *  options (what a checkpoint records); solver.refine.settle needs solver.refine.start_N. */
toml::table scene_table(const std::string& model_spec, const py::dict& arguments, bool complete,
                        const ModelHandle* loaded) {
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
  return root;
}

/** The resolver of a scene made from pardel.solve's arguments: `loaded`, when given, is the model
 *  the scene names as `model_spec`. */
app::ModelResolver generated_scene_resolver(const std::string& model_spec, const ModelHandle* loaded) {
  return [model_spec, loaded](const std::string& spec) {
    return loaded && spec == model_spec ? loaded->model : resolve_spec(spec);
  };
}

}  // namespace

/** The scene text (TOML) of pardel.solve's arguments: scene_table written out. */
std::string scene_text(const std::string& model_spec, const py::dict& arguments, bool complete,
                       const ModelHandle* loaded) {
  std::ostringstream text;
  text << scene_table(model_spec, arguments, complete, loaded);
  return text.str();
}

/** Parses scene text made by scene_text (named "pardel.solve" in messages, without positions in
 *  the generated text); `loaded`, when given, is the model the text names as `model_spec`. */
Scene parse_generated_scene(const std::string& text, const std::string& model_spec,
                            const ModelHandle* loaded) {
  try {
    return app::parse_scene(text, kGeneratedSource, {}, generated_scene_resolver(model_spec, loaded),
                            bundled_model_names());
  } catch (const SceneError& error) {
    throw SceneError(without_generated_position(error.what(), kGeneratedSource));
  }
}

/** A scene from pardel.solve's arguments: their table (scene_table) read by the scene reader, as
 *  parse_generated_scene reads their text (the same checks and messages: a table built in memory
 *  has no positions), then the options outside the scene schema. `loaded`: the model a pardel.Model
 *  holds for model_spec, used instead of resolving the spec again (for a .lag path that is reading,
 *  hashing and checking the file and its cached library: about 0.5 ms a call). `where`: the
 *  calling function, which messages name. */
Scene scene_from_arguments(const std::string& model_spec, const py::dict& arguments, const ModelHandle* loaded,
                           const std::string& where) {
  Scene scene = app::read_scene_table(scene_table(model_spec, arguments, false, loaded), where,
                                      generated_scene_resolver(model_spec, loaded), bundled_model_names());
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

/** pardel.resume's solver options as `pardel solve --resume DIR --set solver.KEY=VALUE` overrides
 *  (their scene keys from kArguments and kRecordedArguments). An option of the problem (T, N, q0, params, ...) is refused:
 *  a warm start keeps the recorded problem and changes how it is solved. */
std::vector<std::string> warm_start_overrides(const py::dict& options) {
  std::vector<std::string> names, out;
  for (const auto& a : kArguments)
    if (a.first != "threads") names.push_back(a.first);
  for (const auto& item : options) {
    const std::string name = py::str(item.first).cast<std::string>();
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
    if (item.second.is_none()) continue;
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

}  // namespace pardel::python
