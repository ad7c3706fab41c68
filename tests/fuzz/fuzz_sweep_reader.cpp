/**
 * @file fuzz_sweep_reader.cpp
 * Fuzz entry for the sweep-file reader (pardel::app::parse_sweep, what `pardel sweep` reads).
 * The input is the sweep file's text, read as if it were PARDEL_FUZZ_SCENES_DIR/sweeps/fuzz.toml,
 * so that `scene = "../zermelo_1.toml"` names a scene of the repository (read, never written);
 * models come from the bundled registry, .lag paths are refused by the resolver. Contract checked
 * on every input:
 *   - parse_sweep either returns a sweep or throws SceneError; any other exception, a crash, a
 *     hang or a leak is a defect;
 *   - a SceneError reads "LOCATION: error: MESSAGE"; when LOCATION is the sweep file with a line,
 *     the line lies inside the input;
 *   - an accepted sweep has at least one configuration, guesses of the model's coordinate count,
 *     random numbers in [0, 1), and its first and last variants can be made, with finite vertices
 *     (a random guess runs from the configuration's q0 to its qN).
 * Built as a libFuzzer target with clang (fuzz_sweep_reader) and, with any compiler, as a corpus
 * replay program (fuzz_sweep_reader_replay, see corpus_replay_main.cpp).
 */
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "pardel/app/sweep.hpp"
#include "fuzz_registry.hpp"
#include "pardel/pardel.hpp"

namespace {

const std::string kSource = std::string(PARDEL_FUZZ_SCENES_DIR) + "/sweeps/fuzz.toml";

[[noreturn]] void violated(const std::string& what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_sweep_reader: contract violated: %s\n%s\n", what.c_str(), detail.c_str());
  std::abort();
}

using pardel_fuzz::count_lines;
using pardel_fuzz::resolve;

void check_error(const std::string& text, const std::string& what) {
  const std::size_t at = what.find(": error: ");
  if (at == std::string::npos || at == 0) violated("diagnostic is not LOCATION: error: MESSAGE", what);
  if (what.size() == at + 9) violated("diagnostic without a message", what);
  if (what.rfind(kSource + ":", 0) != 0 || what.rfind(kSource + ": error: ", 0) == 0) return;
  unsigned long line = 0, column = 0;
  if (std::sscanf(what.c_str() + kSource.size() + 1, "%lu:%lu", &line, &column) != 2)
    violated("diagnostic of the sweep file is neither FILE:LINE:COL nor FILE", what);
  if (line < 1 || line > count_lines(text) || column < 1)
    violated("diagnostic position outside the sweep file (" + std::to_string(count_lines(text)) + " lines)", what);
}

void check_variant(const pardel::app::Sweep& sweep, int id) {
  const pardel::app::Variant v = pardel::app::make_variant(sweep, id);
  if (v.configuration < 0 || v.configuration >= static_cast<int>(sweep.configurations.size()))
    violated("variant of a configuration that does not exist", std::to_string(id));
  const pardel::Problem& problem = sweep.configurations[v.configuration].problem;
  const std::size_t nc = static_cast<std::size_t>(problem.model->ncoords);
  for (const auto& point : v.points) {
    if (point.size() != nc) violated("a guess vertex without one value per coordinate", v.guess_label);
    for (double x : point)
      if (!std::isfinite(x)) violated("a guess vertex that is not finite", v.guess_label);
  }
  if (v.guess_label.rfind("random", 0) == 0) {
    if (v.points.size() != static_cast<std::size_t>(sweep.random.interior_points) + 2)
      violated("a random guess with the wrong number of vertices", v.guess_label);
    for (std::size_t i = 0; i < nc; ++i)
      if (v.points.front()[i] != problem.q0[i] || v.points.back()[i] != problem.qN[i])
        violated("a random guess that does not run from q0 to qN", v.guess_label);
  }
}

void check_sweep(const pardel::app::Sweep& sweep) {
  if (sweep.configurations.empty()) violated("accepted a sweep without configurations", "");
  if (sweep.configuration_values.size() != sweep.configurations.size())
    violated("configuration values do not match the configurations", "");
  const int ncoords = sweep.configurations.front().model->ncoords;
  for (const auto& scene : sweep.configurations)
    if (!scene.model || scene.model->ncoords != ncoords) violated("configurations of different coordinate counts", "");
  for (const auto& polyline : sweep.listed_guesses) {
    if (polyline.size() < 2) violated("a listed guess of fewer than 2 points", "");
    for (const auto& point : polyline)
      if (point.size() != static_cast<std::size_t>(ncoords)) violated("a listed point of the wrong size", "");
  }
  // interior_points * ncoords numbers per random guess, in one array
  if (sweep.random_unit.size() !=
      static_cast<std::size_t>(sweep.random.count) * sweep.random.interior_points * ncoords)
    violated("random numbers for another count or size of guesses", "");
  for (double u : sweep.random_unit)
    if (!(u >= 0 && u < 1)) violated("a random number outside [0, 1)", std::to_string(u));
  const long long expected = static_cast<long long>(sweep.configurations.size()) * sweep.guesses_per_configuration();
  if (sweep.variant_count() != expected) violated("variant count is not configurations x guesses", "");
  check_variant(sweep, 0);
  check_variant(sweep, sweep.variant_count() - 1);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  static const std::vector<std::string> names = pardel::bundled_model_names();
  try {
    check_sweep(pardel::app::parse_sweep(text, kSource, {}, resolve, names));
  } catch (const pardel::app::SceneError& error) {
    check_error(text, error.what());
  } catch (const std::exception& error) {
    violated("parse_sweep threw something other than SceneError", error.what());
  }
  return 0;
}
