/**
 * @file scene.hpp
 * Scenes: the TOML files (schema version 1) that describe one boundary-value problem for
 * `pardel solve` and `pardel check` — model, discretization, params, grid, boundary values,
 * knots, initial guess, solver options and output folder. Parsing is strict: unknown keys,
 * wrong types and wrong sizes raise SceneError naming the key and its FILE:LINE:COL, with the
 * nearest valid key suggested. Each TOML table has its own reader (scene.cpp); the command line,
 * the Python module, tests and fuzzers call the same parse_scene, or for a table built in memory
 * (pardel.solve's keyword arguments) its entry point read_scene_table (scene_table.hpp).
 */
#ifndef PARDEL_APP_SCENE_HPP
#define PARDEL_APP_SCENE_HPP

#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "pardel/pardel.hpp"

namespace pardel::app {

/** A user error in a scene or an override; what() is "LOCATION: error: MESSAGE". */
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** How the initial guess is built. */
enum class GuessKind { linear, polyline, csv };

struct GuessSpec {
  GuessKind kind = GuessKind::linear;
  std::vector<std::vector<double>> points;  ///< polyline vertices, ncoords values each
  std::string csv_path;                     ///< csv: resolved against the scene's folder
};

/** A parsed and checked scene. */
struct Scene {
  std::string path;        ///< the scene file (or the source name given to parse_scene)
  std::string model_spec;  ///< the `model` value as written
  std::string model_path;  ///< the .lag file it resolved to (relative paths against the scene's folder), or ""
  const pardel_model* model = nullptr;
  std::string discretization;  ///< canonical name of problem.discretization
  Problem problem;
  Options options;
  GuessSpec guess;
  std::string output_dir;  ///< [output].dir, empty when not given
};

/**
 * Resolves a model name or .lag path to a model; returns nullptr when the name is unknown, or
 * throws std::exception with the reason when a .lag file cannot be loaded.
 */
using ModelResolver = std::function<const pardel_model*(const std::string& name_or_path)>;

/**
 * Parses scene text. `source_name` names the text in messages (usually its path; relative
 * paths inside the scene resolve against its folder). `overrides` are "key.path=value" strings
 * (as given to --set): each value is read as a TOML value, or as a string when it is not one,
 * and replaces the key before any check. `model_names` lists the known names for suggestions.
 */
Scene parse_scene(std::string_view text, const std::string& source_name,
                  const std::vector<std::string>& overrides, const ModelResolver& resolve,
                  const std::vector<std::string>& model_names = {});

/** Reads and parses a scene file; a missing or unreadable file is a SceneError too. */
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides,
                 const ModelResolver& resolve, const std::vector<std::string>& model_names = {});

/** The initial guess the scene asks for, on the scene's grid (a CSV guess is resampled). */
Trajectory make_initial_guess(const Scene& scene);

/** Levenshtein distance between two strings. */
std::size_t edit_distance(std::string_view a, std::string_view b);

/** The candidate nearest to `word` if it is close enough to be a plausible typo, else "". */
std::string nearest_name(std::string_view word, const std::vector<std::string>& candidates);

/** The scene names of the boundary values of derivative `d` (0 = position): "q", "v", "a", "j",
 *  then "d4_", "d5_", ...; the keys are this prefix followed by "0" or "N". */
std::string boundary_prefix(int d);

/**
 * Refuses non-ASCII bytes outside strings and comments (SceneError naming FILE:LINE:COL) before
 * toml++ sees them: toml++ 3.3.0 reaches undefined behaviour on some non-ASCII code points where
 * whitespace may stand. Every TOML reader of pardel::app calls it first.
 */
void check_ascii_outside_strings(std::string_view text, const std::string& source_name);

}  // namespace pardel::app

#endif  // PARDEL_APP_SCENE_HPP
