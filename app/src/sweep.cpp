// Sweep files, variants, their solves, the grouping into distinct solutions, the output files and
// the report of `pardel sweep` (see sweep.hpp for the contract).
#include "pardel/app/sweep.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <new>
#include <random>
#include <sstream>

#include <unistd.h>

#include "pardel/app/outputs.hpp"
#include "pardel/app/solve.hpp"
#include "pardel/app/trajectory_io.hpp"
#include "pardel/memory.hpp"
#include "pardel/regular_file.hpp"
#include "toml_read.hpp"

namespace pardel::app {

namespace fs = std::filesystem;

int Sweep::guesses_per_configuration() const {
  const int given = static_cast<int>(listed_guesses.size()) + random.count;
  return given > 0 ? given : 1;
}

int Sweep::variant_count() const {
  return static_cast<int>(configurations.size()) * guesses_per_configuration();
}

namespace {

const std::vector<std::string> kTopKeys = {"scene", "set", "guesses", "random_guesses", "vary", "grouping", "output"};
constexpr long long kMaxVariants = 10000000;
// Every configuration is a scene loaded and checked before anything is solved (10^6 of them took
// minutes and gigabytes): at most this many.
constexpr long long kMaxConfigurations = 10000;
// The random numbers of all random guesses are drawn when the file is read: at most this many
// (80 MB; count = 10^6 with interior_points = 1000 asked for 16 GB).
constexpr long long kMaxRandomNumbers = 10000000;

using detail::join;
using detail::resolve_relative;
using detail::type_name;

/** Integral values print as integers (so that grid.N = 80.0 from a range stays an integer key),
 *  others in the shortest text that reads back to the same double. */
std::string number_text(double value) {
  if (std::abs(value) < 1e15 && value == std::floor(value)) return fmt::format("{}", static_cast<long long>(value));
  return fmt::format("{}", value);
}

std::string quote_toml_string(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) out += fmt::format("\\u{:04X}", static_cast<int>(c));
        else out += c;
    }
  }
  return out + "\"";
}

/** Reads the sweep document; every error names FILE:LINE:COL. */
class SweepReader : public detail::TomlReader {
 public:
  using TomlReader::TomlReader;
  using TomlReader::fail;
  using TomlReader::integer;
  using TomlReader::where;

  std::string where(const toml::node& node) const { return where(node.source(), ""); }

  [[noreturn]] void fail(const toml::source_region& source, const std::string& message) const {
    fail(source, "", message);
  }
  [[noreturn]] void fail(const toml::node& node, const std::string& message) const { fail(node.source(), message); }

  /** An integer from lo to hi. */
  long long integer(const toml::node& node, const std::string& dotted, long long lo, long long hi) const {
    const long long v = integer(node, dotted);
    if (v < lo || v > hi) fail(node, fmt::format("{} must be between {} and {}, got {}", dotted, lo, hi, v));
    return v;
  }

  /** A TOML value as text for --set (tables refused). */
  std::string value_text(const toml::node& node, const std::string& dotted) const {
    if (node.is_integer()) return std::to_string(node.as_integer()->get());
    if (node.is_floating_point()) return number_text(number(node, dotted));
    if (node.is_boolean()) return node.as_boolean()->get() ? "true" : "false";
    if (node.is_string()) return quote_toml_string(node.as_string()->get());
    if (const toml::array* array = node.as_array()) {
      std::string out = "[";
      for (std::size_t i = 0; i < array->size(); ++i) {
        out += (i ? ", " : "") + value_text(*array->get(i), fmt::format("{}[{}]", dotted, i));
      }
      return out + "]";
    }
    fail(node, fmt::format("{} must be a number, string, boolean or array, got {}", dotted, type_name(node)));
  }

};

VaryAxis read_axis(const SweepReader& r, const toml::node& node, const std::string& name) {
  const toml::table* entry = node.as_table();
  if (!entry) r.fail(node, fmt::format("{} must be a table with key and values (or from, to, count)", name));
  r.check_keys(*entry, name, {"key", "values", "from", "to", "count"});
  VaryAxis axis;
  axis.where = r.where(node);
  const toml::node* key = entry->get("key");
  if (!key) r.fail(node, fmt::format("missing key '{}.key' (a scene key such as params.s or grid.N)", name));
  axis.key = r.string(*key, name + ".key");
  if (axis.key.empty() || axis.key.find('=') != std::string::npos) {
    r.fail(*key, fmt::format("{}.key = \"{}\" is not a scene key path (keys joined by '.', e.g. grid.N)", name, axis.key));
  }
  if (axis.key.rfind("guess", 0) == 0 || axis.key.rfind("output", 0) == 0) {
    r.fail(*key, fmt::format("{}.key = \"{}\": the guess comes from [[guesses]] and [random_guesses], and outputs "
                             "from [output] of the sweep file",
                             name, axis.key));
  }
  const toml::node* values = entry->get("values");
  const toml::node* from = entry->get("from");
  const toml::node* to = entry->get("to");
  const toml::node* count = entry->get("count");
  if (values && (from || to || count)) {
    r.fail(*values, fmt::format("{}: give either values or from, to and count, not both", name));
  }
  if (values) {
    const toml::array* array = values->as_array();
    if (!array || array->empty()) r.fail(*values, fmt::format("{}.values must be a non-empty array", name));
    for (std::size_t i = 0; i < array->size(); ++i) {
      axis.values.push_back(r.value_text(*array->get(i), fmt::format("{}.values[{}]", name, i)));
    }
    return axis;
  }
  if (!from || !to || !count) {
    r.fail(node, fmt::format("{} needs values = [...] or all of from, to and count", name));
  }
  const double a = r.number(*from, name + ".from");
  const double b = r.number(*to, name + ".to");
  const long long n = r.integer(*count, name + ".count", 1, kMaxConfigurations);
  for (long long i = 0; i < n; ++i) {
    const double v = n == 1 ? a : (i == n - 1 ? b : a + (b - a) * static_cast<double>(i) / static_cast<double>(n - 1));
    axis.values.push_back(number_text(v));
  }
  return axis;
}

}  // namespace

Sweep parse_sweep(std::string_view text, const std::string& source_name,
                  const std::vector<std::string>& command_line_sets, const ModelResolver& resolve,
                  const std::vector<std::string>& model_names) {
  const toml::table root = detail::parse_document(text, source_name);
  const SweepReader r(source_name);
  r.check_keys(root, "", kTopKeys);
  Sweep sweep;
  sweep.path = source_name;

  const toml::node* scene_node = root.get("scene");
  if (!scene_node) {
    throw SceneError(fmt::format("{}: error: missing key 'scene' (the base scene, relative to the sweep file)",
                                 source_name));
  }
  const std::string scene_text = r.string(*scene_node, "scene");
  if (scene_text.empty()) r.fail(*scene_node, "scene must not be empty");
  sweep.scene_path = resolve_relative(source_name, scene_text);
  try {  // a missing file, a folder or a FIFO named at the key
    ::close(pardel::open_regular_file(sweep.scene_path, pardel::FileLimits::scene, "scene file"));
  } catch (const pardel::FileError& error) {
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(sweep.scene_path, ec)))
      r.fail(*scene_node, fmt::format("scene file '{}' not found", sweep.scene_path));
    r.fail(*scene_node, fmt::format("scene '{}' {}", sweep.scene_path, error.reason()));
  }

  if (const toml::node* set = root.get("set")) {
    const toml::array* array = set->as_array();
    if (!array) r.fail(*set, fmt::format("set must be an array of \"key=value\" strings, got {}", type_name(*set)));
    for (std::size_t i = 0; i < array->size(); ++i) {
      const std::string item = r.string(*array->get(i), fmt::format("set[{}]", i));
      if (item.find('=') == std::string::npos) {
        r.fail(*array->get(i), fmt::format("set[{}] = \"{}\" is not KEY=VALUE (e.g. solver.method=newton)", i, item));
      }
      // An override is one line of TOML: text after a line break would be dropped unseen.
      if (item.find_first_of("\n\r") != std::string::npos) {
        r.fail(*array->get(i), fmt::format("set[{}] holds a line break; an override is KEY=VALUE on one line", i));
      }
      sweep.sets.push_back(item);
    }
  }
  sweep.sets.insert(sweep.sets.end(), command_line_sets.begin(), command_line_sets.end());

  std::vector<const toml::node*> axis_nodes;
  if (const toml::node* vary = root.get("vary")) {
    const toml::array* array = vary->as_array();
    if (!array) r.fail(*vary, fmt::format("vary must be an array of tables ([[vary]]), got {}", type_name(*vary)));
    for (std::size_t i = 0; i < array->size(); ++i) {
      const std::string name = fmt::format("vary[{}]", i);
      sweep.axes.push_back(read_axis(r, *array->get(i), name));
      for (std::size_t j = 0; j + 1 < sweep.axes.size(); ++j) {
        if (sweep.axes[j].key == sweep.axes.back().key) {
          r.fail(*array->get(i), fmt::format("{}: key '{}' already varies in vary[{}]", name, sweep.axes.back().key, j));
        }
      }
      axis_nodes.push_back(array->get(i));
    }
  }

  // Configurations: the Cartesian product of the axes, last axis fastest.
  long long configurations = 1;
  for (const auto& axis : sweep.axes) {
    configurations *= static_cast<long long>(axis.values.size());
    if (configurations > kMaxConfigurations) {
      throw SceneError(fmt::format("{}: error: the varied keys give more than {} configurations (each is a scene "
                                   "loaded and checked before anything is solved)",
                                   source_name, kMaxConfigurations));
    }
  }
  for (long long c = 0; c < configurations; ++c) {
    std::vector<std::string> overrides = sweep.sets;
    std::vector<std::string> values(sweep.axes.size());
    long long rest = c;
    for (std::size_t a = sweep.axes.size(); a-- > 0;) {
      const auto& axis = sweep.axes[a];
      values[a] = axis.values[static_cast<std::size_t>(rest % static_cast<long long>(axis.values.size()))];
      rest /= static_cast<long long>(axis.values.size());
    }
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) overrides.push_back(sweep.axes[a].key + "=" + values[a]);
    Scene scene;
    try {
      scene = load_scene(sweep.scene_path, overrides, resolve, model_names);
    } catch (const SceneError& error) {
      // A bad varied value: say which; errors of the base scene or of `set` speak for themselves.
      const std::string what = error.what();
      for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
        if (what.find("--set " + sweep.axes[a].key + "=") != std::string::npos) {
          throw SceneError(fmt::format("{}: error: vary {} = {}: {}", sweep.axes[a].where, sweep.axes[a].key,
                                       values[a], what));
        }
      }
      throw;
    }
    if (!sweep.configurations.empty() && scene.model->ncoords != sweep.configurations.front().model->ncoords) {
      throw SceneError(fmt::format("{}: error: configuration {} uses model {} with {} coordinates; the guesses need "
                                   "the {} of model {}",
                                   source_name, c, scene.model->name, scene.model->ncoords,
                                   sweep.configurations.front().model->ncoords,
                                   sweep.configurations.front().model->name));
    }
    sweep.configurations.push_back(std::move(scene));
    sweep.configuration_values.push_back(std::move(values));
  }
  const pardel_model& model = *sweep.configurations.front().model;
  const int ncoords = model.ncoords;
  std::string coords;
  for (int i = 0; i < ncoords; ++i) coords += (i ? ", " : "") + std::string(model.coords[i]);
  const std::string coords_note = fmt::format("model {} has coords {}", model.name, coords);

  // [[guesses]]
  if (const toml::node* guesses = root.get("guesses")) {
    const toml::array* array = guesses->as_array();
    if (!array) {
      r.fail(*guesses, fmt::format("guesses must be an array of tables ([[guesses]] with points), got {}",
                                   type_name(*guesses)));
    }
    for (std::size_t i = 0; i < array->size(); ++i) {
      const std::string name = fmt::format("guesses[{}]", i);
      const toml::node& node = *array->get(i);
      const toml::table* entry = node.as_table();
      if (!entry) r.fail(node, fmt::format("{} must be a table with points, got {}", name, type_name(node)));
      r.check_keys(*entry, name, {"points"});
      const toml::node* points = entry->get("points");
      if (!points) r.fail(node, fmt::format("missing key '{}.points' (the polyline's vertices, ends included)", name));
      const toml::array* list = points->as_array();
      if (!list || list->size() < 2) {
        r.fail(*points, fmt::format("{}.points must be an array of at least 2 points ({})", name, coords_note));
      }
      std::vector<std::vector<double>> polyline;
      for (std::size_t j = 0; j < list->size(); ++j) {
        polyline.push_back(r.vector(*list->get(j), fmt::format("{}.points[{}]", name, j),
                                    static_cast<std::size_t>(ncoords), coords_note));
      }
      sweep.listed_guesses.push_back(std::move(polyline));
    }
  }

  // [random_guesses]
  if (const toml::table* random = r.table(root, "random_guesses", "random_guesses")) {
    r.check_keys(*random, "random_guesses", {"count", "interior_points", "seed", "box", "spread"});
    RandomGuessSpec& spec = sweep.random;
    const toml::node* count = random->get("count");
    if (!count) r.fail(random->source(), "missing key 'random_guesses.count' (how many random polylines)");
    spec.count = static_cast<int>(r.integer(*count, "random_guesses.count", 1, 1000000));
    if (const toml::node* n = random->get("interior_points")) {
      spec.interior_points = static_cast<int>(r.integer(*n, "random_guesses.interior_points", 1, 1000));
    }
    if (const toml::node* seed = random->get("seed")) {
      spec.seed = static_cast<std::uint64_t>(
          r.integer(*seed, "random_guesses.seed", 0, std::numeric_limits<long long>::max()));
    }
    const toml::node* box = random->get("box");
    const toml::node* spread = random->get("spread");
    if (box && spread) r.fail(*spread, "random_guesses: give either box or spread, not both");
    if (!box && !spread) {
      r.fail(random->source(), "random_guesses needs box = { min = [...], max = [...] } (vertices uniform in a box) "
                               "or spread = D (vertices within D of the straight line)");
    }
    if (box) {
      const toml::table* table = box->as_table();
      if (!table) r.fail(*box, fmt::format("random_guesses.box must be a table with min and max, got {}", type_name(*box)));
      r.check_keys(*table, "random_guesses.box", {"min", "max"});
      const toml::node* lo = table->get("min");
      const toml::node* hi = table->get("max");
      if (!lo || !hi) r.fail(*box, "random_guesses.box needs both min and max");
      spec.in_box = true;
      spec.box_min = r.vector(*lo, "random_guesses.box.min", static_cast<std::size_t>(ncoords), coords_note);
      spec.box_max = r.vector(*hi, "random_guesses.box.max", static_cast<std::size_t>(ncoords), coords_note);
      for (int i = 0; i < ncoords; ++i) {
        if (!(spec.box_min[i] <= spec.box_max[i])) {
          r.fail(*hi, fmt::format("random_guesses.box.max[{}] = {} is below min[{}] = {}", i, spec.box_max[i], i,
                                  spec.box_min[i]));
        }
        // A vertex is min + u (max - min): the width must be a finite number.
        if (!std::isfinite(spec.box_max[i] - spec.box_min[i])) {
          r.fail(*hi, fmt::format("random_guesses.box: max[{}] - min[{}] = {} - ({}) is beyond the range of a double",
                                  i, i, spec.box_max[i], spec.box_min[i]));
        }
      }
    } else {
      spec.spread = r.number(*spread, "random_guesses.spread");
      if (!(spec.spread > 0)) r.fail(*spread, fmt::format("random_guesses.spread must be > 0, got {}", spec.spread));
      // A vertex is q0 + f (qN - q0) + s spread, 0 <= f <= 1, |s| <= 1: finite in every configuration.
      for (std::size_t c = 0; c < sweep.configurations.size(); ++c) {
        const Problem& problem = sweep.configurations[c].problem;
        for (int i = 0; i < ncoords; ++i) {
          const double q0 = problem.q0[i], qN = problem.qN[i];
          if (!std::isfinite(qN - q0) || !std::isfinite(std::abs(q0) + std::abs(qN - q0) + spec.spread)) {
            r.fail(*spread, fmt::format("random_guesses.spread = {}: the vertices around the line from q0[{}] = {} "
                                        "to qN[{}] = {} (configuration {}) are beyond the range of a double",
                                        spec.spread, i, q0, i, qN, c));
          }
        }
      }
    }
    const long long numbers = static_cast<long long>(spec.count) * spec.interior_points * ncoords;
    if (numbers > kMaxRandomNumbers) {
      r.fail(*count, fmt::format("random_guesses: count x interior_points x coordinates = {} x {} x {} = {} random "
                                 "numbers, more than {}",
                                 spec.count, spec.interior_points, ncoords, numbers, kMaxRandomNumbers));
    }
    // std::mt19937_64's sequence is fixed by the C++ standard, so the guesses are the same everywhere.
    std::mt19937_64 generator(spec.seed);
    const std::size_t per_guess = static_cast<std::size_t>(spec.interior_points) * ncoords;
    sweep.random_unit.resize(static_cast<std::size_t>(spec.count) * per_guess);
    for (double& u : sweep.random_unit) u = static_cast<double>(generator() >> 11) * 0x1.0p-53;
  }
  if (static_cast<long long>(sweep.configurations.size()) * sweep.guesses_per_configuration() > kMaxVariants) {
    throw SceneError(fmt::format("{}: error: the sweep has more than {} variants", source_name, kMaxVariants));
  }

  // [grouping]
  if (const toml::table* grouping = r.table(root, "grouping", "grouping")) {
    r.check_keys(*grouping, "grouping", {"action_tol", "distance_tol"});
    for (const char* key : {"action_tol", "distance_tol"}) {
      const toml::node* node = grouping->get(key);
      if (!node) continue;
      const std::string dotted = std::string("grouping.") + key;
      const double v = r.number(*node, dotted);
      if (!(v >= 0)) r.fail(*node, fmt::format("{} must be >= 0, got {}", dotted, v));
      (std::string(key) == "action_tol" ? sweep.grouping.action_tol : sweep.grouping.distance_tol) = v;
    }
  }

  // [output]
  if (const toml::table* output = r.table(root, "output", "output")) {
    r.check_keys(*output, "output", {"dir", "plot"});
    if (const toml::node* dir = output->get("dir")) {
      sweep.output_dir = r.string(*dir, "output.dir");
      if (sweep.output_dir.empty()) r.fail(*dir, "output.dir must not be empty");
    }
    if (const toml::node* plot = output->get("plot")) {
      if (!plot->is_boolean()) r.fail(*plot, fmt::format("output.plot must be a boolean, got {}", type_name(*plot)));
      sweep.plot = plot->as_boolean()->get();
    }
  }
  return sweep;
}

Sweep load_sweep(const std::string& path, const std::vector<std::string>& command_line_sets,
                 const ModelResolver& resolve, const std::vector<std::string>& model_names) {
  std::string text;
  try {
    text = pardel::read_regular_file(path, pardel::FileLimits::sweep, "sweep file");
  } catch (const pardel::FileError& error) {
    throw SceneError(error.what());
  }
  return parse_sweep(text, path, command_line_sets, resolve, model_names);
}

Variant make_variant(const Sweep& sweep, int id) {
  Variant v;
  v.id = id;
  const int per = sweep.guesses_per_configuration();
  v.configuration = id / per;
  v.guess = id % per;
  const int listed = static_cast<int>(sweep.listed_guesses.size());
  if (listed + sweep.random.count == 0) {
    v.guess_label = "scene";
    return v;
  }
  if (v.guess < listed) {
    v.guess_label = fmt::format("listed {}", v.guess);
    v.points = sweep.listed_guesses[v.guess];
    return v;
  }
  const int r = v.guess - listed;
  v.guess_label = fmt::format("random {}", r);
  const Problem& problem = sweep.configurations[v.configuration].problem;
  const int nc = problem.model->ncoords;
  const RandomGuessSpec& spec = sweep.random;
  const double* u = sweep.random_unit.data() + static_cast<std::size_t>(r) * spec.interior_points * nc;
  std::vector<double> q0(problem.q0.begin(), problem.q0.begin() + nc);
  std::vector<double> qN(problem.qN.begin(), problem.qN.begin() + nc);
  v.points.push_back(q0);
  for (int i = 0; i < spec.interior_points; ++i) {
    std::vector<double> point(nc);
    const double f = static_cast<double>(i + 1) / (spec.interior_points + 1);
    for (int j = 0; j < nc; ++j) {
      const double unit = u[static_cast<std::size_t>(i) * nc + j];
      point[j] = spec.in_box ? spec.box_min[j] + unit * (spec.box_max[j] - spec.box_min[j])
                             : q0[j] + f * (qN[j] - q0[j]) + (2 * unit - 1) * spec.spread;
    }
    v.points.push_back(std::move(point));
  }
  v.points.push_back(qN);
  return v;
}

VariantResult solve_variant(const Sweep& sweep, const Variant& variant, int threads, const std::atomic<bool>* stop) {
  VariantResult result;
  result.id = variant.id;
  result.configuration = variant.configuration;
  if (stop && stop->load()) {
    result.status = to_string(Termination::interrupted);
    result.message = "not started: the sweep was interrupted";
    result.cost = std::nan("");
    return result;
  }
  try {
    Scene scene = sweep.configurations.at(variant.configuration);
    if (!variant.points.empty()) {
      scene.guess.kind = GuessKind::polyline;
      scene.guess.points = variant.points;
    }
    if (threads > 0) scene.options.threads = threads;
    // Each variant in this process (sweeps spread variants, not nodes, over ranks); refused before
    // anything of size N is allocated, as `pardel solve` refuses the scene.
    SolveRequest request;
    request.over_ranks = false;
    request.check_memory = sweep.memory_check;
    if (stop) request.on_iteration = [stop](const IterationRecord&) { return !stop->load(); };
    Trajectory trajectory;  // the variant's scene's guess
    Summary summary;
    try {
      summary = run_solve(scene, trajectory, request).summary;
    } catch (const MemoryRefused& refused) {
      result.status = "error";
      result.message = "refused before solving: " + refused.reason() + " (--no-memory-check skips this check)";
      result.cost = std::nan("");
      return result;
    }
    result.status = to_string(summary.termination);
    result.message = summary.message;
    result.iterations = summary.iterations;
    result.residual = summary.residual;
    result.action = summary.action;
    result.seconds = summary.wall_seconds;
    const bool have_trajectory = trajectory.N >= 2 && static_cast<int>(trajectory.t.size()) == trajectory.N + 1;
    result.cost = have_trajectory ? physical_cost(scene, summary, trajectory).value : std::nan("");
    if (summary.converged() && have_trajectory) {
      // The solve's own point assessment (inertia from its factorization, O(N)).
      const PointAssessment& point = summary.point;
      result.certificate_valid = point.kind != PointKind::unknown;
      result.hessian_positive_definite = point.kind == PointKind::minimum;
      result.inertia_negative = point.negative;
      result.inertia_zero = point.zero;
      result.trajectory = std::move(trajectory);
    } else if (summary.converged()) {
      result.status = "error";
      result.message = "converged without a trajectory on the grid";
    }
  } catch (const OutOfMemory& error) {
    result = VariantResult{};
    result.id = variant.id;
    result.configuration = variant.configuration;
    result.status = "error";
    result.cost = std::nan("");
    result.message = error.what();
  } catch (const std::exception& error) {
    result.status = "error";
    result.message = error.what();
  }
  return result;
}

std::string certificate_verdict(const VariantResult& result) {
  if (!result.certificate_valid) return "unknown";
  if (result.hessian_positive_definite) return "minimum";
  if (result.inertia_negative > 0) return fmt::format("saddle ({} negative)", result.inertia_negative);
  return fmt::format("degenerate ({} zero)", result.inertia_zero);
}

double trajectory_distance(const Trajectory& a, const Trajectory& b) {
  if (a.N != b.N || a.dim != b.dim || a.q.size() != b.q.size()) return std::numeric_limits<double>::infinity();
  double largest = 0;
  for (std::size_t i = 0; i < a.q.size(); ++i) {
    const double d = std::abs(a.q[i] - b.q[i]);
    if (std::isnan(d)) return std::numeric_limits<double>::infinity();  // not the same path
    largest = std::max(largest, d);
  }
  return largest;
}

bool same_solution(const VariantResult& a, const VariantResult& b, const GroupingOptions& options) {
  if (a.configuration != b.configuration) return false;
  if (!(std::abs(a.action - b.action) <= options.action_tol * std::max(1.0, std::abs(a.action)))) return false;
  return trajectory_distance(a.trajectory, b.trajectory) <= options.distance_tol;
}

std::vector<Solution> group_solutions(const std::vector<VariantResult>& results, const GroupingOptions& options,
                                      std::vector<int>* solution_of) {
  std::vector<Solution> groups;
  std::vector<std::size_t> representative;  // index into results
  std::vector<int> group_of(results.size(), -1);
  std::map<int, std::size_t> group_of_representative;  // variant id -> group
  for (std::size_t i = 0; i < results.size(); ++i) {
    const VariantResult& r = results[i];
    if (!r.converged()) continue;
    // Matched while the sweep ran (its trajectory released): the same comparisons, made then.
    const auto known = r.same_as >= 0 ? group_of_representative.find(r.same_as) : group_of_representative.end();
    if (known != group_of_representative.end()) {
      group_of[i] = static_cast<int>(known->second);
      groups[known->second].variants.push_back(r.id);
      continue;
    }
    for (std::size_t g = 0; g < groups.size(); ++g) {
      if (same_solution(results[representative[g]], r, options)) {
        group_of[i] = static_cast<int>(g);
        groups[g].variants.push_back(r.id);
        break;
      }
    }
    if (group_of[i] >= 0) continue;
    Solution s;
    s.configuration = r.configuration;
    s.first_variant = r.id;
    s.variants.push_back(r.id);
    s.cost = r.cost;
    s.action = r.action;
    s.residual = r.residual;
    group_of[i] = static_cast<int>(groups.size());
    group_of_representative[r.id] = groups.size();
    groups.push_back(std::move(s));
    representative.push_back(i);
  }
  std::vector<std::size_t> order(groups.size());
  for (std::size_t g = 0; g < order.size(); ++g) order[g] = g;
  std::stable_sort(order.begin(), order.end(), [&groups](std::size_t x, std::size_t y) {
    const Solution& a = groups[x];
    const Solution& b = groups[y];
    if (a.configuration != b.configuration) return a.configuration < b.configuration;
    if (a.cost != b.cost) return a.cost < b.cost;  // NaN costs keep their place among equals
    return a.first_variant < b.first_variant;
  });
  std::vector<Solution> sorted;
  std::vector<int> id_of_group(groups.size());
  int rank = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    Solution s = groups[order[k]];
    s.id = static_cast<int>(k) + 1;
    rank = (k > 0 && sorted.back().configuration == s.configuration) ? rank + 1 : 1;
    s.rank = rank;
    id_of_group[order[k]] = s.id;
    sorted.push_back(std::move(s));
  }
  if (solution_of) {
    solution_of->assign(results.size(), 0);
    for (std::size_t i = 0; i < results.size(); ++i) {
      if (group_of[i] >= 0) (*solution_of)[i] = id_of_group[group_of[i]];
    }
  }
  return sorted;
}

namespace {

/** A CSV cell: quoted when it holds a comma, a quote or a newline. */
std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string points_text(const std::vector<std::vector<double>>& points) {
  std::string out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    out += i ? ";" : "";
    for (std::size_t j = 0; j < points[i].size(); ++j) out += (j ? " " : "") + fmt::format("{}", points[i][j]);
  }
  return out;
}

const VariantResult* find_result(const std::vector<VariantResult>& results, int id) {
  if (id >= 0 && id < static_cast<int>(results.size()) && results[id].id == id) return &results[id];
  // In variant order, with the variants not started (after an interruption) left out.
  const auto it = std::lower_bound(results.begin(), results.end(), id,
                                   [](const VariantResult& r, int value) { return r.id < value; });
  if (it != results.end() && it->id == id) return &*it;
  for (const auto& r : results) {
    if (r.id == id) return &r;
  }
  return nullptr;
}

/** Writes the text that `append(out)` produces, chunk by chunk, to a temporary file beside `path`
 *  and renames it into place (memory stays bounded however many rows there are). */
void write_streamed_atomic(const std::string& path, const std::function<bool(std::string& out)>& append) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw std::runtime_error(fmt::format("{}: cannot write: {}", tmp, std::strerror(errno)));
  std::string chunk;
  bool ok = true;
  for (bool more = true; more && ok;) {
    chunk.clear();
    while ((more = append(chunk)) && chunk.size() < (1u << 20)) {
    }
    ok = std::fwrite(chunk.data(), 1, chunk.size(), f) == chunk.size();
  }
  ok = ok && std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const int err = errno;
  if (std::fclose(f) != 0 || !ok) {
    std::remove(tmp.c_str());
    throw std::runtime_error(fmt::format("{}: cannot write: {}", tmp, std::strerror(err)));
  }
  rename_into_place(tmp, path);
}

/** solution_<digits>.csv, the trajectory files of a sweep. */
bool is_solution_file(const std::string& name) {
  constexpr std::string_view prefix = "solution_", suffix = ".csv";
  if (name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  return digits.find_first_not_of("0123456789") == std::string::npos;
}

}  // namespace

std::string solutions_csv(const std::vector<VariantResult>& results, const std::vector<Solution>& solutions) {
  std::string out = "solution,configuration,rank,cost,action,residual,variants,first_variant,certificate\n";
  for (const auto& s : solutions) {
    const VariantResult* r = find_result(results, s.first_variant);
    out += fmt::format("{},{},{},{},{},{},{},{},{}\n", s.id, s.configuration, s.rank, format_double(s.cost),
                       format_double(s.action), format_double(s.residual), s.variants.size(), s.first_variant,
                       csv_cell(r ? certificate_verdict(*r) : "unknown"));
  }
  return out;
}

void write_sweep_outputs(const Sweep& sweep, const std::vector<VariantResult>& results,
                         const std::vector<Solution>& solutions, const std::vector<int>& solution_of,
                         const SweepRunInfo& info, const std::string& out_dir) {
  create_output_folder(out_dir);
  const fs::path dir(out_dir);
  const std::string index_path = (dir / "sweep.json").string();
  // Paths that are not UTF-8 are written with U+FFFD for their invalid bytes (valid JSON, never thrown).
  const std::string index =
      sweep_json(sweep, results, solutions, info).dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) +
      "\n";

  // An earlier sweep's files go first, its index (sweep.json) before the rest: an interrupted or
  // smaller sweep must not leave solution_<id>.csv files (or a picture) that look like its own.
  // Whenever sweep.json exists, the files beside it are the ones it lists.
  for (const char* name : {"sweep.json", "solutions.csv", "variants.csv", "sweep.png"}) {
    remove_stale_temporaries((dir / name).string());
    if (::unlink((dir / name).c_str()) != 0 && errno != ENOENT)
      throw std::runtime_error(fmt::format("{}: cannot remove the earlier sweep's file: {}", (dir / name).string(),
                                           std::strerror(errno)));
  }
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const auto tmp = name.find(".tmp.");
    if (!is_solution_file(tmp == std::string::npos ? name : name.substr(0, tmp))) continue;
    if (tmp != std::string::npos) {
      remove_stale_temporaries((dir / name.substr(0, tmp)).string());
    } else if (::unlink(it->path().c_str()) != 0 && errno != ENOENT) {
      throw std::runtime_error(fmt::format("{}: cannot remove the earlier sweep's file: {}", it->path().string(),
                                           std::strerror(errno)));
    }
  }

  // one trajectory per solution
  for (const auto& s : solutions) {
    const VariantResult* r = find_result(results, s.first_variant);
    if (!r) continue;
    write_file_atomic((dir / fmt::format("solution_{}.csv", s.id)).string(),
                      trajectory_csv(*sweep.configurations[s.configuration].model, r->trajectory));
  }

  write_file_atomic((dir / "solutions.csv").string(), solutions_csv(results, solutions));

  // variants.csv, one row per variant started, written as it is formatted
  std::string header = "variant,configuration";
  for (const auto& axis : sweep.axes) header += "," + csv_cell(axis.key);
  header += ",guess,guess_points,status,iterations,residual,action,cost,certificate,solution,error,seconds\n";
  std::size_t next = 0;
  bool header_done = false;
  write_streamed_atomic((dir / "variants.csv").string(), [&](std::string& out) {
    if (!header_done) {
      out += header;
      header_done = true;
      return !results.empty();
    }
    const std::size_t i = next++;
    const VariantResult& r = results[i];
    const Variant v = make_variant(sweep, r.id);
    out += fmt::format("{},{}", r.id, r.configuration);
    for (const auto& value : sweep.configuration_values[r.configuration]) out += "," + csv_cell(value);
    out += fmt::format(",{},{},{},{},{},{},{},{},{},{},{}\n", v.guess_label, points_text(v.points), r.status,
                       r.iterations, format_double(r.residual), format_double(r.action), format_double(r.cost),
                       r.converged() ? csv_cell(certificate_verdict(r)) : "",
                       i < solution_of.size() && solution_of[i] > 0 ? std::to_string(solution_of[i]) : "",
                       r.status == "error" ? csv_cell(r.message) : "", format_double(r.seconds));
    return next < results.size();
  });

  write_file_atomic(index_path, index);
}

nlohmann::ordered_json sweep_json(const Sweep& sweep, const std::vector<VariantResult>& results,
                                  const std::vector<Solution>& solutions, const SweepRunInfo& info) {
  const Scene& first = sweep.configurations.front();
  const PhysicalCost cost_kind = physical_cost(first, Summary{}, Trajectory{});  // for its name only
  nlohmann::ordered_json j;
  j["sweep"] = sweep.path;
  j["scene"] = sweep.scene_path;
  j["model"] = first.model->name;
  j["model_source"] = scene_model_source(first);
  j["discretization"] = first.discretization;
  j["cost"] = {{"name", cost_kind.name}, {"definition", cost_kind.definition}};
  j["set"] = sweep.sets;
  j["variants"] = sweep.variant_count();
  // After an interruption, the variants never started (not listed in variants.csv).
  j["not_started"] = static_cast<std::size_t>(sweep.variant_count()) - std::min(results.size(),
                                                                                 static_cast<std::size_t>(sweep.variant_count()));
  j["guesses_per_configuration"] = sweep.guesses_per_configuration();
  nlohmann::ordered_json configurations = nlohmann::ordered_json::array();
  for (std::size_t c = 0; c < sweep.configurations.size(); ++c) {
    const Scene& scene = sweep.configurations[c];
    nlohmann::ordered_json values = nlohmann::ordered_json::object();
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) values[sweep.axes[a].key] = sweep.configuration_values[c][a];
    nlohmann::ordered_json params = nlohmann::ordered_json::object();
    for (int i = 0; i < scene.model->nparams; ++i) params[scene.model->param_names[i]] = scene.problem.params[i];
    configurations.push_back({{"id", c}, {"values", values}, {"N", scene.problem.N}, {"params", params},
                              {"method", to_string(scene.options.method)}, {"tol", scene.options.tol}});
  }
  j["configurations"] = configurations;
  j["ranks"] = info.ranks;
  j["threads"] = info.threads;
  j["wall_seconds"] = info.wall_seconds;
  j["grouping"] = {{"action_tol", sweep.grouping.action_tol}, {"distance_tol", sweep.grouping.distance_tol}};
  std::map<std::string, int> by_status;
  int converged = 0;
  for (const auto& r : results) {
    if (r.converged()) ++converged;
    else ++by_status[r.status];
  }
  j["converged"] = converged;
  nlohmann::ordered_json failures = nlohmann::ordered_json::object();
  for (const auto& [status, count] : by_status) failures[status] = count;
  j["failures"] = failures;
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  const Solution* best = nullptr;
  for (const auto& s : solutions) {
    const VariantResult* r = find_result(results, s.first_variant);
    list.push_back({{"id", s.id}, {"configuration", s.configuration}, {"rank", s.rank}, {"cost", s.cost},
                    {"action", s.action}, {"residual", s.residual}, {"variants", s.variants.size()},
                    {"first_variant", s.first_variant}, {"certificate", r ? certificate_verdict(*r) : "unknown"},
                    {"trajectory", fmt::format("solution_{}.csv", s.id)}});
    if (!best || s.cost < best->cost) best = &s;
  }
  j["solutions_count"] = solutions.size();
  j["solutions"] = list;
  j["best"] = best ? list[static_cast<std::size_t>(best->id - 1)] : nlohmann::ordered_json(nullptr);
  return j;
}

namespace {

std::string short_number(double v) { return fmt::format("{:.10g}", v); }

}  // namespace

void print_sweep_report(const Sweep& sweep, const std::vector<VariantResult>& results,
                  const std::vector<Solution>& solutions, const SweepRunInfo& info, const std::string& out_dir) {
  std::map<std::string, int> failures;
  int converged = 0;
  for (const auto& r : results) {
    if (r.converged()) ++converged;
    else ++failures[r.status];
  }
  std::string failed;
  for (const auto& [status, count] : failures) failed += fmt::format("{}{} {}", failed.empty() ? "" : ", ", count, status);
  const std::size_t total = static_cast<std::size_t>(sweep.variant_count());
  if (results.size() < total) {
    failed += fmt::format("{}{} not started", failed.empty() ? "" : ", ", total - results.size());
  }
  const PhysicalCost kind = physical_cost(sweep.configurations.front(), Summary{}, Trajectory{});
  std::cout << fmt::format("sweep {}: {} variant{} on {} rank{}, {} converged{}, {} distinct solution{}, {:.3g} s\n",
                           sweep.path, total, total == 1 ? "" : "s", info.ranks,
                           info.ranks == 1 ? "" : "s", converged, failed.empty() ? "" : " (" + failed + ")",
                           solutions.size(), solutions.size() == 1 ? "" : "s", info.wall_seconds);
  if (solutions.empty()) return;
  const bool several = sweep.configurations.size() > 1;
  std::cout << fmt::format("{:>8}{}{:>5}  {:>18}  {:>18}  {:>9}  {:>8}  {}\n", "solution",
                           several ? fmt::format("{:>7}", "config") : "", "rank",
                           kind.name == "action" ? "cost (action)" : kind.name, "action", "residual",
                           "variants", "certificate");
  for (const auto& s : solutions) {
    const VariantResult* representative = find_result(results, s.first_variant);
    const std::string verdict = representative ? certificate_verdict(*representative) : "unknown";
    std::cout << fmt::format("{:>8}{}{:>5}  {:>18}  {:>18}  {:>9.2e}  {:>8}  {}\n", s.id,
                             several ? fmt::format("{:>7}", s.configuration) : "", s.rank, short_number(s.cost),
                             short_number(s.action), s.residual, s.variants.size(), verdict);
  }
  const Solution* best = &solutions.front();
  for (const auto& s : solutions) {
    if (s.cost < best->cost) best = &s;
  }
  std::cout << fmt::format("best: solution {}, {} = {} (first reached by variant {}, {})\n", best->id, kind.name,
                           format_double(best->cost), best->first_variant,
                           make_variant(sweep, best->first_variant).guess_label);
  std::cout << "output: " << out_dir << "\n";
}

}  // namespace pardel::app
