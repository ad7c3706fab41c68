// The readers of a scene's tables, one each (model, discretization, params, grid, boundary,
// solver, knots, guess, output): every key checked, every error naming where the key came from
// (see scene_reader.hpp; read_scene in scene.cpp calls them in order).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <unistd.h>

#include "pardel/app/trajectory_io.hpp"
#include "pardel/regular_file.hpp"
#include "scene_reader.hpp"

namespace pardel::app::detail {

namespace {

const std::vector<std::string> kMethodNames = method_names();
const std::vector<std::string> kClockNames = clock_mode_names();
const std::vector<std::string> kGuessKinds = {"linear", "polyline", "csv"};

/** 'a' or 'b' / 'a', 'b' or 'c': the names a key accepts, as its error lists them. */
std::string quoted_alternatives(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += i + 1 == names.size() ? " or " : ", ";
    out += "'" + names[i] + "'";
  }
  return out;
}

/** The enum-valued key `section.key` of `table`, read by `parse` into `out`; an unknown name is
 *  refused at its value with the names `names()` lists. */
template <class E>
void read_choice(const SceneReader& r, const toml::table* table, const char* section, const char* key,
                 bool (*parse)(std::string_view, E*), std::vector<std::string> (*names)(), E* out) {
  const std::string dotted = std::string(section) + "." + key;
  if (const auto text = r.string(table, key, dotted); text && !parse(*text, out))
    r.fail(*table->get(key), dotted,
           fmt::format("unknown {} '{}' (expected {})", key, *text, quoted_alternatives(names())));
}

bool looks_like_path(const std::string& spec) {
  return spec.find('/') != std::string::npos ||
         (spec.size() > 4 && spec.compare(spec.size() - 4, 4, ".lag") == 0);
}

/** The model's coordinate names, as "x, y". */
std::string coords_list(const pardel_model& model) {
  std::vector<std::string> names;
  for (int i = 0; i < model.ncoords; ++i) names.push_back(model.coords[i]);
  return join(names);
}

}  // namespace

/** The `model` key: a bundled model's name or a .lag path, resolved (relative paths against the
 *  scene's folder first). */
void read_model(const SceneReader& r, const toml::table& root, const ModelResolver& resolve,
                const std::vector<std::string>& model_names, Scene& scene) {
  const auto model_spec = r.string(&root, "model", "model");
  if (!model_spec) {
    throw SceneError(fmt::format("{}: error: missing key 'model' (a bundled model's name or a path to a .lag file)",
                                 r.file()));
  }
  scene.model_spec = *model_spec;
  std::string to_resolve = *model_spec;
  if (looks_like_path(to_resolve)) {
    const std::string beside_scene = resolve_relative(r.file(), to_resolve);
    std::error_code ec;
    if (std::filesystem::exists(beside_scene, ec)) to_resolve = beside_scene;
    scene.model_path = to_resolve;
  }
  const toml::node& model_node = *root.get("model");
  try {
    scene.model = resolve(to_resolve);
  } catch (const std::exception& error) {
    r.fail(model_node, "model", fmt::format("cannot load model '{}': {}", *model_spec, error.what()));
  }
  if (!scene.model) {
    const std::string suggestion = nearest_name(*model_spec, model_names);
    std::string message = fmt::format("unknown model '{}'", *model_spec);
    if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
    else if (!model_names.empty()) message += fmt::format(" (bundled models: {})", join(model_names));
    r.fail(model_node, "model", message);
  }
  scene.problem.model = scene.model;
}

/** The `discretization` key, else the model's first. */
void read_discretization(const SceneReader& r, const toml::table& root, Scene& scene) {
  const pardel_model& model = *scene.model;
  Problem& problem = scene.problem;
  std::vector<std::string> disc_names;
  for (int i = 0; i < model.ndiscretizations; ++i) disc_names.push_back(model.discretizations[i].name);
  if (const auto disc = r.string(&root, "discretization", "discretization")) {
    problem.discretization = find_discretization(model, *disc);
    if (!problem.discretization) {
      const std::string suggestion = nearest_name(*disc, disc_names);
      std::string message = fmt::format("unknown discretization '{}' for model {}", *disc, model.name);
      if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
      message += fmt::format(" (it has: {})", join(disc_names));
      r.fail(*root.get("discretization"), "discretization", message);
    }
  } else {
    if (model.ndiscretizations < 1) {
      throw SceneError(fmt::format("{}: error: model {} has no discretization", r.file(), model.name));
    }
    problem.discretization = &model.discretizations[0];
  }
  scene.discretization = problem.discretization->name;
}

/** [params]: the model's params by name, the others at their defaults. */
void read_params(const SceneReader& r, const toml::table& root, Scene& scene) {
  const pardel_model& model = *scene.model;
  Problem& problem = scene.problem;
  std::vector<std::string> param_names;
  for (int i = 0; i < model.nparams; ++i) param_names.push_back(model.param_names[i]);
  problem.params.assign(model.param_defaults, model.param_defaults + model.nparams);
  if (const toml::table* params = r.table(root, "params", "params")) {
    r.check_keys(*params, "params", param_names,
                 model.nparams == 0 ? fmt::format("(model {} has no params)", model.name) : "");
    for (int i = 0; i < model.nparams; ++i) {
      if (auto v = r.number(params, param_names[i], "params." + param_names[i])) problem.params[i] = *v;
    }
  }
}

/** The first grid of an adaptive solve (grid.accuracy) whose scene gives no grid.N. */
constexpr int kAdaptiveStartN = 16;

/** [grid]: t0, T and N, with node times that a double can tell apart; or an adaptive grid:
 *  accuracy (and accuracy_max_N), N then being the first grid's (default kAdaptiveStartN, or
 *  accuracy_max_N where that is smaller; at most accuracy_max_N). */
void read_grid(const SceneReader& r, const toml::table& root, Scene& scene) {
  Problem& problem = scene.problem;
  const toml::table* grid = r.table(root, "grid", "grid");
  if (!grid) throw SceneError(fmt::format("{}: error: missing table [grid] (keys t0, T, N)", r.file()));
  r.check_keys(*grid, "grid", {"t0", "T", "N", "accuracy", "accuracy_max_N"});
  if (const auto accuracy = r.bounded_number(grid, "accuracy", "grid.accuracy", "accuracy")) {
    if (!(*accuracy > 0))
      r.fail(*grid->get("accuracy"), "grid.accuracy", "grid.accuracy must be > 0 (the requested error; leave it out for a fixed grid)");
    scene.options.accuracy = *accuracy;
  }
  if (const auto max_N = r.bounded_integer(grid, "accuracy_max_N", "grid.accuracy_max_N", "accuracy_max_N")) {
    if (scene.options.accuracy <= 0)
      r.fail(*grid->get("accuracy_max_N"), "grid.accuracy_max_N", "grid.accuracy_max_N needs grid.accuracy (an adaptive grid)");
    scene.options.accuracy_max_N = static_cast<int>(*max_N);
  }
  problem.t0 = r.number(grid, "t0", "grid.t0").value_or(0.0);
  const auto T = r.number(grid, "T", "grid.T");
  if (!T) r.fail(grid->source(), "grid", "missing key 'grid.T' (the final time minus t0)");
  if (!(*T > 0)) r.fail(*grid->get("T"), "grid.T", fmt::format("grid.T must be > 0, got {}", *T));
  problem.T = *T;
  auto N = r.integer(grid, "N", "grid.N");
  if (!N && scene.options.accuracy > 0) N = std::min(kAdaptiveStartN, scene.options.accuracy_max_N);
  if (!N) r.fail(grid->source(), "grid", "missing key 'grid.N' (the number of intervals; or grid.accuracy for an adaptive grid)");
  constexpr long long kMaxN = 100000000;
  if (*N < 2 || *N > kMaxN) {
    r.fail(*grid->get("N"), "grid.N", fmt::format("grid.N must be between 2 and {}, got {}", kMaxN, *N));
  }
  if (scene.options.accuracy > 0 && *N > scene.options.accuracy_max_N) {
    r.fail(*grid->get("N"), "grid.N",
           fmt::format("grid.N = {}, the first grid of the adaptive solve, is above grid.accuracy_max_N = {}", *N,
                       scene.options.accuracy_max_N));
  }
  problem.N = static_cast<int>(*N);
  if (!std::isfinite(problem.t0 + problem.T)) {
    r.fail(*grid->get("T"), "grid.T",
           fmt::format("grid.t0 + grid.T = {} + {} overflows a double", problem.t0, problem.T));
  }
  const double step = problem.T / problem.N;
  const bool separate = problem.t0 + step != problem.t0 && problem.t0 + problem.T - step != problem.t0 + problem.T;
  if (std::isnormal(step) && !separate && grid->get("t0") &&
      std::fabs(problem.t0) > std::fabs(problem.T)) {
    // The step itself is fine; the node times round to one another next to so large a t0.
    r.fail(*grid->get("t0"), "grid.t0",
           fmt::format("grid.t0 = {} is too large for the step grid.T / grid.N = {} / {} = {}: in double precision "
                       "t0 + step rounds to t0, so the node times cannot be told apart (shift the time origin)",
                       problem.t0, problem.T, problem.N, step));
  }
  if (!std::isnormal(step) || !separate) {
    r.fail(*grid->get("T"), "grid.T",
           fmt::format("the step grid.T / grid.N = {} / {} = {} is too small to separate the node times", problem.T,
                       problem.N, step));
  }
}

/** [boundary]: q0, qN and, for higher orders, the derivatives' end values, laid out
 *  [coords, coords', ...] (derivative by derivative). */
void read_boundary(const SceneReader& r, const toml::table& root, Scene& scene) {
  const pardel_model& model = *scene.model;
  Problem& problem = scene.problem;
  const std::string coords_text = coords_list(model);
  const toml::table* boundary = r.table(root, "boundary", "boundary");
  std::vector<std::string> boundary_keys;
  for (int d = 0; d < model.order; ++d) {
    boundary_keys.push_back(boundary_prefix(d) + "0");
    boundary_keys.push_back(boundary_prefix(d) + "N");
  }
  if (!boundary) {
    throw SceneError(fmt::format("{}: error: missing table [boundary] (keys {})", r.file(), join(boundary_keys)));
  }
  r.check_keys(*boundary, "boundary", boundary_keys, fmt::format("(model {} has order {})", model.name, model.order));
  problem.q0.clear();
  problem.qN.clear();
  for (int d = 0; d < model.order; ++d) {
    for (const char end : {'0', 'N'}) {
      const std::string key = boundary_prefix(d) + end;
      const toml::node* node = boundary->get(key);
      if (!node) {
        r.fail(boundary->source(), "boundary",
               fmt::format("missing key 'boundary.{}' ({} values: {}{})", key, model.ncoords, coords_text,
                           d == 0 ? "" : fmt::format(", derivative {}", d)));
      }
      const auto values = r.vector(*node, "boundary." + key, static_cast<std::size_t>(model.ncoords),
                                   fmt::format("model {} has coords {}", model.name, coords_text));
      auto& target = end == '0' ? problem.q0 : problem.qN;
      target.insert(target.end(), values.begin(), values.end());
    }
  }
}

/** [solver]: the method and its options, and the clock mode (read before the knots: the clock
 *  mode decides whether knots make sense). */
void read_solver(const SceneReader& r, const toml::table& root, Scene& scene) {
  const pardel_model& model = *scene.model;
  Problem& problem = scene.problem;
  Options& options = scene.options;
  const toml::table* solver = r.table(root, "solver", "solver");
  if (!solver) return;
  r.check_keys(*solver, "solver",
               {"method", "tol", "rtol", "max_iterations", "damping", "newton_substeps", "newton_shift",
                "linear_solver", "threads", "refine", "clock_update_every", "history_every", "divergence_factor",
                "clock", "error_estimate", "extrapolate", "iterative_refinement", "device"});
  if (const auto method = r.string(solver, "method", "solver.method")) {
    if (!parse_method(*method, &options.method)) {
      const std::string suggestion = nearest_name(*method, kMethodNames);
      std::string message = fmt::format("unknown method '{}'", *method);
      if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
      message += fmt::format(" (methods: {})", join(kMethodNames));
      r.fail(*solver->get("method"), "solver.method", message);
    }
  }
  if (const auto tol = r.bounded_number(solver, "tol", "solver.tol", "tol")) options.tol = *tol;
  if (const auto rtol = r.bounded_number(solver, "rtol", "solver.rtol", "rtol")) options.rtol = *rtol;
  if (const auto max_it = r.bounded_integer(solver, "max_iterations", "solver.max_iterations", "max_iterations"))
    options.max_iterations = static_cast<long>(*max_it);
  if (const auto damping = r.bounded_number(solver, "damping", "solver.damping", "damping")) options.damping = *damping;
  if (const auto m = r.bounded_integer(solver, "newton_substeps", "solver.newton_substeps", "newton_substeps"))
    options.newton_substeps = static_cast<int>(*m);
  read_choice(r, solver, "solver", "newton_shift", parse_newton_shift, newton_shift_names, &options.newton_shift);
  read_choice(r, solver, "solver", "iterative_refinement", parse_refinement, refinement_names,
              &options.iterative_refinement);
  read_choice(r, solver, "solver", "linear_solver", parse_linear_solver, linear_solver_names, &options.linear_solver);
  read_choice(r, solver, "solver", "device", parse_device, device_names, &options.device);
  if (const auto threads = r.bounded_integer(solver, "threads", "solver.threads", "threads"))
    options.threads = static_cast<int>(*threads);
  if (const toml::table* refine = r.table(*solver, "refine", "solver.refine")) {
    r.check_keys(*refine, "solver.refine", {"start_N", "factor", "settle"});
    const auto start = r.bounded_integer(refine, "start_N", "solver.refine.start_N", "refine_start_N");
    if (!start) r.fail(refine->source(), "solver.refine", "missing key 'solver.refine.start_N'");
    if (*start > problem.N) {
      r.fail(*refine->get("start_N"), "solver.refine.start_N",
             fmt::format("solver.refine.start_N must be at most grid.N = {}, got {}", problem.N, *start));
    }
    options.refine_start_N = static_cast<int>(*start);
    if (const auto factor = r.bounded_number(refine, "factor", "solver.refine.factor", "refine_factor"))
      options.refine_factor = *factor;
    if (const auto settle = r.bounded_number(refine, "settle", "solver.refine.settle", "refine_settle"))
      options.refine_settle = *settle;
  }
  // Counts beyond 1e9 iterations all mean "never"; they are clamped so that they fit an int.
  if (const auto every = r.bounded_integer(solver, "history_every", "solver.history_every", "history_every"))
    options.history_every = static_cast<long>(std::min<long long>(*every, 1000000000));
  if (const auto factor =
          r.bounded_number(solver, "divergence_factor", "solver.divergence_factor", "divergence_factor"))
    options.divergence_factor = *factor;
  if (const auto every =
          r.bounded_integer(solver, "clock_update_every", "solver.clock_update_every", "clock_update_every"))
    options.clock_update_every = static_cast<int>(std::min<long long>(*every, 1000000000));
  if (const auto estimate = r.boolean(solver, "error_estimate", "solver.error_estimate"))
    options.error_estimate = *estimate;
  if (const auto extrapolate = r.boolean(solver, "extrapolate", "solver.extrapolate")) {
    options.extrapolate = *extrapolate;
    if (*extrapolate && !options.error_estimate)
      r.fail(*solver->get("extrapolate"), "solver.extrapolate",
             "solver.extrapolate = true needs the error estimate it extrapolates with; solver.error_estimate is false");
  }
  if (const auto clock = r.string(solver, "clock", "solver.clock")) {
    if (!parse_clock_mode(*clock, &problem.clock)) {
      const std::string suggestion = nearest_name(*clock, kClockNames);
      std::string message = fmt::format("unknown clock mode '{}'", *clock);
      if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
      message += fmt::format(" (modes: {})", join(kClockNames));
      r.fail(*solver->get("clock"), "solver.clock", message);
    }
    if (problem.clock != ClockMode::none && !model.clock) {
      r.fail(*solver->get("clock"), "solver.clock",
             fmt::format("solver.clock = \"{}\" needs a model with a clock; model {} declares none", *clock,
                         model.name));
    }
  }
}

/** [[knots]]: interior points the path must pass, each on a grid node (under grid.accuracy
 *  anywhere inside: the adaptive solve's first grid has nodes there). */
void read_knots(const SceneReader& r, const toml::table& root, Scene& scene) {
  const pardel_model& model = *scene.model;
  Problem& problem = scene.problem;
  const std::string coords_text = coords_list(model);
  if (const toml::node* knots_node = root.get("knots")) {
    const toml::array* knots = knots_node->as_array();
    if (!knots) {
      r.fail(*knots_node, "knots", fmt::format("knots must be an array of tables ([[knots]] with t and q), got {}",
                                               type_name(*knots_node)));
    }
    if (!knots->empty() && problem.clock != ClockMode::none) {
      r.fail(*knots_node, "knots", "knots need solver.clock = \"none\" (node times move under a clock)");
    }
    const double h = problem.T / problem.N;
    std::vector<long> used_nodes;
    for (std::size_t i = 0; i < knots->size(); ++i) {
      const std::string name = fmt::format("knots[{}]", i);
      const toml::node& node = *knots->get(i);
      const toml::table* knot = node.as_table();
      if (!knot) r.fail(node, name, fmt::format("{} must be a table with t and q, got {}", name, type_name(node)));
      r.check_keys(*knot, name, {"t", "q"});
      const auto t = r.number(knot, "t", name + ".t");
      if (!t) r.fail(knot->source(), name, fmt::format("missing key '{}.t'", name));
      if (!knot->get("q")) r.fail(knot->source(), name, fmt::format("missing key '{}.q'", name));
      Knot k;
      k.q = r.vector(*knot->get("q"), name + ".q", static_cast<std::size_t>(model.ncoords),
                     fmt::format("model {} has coords {}", model.name, coords_text));
      const double position = (*t - problem.t0) / h;
      const toml::node& t_node = *knot->get("t");
      const double tol = 1e-9 * std::max(1.0, std::abs(problem.T));
      const bool inside = scene.options.accuracy > 0 ? *t > problem.t0 + tol && *t < problem.t0 + problem.T - tol
                                                     : position > 0.5 && position < problem.N - 0.5;
      if (!inside && scene.options.accuracy > 0) {
        r.fail(t_node, name + ".t",
               fmt::format("{}.t = {} must lie inside the grid ({}, {}), more than {:.3g} from either end; the ends "
                           "are set by [boundary]",
                           name, *t, problem.t0, problem.t0 + problem.T, tol));
      }
      if (!inside) {
        r.fail(t_node, name + ".t",
               fmt::format("{}.t = {} must lie strictly inside the grid ({}, {}); the ends are set by [boundary]", name,
                           *t, problem.t0, problem.t0 + problem.T));
      }
      if (scene.options.accuracy > 0) {
        // An adaptive solve's first grid puts the knots on nodes (docs/solvers.md, "Adaptive grids").
        for (const Knot& other : problem.knots) {
          if (std::abs(*t - other.t) <= tol)
            r.fail(t_node, name + ".t",
                   fmt::format("{}.t = {}: another knot is already at t = {}{}", name, *t, other.t,
                               *t == other.t ? "" : fmt::format(" (within {:.3g})", tol)));
        }
        k.t = *t;
        problem.knots.push_back(std::move(k));
        continue;
      }
      const long node_index = std::lround(position);
      const double node_time = problem.t0 + node_index * h;
      if (std::abs(*t - node_time) > tol) {
        const long below = static_cast<long>(std::floor(position));
        r.fail(t_node, name + ".t",
               fmt::format("{}.t = {} is not on a grid node (h = T/N = {}); nearest nodes: t = {} (k = {}) and "
                           "t = {} (k = {})",
                           name, *t, h, problem.t0 + below * h, below, problem.t0 + (below + 1) * h, below + 1));
      }
      if (std::find(used_nodes.begin(), used_nodes.end(), node_index) != used_nodes.end()) {
        r.fail(t_node, name + ".t", fmt::format("{}.t = {}: another knot is already at node k = {}", name, *t, node_index));
      }
      used_nodes.push_back(node_index);
      k.t = node_time;
      problem.knots.push_back(std::move(k));
    }
  }
}

/** [guess]: the initial guess (linear, polyline or a trajectory.csv). */
void read_guess(const SceneReader& r, const toml::table& root, Scene& scene) {
  const pardel_model& model = *scene.model;
  const std::string coords_text = coords_list(model);
  if (const toml::table* guess = r.table(root, "guess", "guess")) {
    r.check_keys(*guess, "guess", {"kind", "points", "path"});
    const std::string kind = r.string(guess, "kind", "guess.kind").value_or("linear");
    if (kind == "linear") {
      scene.guess.kind = GuessKind::linear;
    } else if (kind == "polyline") {
      scene.guess.kind = GuessKind::polyline;
    } else if (kind == "csv") {
      scene.guess.kind = GuessKind::csv;
    } else {
      const std::string suggestion = nearest_name(kind, kGuessKinds);
      std::string message = fmt::format("unknown guess kind '{}'", kind);
      if (!suggestion.empty()) message += fmt::format("; did you mean '{}'?", suggestion);
      message += fmt::format(" (kinds: {})", join(kGuessKinds));
      r.fail(*guess->get("kind"), "guess.kind", message);
    }
    const toml::node* points = guess->get("points");
    const toml::node* path = guess->get("path");
    if (points && scene.guess.kind != GuessKind::polyline) {
      r.fail(*points, "guess.points", fmt::format("guess.points is used only with kind = \"polyline\", not \"{}\"", kind));
    }
    if (path && scene.guess.kind != GuessKind::csv) {
      r.fail(*path, "guess.path", fmt::format("guess.path is used only with kind = \"csv\", not \"{}\"", kind));
    }
    if (scene.guess.kind == GuessKind::polyline) {
      if (!points) r.fail(guess->source(), "guess", "missing key 'guess.points' (the polyline's vertices)");
      const toml::array* array = points->as_array();
      if (!array || array->size() < 2) {
        r.fail(*points, "guess.points",
               fmt::format("guess.points must be an array of at least 2 points (arrays of {} numbers: {})",
                           model.ncoords, coords_text));
      }
      for (std::size_t i = 0; i < array->size(); ++i) {
        scene.guess.points.push_back(r.vector(*array->get(i), fmt::format("guess.points[{}]", i),
                                              static_cast<std::size_t>(model.ncoords),
                                              fmt::format("model {} has coords {}", model.name, coords_text)));
      }
    }
    if (scene.guess.kind == GuessKind::csv) {
      const auto csv = r.string(guess, "path", "guess.path");
      if (!csv) r.fail(guess->source(), "guess", "missing key 'guess.path' (a trajectory.csv file)");
      scene.guess.csv_path = resolve_relative(r.file(), *csv);
      // Checked here, so that a missing file, a folder or a FIFO is named at guess.path.
      try {
        ::close(pardel::open_regular_file(scene.guess.csv_path, pardel::FileLimits::trajectory, "trajectory file"));
      } catch (const pardel::FileError& error) {
        std::error_code ec;
        const bool missing = !std::filesystem::exists(std::filesystem::symlink_status(scene.guess.csv_path, ec));
        r.fail(*path, "guess.path",
               missing ? fmt::format("guess.path: file '{}' not found", scene.guess.csv_path)
                       : fmt::format("guess.path: '{}' {}", scene.guess.csv_path, error.reason()));
      }
    }
  }
}

/** [output]: the output folder. */
void read_output(const SceneReader& r, const toml::table& root, Scene& scene) {
  if (const toml::table* output = r.table(root, "output", "output")) {
    r.check_keys(*output, "output", {"dir"});
    if (const auto dir = r.string(output, "dir", "output.dir")) {
      if (dir->empty()) r.fail(*output->get("dir"), "output.dir", "output.dir must not be empty");
      scene.output_dir = *dir;
    }
  }
}

}  // namespace pardel::app::detail
