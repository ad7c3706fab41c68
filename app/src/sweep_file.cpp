// The sweep file of `pardel sweep`: reading it (every error names FILE:LINE:COL), its
// configurations (the base scene with the varied keys, each loaded and checked), the listed and
// random guesses, grouping and output settings (see sweep.hpp for the contract).
#include "pardel/app/sweep.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <random>

#include <unistd.h>

#include "pardel/regular_file.hpp"
#include "toml_read.hpp"

namespace pardel::app {

namespace fs = std::filesystem;

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

/** scene = "FILE": the base scene, relative to the sweep file, a regular file. */
void read_scene_key(const SweepReader& r, const toml::table& root, const std::string& source_name, Sweep& sweep) {
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
}

/** set = ["KEY=VALUE", ...], then the command line's overrides. */
void read_sets(const SweepReader& r, const toml::table& root, const std::vector<std::string>& command_line_sets,
               Sweep& sweep) {
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
      sweep.set_origins.push_back(fmt::format("{}: error: set[{}]", r.where(*array->get(i)), i));
    }
  }
  sweep.sets.insert(sweep.sets.end(), command_line_sets.begin(), command_line_sets.end());
  sweep.set_origins.resize(sweep.sets.size());
}

/** An override of a varied key would be replaced by every variant's value unseen (and its value
 *  never checked): refused, naming both. */
void check_sets_against_axes(const Sweep& sweep) {
  auto trimmed = [](std::string text) {
    const auto first = text.find_first_not_of(" \t");
    const auto last = text.find_last_not_of(" \t");
    return first == std::string::npos ? std::string() : text.substr(first, last - first + 1);
  };
  for (std::size_t i = 0; i < sweep.sets.size(); ++i) {
    const std::string key = trimmed(sweep.sets[i].substr(0, sweep.sets[i].find('=')));
    for (const VaryAxis& axis : sweep.axes) {
      if (axis.key != key) continue;
      const std::string what = sweep.set_origins[i].empty()
                                   ? fmt::format("--set {}: error:", sweep.sets[i])
                                   : fmt::format("{} = \"{}\":", sweep.set_origins[i], sweep.sets[i]);
      throw SceneError(fmt::format("{} the sweep varies {} ({}): each variant's value would replace this override",
                                   what, key, axis.where));
    }
  }
}

/** [[vary]]: the varied keys, each once. */
void read_axes(const SweepReader& r, const toml::table& root, Sweep& sweep) {
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
    }
  }
}

/** Every configuration's scene, loaded and checked; a bad varied value names its axis. */
void load_configurations(const std::string& source_name, const ModelResolver& resolve,
                         const std::vector<std::string>& model_names, Sweep& sweep) {
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
      // A bad varied value, or a bad entry of the sweep file's `set`: say which, where; errors of
      // the base scene or of the command line's --set speak for themselves.
      const std::string what = error.what();
      for (std::size_t i = 0; i < sweep.sets.size(); ++i) {
        const std::string prefix = "--set " + sweep.sets[i] + ": ";
        if (!sweep.set_origins[i].empty() && what.rfind(prefix, 0) == 0) {
          std::string reason = what.substr(prefix.size());
          if (reason.rfind("error: ", 0) == 0) reason = reason.substr(7);
          throw SceneError(fmt::format("{} = \"{}\": {}", sweep.set_origins[i], sweep.sets[i], reason));
        }
      }
      for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
        if (what.find("--set " + sweep.axes[a].key + "=") != std::string::npos) {
          throw SceneError(fmt::format("{}: error: vary {} = {}: {}", sweep.axes[a].where, sweep.axes[a].key,
                                       values[a], what));
        }
      }
      // An error of the base scene that only this configuration's varied values bring out (another
      // model's coordinates against the scene's boundary values): the message names them.
      if (!sweep.axes.empty()) {
        std::string varied;
        for (std::size_t a = 0; a < sweep.axes.size(); ++a)
          varied += fmt::format("{}vary {} = {} ({})", a ? ", " : "", sweep.axes[a].key, values[a], sweep.axes[a].where);
        throw SceneError(what + "; in the sweep's configuration " + varied);
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
}

/** [[guesses]]: polylines of the model's coordinates, ends included. */
void read_listed_guesses(const SweepReader& r, const toml::table& root, int ncoords, const std::string& coords_note,
                         Sweep& sweep) {
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
}

/** [random_guesses]: the specification, checked to give finite vertices in every configuration,
 *  and all its random numbers drawn now. */
void read_random_guesses(const SweepReader& r, const toml::table& root, int ncoords, const std::string& coords_note,
                         Sweep& sweep) {
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
}

/** [grouping] and [output]. */
void read_grouping_and_output(const SweepReader& r, const toml::table& root, Sweep& sweep) {
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
  read_scene_key(r, root, source_name, sweep);
  read_sets(r, root, command_line_sets, sweep);
  read_axes(r, root, sweep);
  check_sets_against_axes(sweep);
  load_configurations(source_name, resolve, model_names, sweep);
  const pardel_model& model = *sweep.configurations.front().model;
  const int ncoords = model.ncoords;
  std::string coords;
  for (int i = 0; i < ncoords; ++i) coords += (i ? ", " : "") + std::string(model.coords[i]);
  const std::string coords_note = fmt::format("model {} has coords {}", model.name, coords);
  read_listed_guesses(r, root, ncoords, coords_note, sweep);
  read_random_guesses(r, root, ncoords, coords_note, sweep);
  if (static_cast<long long>(sweep.configurations.size()) * sweep.guesses_per_configuration() > kMaxVariants) {
    throw SceneError(fmt::format("{}: error: the sweep has more than {} variants", source_name, kMaxVariants));
  }
  read_grouping_and_output(r, root, sweep);
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

}  // namespace pardel::app
