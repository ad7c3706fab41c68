/**
 * @file scene_reader.hpp
 * Internal to the scene reader: SceneReader, which walks a parsed scene and names where each key
 * came from (FILE:LINE:COL or the --set that supplied it), and the readers of the scene's tables,
 * one each (scene_sections.cpp), which scene.cpp's read_scene calls in order.
 */
#ifndef PARDEL_APP_SCENE_READER_HPP
#define PARDEL_APP_SCENE_READER_HPP

#include <fmt/format.h>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "pardel/app/scene.hpp"
#include "toml_read.hpp"

namespace pardel::app::detail {

/** Walks a parsed scene, checking each key; every error names the key and where it came from. */
class SceneReader : public TomlReader {
 public:
  SceneReader(const std::string& file, std::map<std::string, std::string> origins)
      : TomlReader(file), origins_(std::move(origins)) {}

  using TomlReader::boolean;
  using TomlReader::integer;
  using TomlReader::number;
  using TomlReader::string;

  /** "FILE:LINE:COL", or the --set that supplied the key, or the file alone. */
  std::string where(const toml::source_region& source, const std::string& dotted) const override {
    if (source.begin.line > 0 && source.path && source.path->rfind("--set", 0) != 0) {
      return TomlReader::where(source, dotted);
    }
    // An element (boundary.q0[1]) comes from wherever its array came from.
    std::string prefix = dotted.substr(0, dotted.find('['));
    for (;;) {
      auto it = origins_.find(prefix);
      if (it != origins_.end()) return it->second;
      const auto dot = prefix.rfind('.');
      if (dot == std::string::npos) break;
      prefix.resize(dot);
    }
    return file();
  }

  /** The optional keys: parent[key] read as number(), integer() or string(); nullopt when the
   *  table or the key is absent. */
  std::optional<double> number(const toml::table* parent, const std::string& key, const std::string& dotted) const {
    const toml::node* node = find(parent, key);
    return node ? std::optional<double>(number(*node, dotted)) : std::nullopt;
  }
  std::optional<long long> integer(const toml::table* parent, const std::string& key, const std::string& dotted) const {
    const toml::node* node = find(parent, key);
    return node ? std::optional<long long>(integer(*node, dotted)) : std::nullopt;
  }
  std::optional<std::string> string(const toml::table* parent, const std::string& key, const std::string& dotted) const {
    const toml::node* node = find(parent, key);
    return node ? std::optional<std::string>(string(*node, dotted)) : std::nullopt;
  }
  std::optional<bool> boolean(const toml::table* parent, const std::string& key, const std::string& dotted) const {
    const toml::node* node = find(parent, key);
    return node ? std::optional<bool>(boolean(*node, dotted)) : std::nullopt;
  }

  /** A number (bounded_number) or an integer (bounded_integer) that must lie within the bound of
   *  the member `option` of pardel::Options (option_bound), failing with that bound's rule. */
  std::optional<double> bounded_number(const toml::table* parent, const std::string& key, const std::string& dotted,
                                       std::string_view option) const {
    const auto value = number(parent, key, dotted);
    if (value) check_bound(*parent->get(key), dotted, option, *value, fmt::format("{}", *value));
    return value;
  }
  std::optional<long long> bounded_integer(const toml::table* parent, const std::string& key, const std::string& dotted,
                                           std::string_view option) const {
    const auto value = integer(parent, key, dotted);
    if (value) check_bound(*parent->get(key), dotted, option, static_cast<double>(*value), std::to_string(*value));
    return value;
  }

 private:
  static const toml::node* find(const toml::table* parent, const std::string& key) {
    return parent ? parent->get(key) : nullptr;
  }

  void check_bound(const toml::node& node, const std::string& dotted, std::string_view option, double value,
                   const std::string& shown) const {
    const OptionBound* bound = option_bound(option);
    if (!bound->accepts(value)) fail(node, dotted, fmt::format("{} {}, got {}", dotted, bound->rule, shown));
  }

  std::map<std::string, std::string> origins_;
};

/** The `model` key: a bundled model's name or a .lag path, resolved (relative paths against the
 *  scene's folder first). */
void read_model(const SceneReader& r, const toml::table& root, const ModelResolver& resolve,
                const std::vector<std::string>& model_names, Scene& scene);

/** The `discretization` key, else the model's first. */
void read_discretization(const SceneReader& r, const toml::table& root, Scene& scene);

/** [params]: the model's params by name, the others at their defaults. */
void read_params(const SceneReader& r, const toml::table& root, Scene& scene);

/** [grid]: t0, T and N, with node times that a double can tell apart; or an adaptive grid:
 *  accuracy (and accuracy_max_N), N then being the first grid's (default kAdaptiveStartN). */
void read_grid(const SceneReader& r, const toml::table& root, Scene& scene);

/** [boundary]: q0, qN and, for higher orders, the derivatives' end values, laid out
 *  [coords, coords', ...] (derivative by derivative). */
void read_boundary(const SceneReader& r, const toml::table& root, Scene& scene);

/** [solver]: the method and its options, and the clock mode (read before the knots: the clock
 *  mode decides whether knots make sense). */
void read_solver(const SceneReader& r, const toml::table& root, Scene& scene);

/** [[knots]]: interior points the path must pass, each on a grid node. */
void read_knots(const SceneReader& r, const toml::table& root, Scene& scene);

/** [guess]: the initial guess (linear, polyline or a trajectory.csv). */
void read_guess(const SceneReader& r, const toml::table& root, Scene& scene);

/** [output]: the output folder. */
void read_output(const SceneReader& r, const toml::table& root, Scene& scene);

}  // namespace pardel::app::detail

#endif  // PARDEL_APP_SCENE_READER_HPP
