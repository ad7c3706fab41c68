/**
 * @file fuzz_scene_parser.cpp
 * Fuzz entry for the scene reader (pardel::app::parse_scene) with a fixed model registry: the
 * models bundled into this binary; a .lag path is refused by the resolver (nothing is compiled
 * while fuzzing). The input is the scene's TOML text, optionally followed by a line "%%" and one
 * --set override per line. Contract checked on every input:
 *   - parse_scene either returns a scene or throws SceneError; any other exception, a crash, a
 *     hang or a leak is a defect;
 *   - a SceneError starts with "fuzz.toml:LINE:COL: error: " (LINE inside the input),
 *     "fuzz.toml: error: " or "--set KEY=VALUE: error: ";
 *   - an accepted scene has consistent sizes, a grid with finite end time t0 + T and a non-zero
 *     step T/N, and its initial guess (linear or polyline) is a
 *     trajectory on the scene's grid that starts and ends at the boundary values.
 * Built as a libFuzzer target with clang (fuzz_scene_parser) and, with any compiler, as a corpus
 * replay program (fuzz_scene_parser_replay, see corpus_replay_main.cpp).
 */
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "fuzz_registry.hpp"
#include "pardel/pardel.hpp"
#include "pardel/app/scene.hpp"

namespace {

const char kSourceName[] = "fuzz.toml";

[[noreturn]] void violated(const std::string& what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scene_parser: contract violated: %s\n%s\n", what.c_str(), detail.c_str());
  std::abort();
}

using pardel_fuzz::count_lines;
using pardel_fuzz::resolve;

void check_error(const std::string& scene_text, const pardel::app::SceneError& error) {
  const std::string what = error.what();
  if (what.rfind("--set ", 0) == 0) {
    if (what.find(": error: ") == std::string::npos) violated("--set diagnostic without ': error: '", what);
    return;
  }
  const std::string file_head = std::string(kSourceName) + ":";
  if (what.rfind(file_head, 0) != 0) violated("diagnostic does not name " + std::string(kSourceName), what);
  if (what.rfind(file_head + " error: ", 0) == 0) return;  // names the key, no position
  unsigned long line = 0, column = 0;
  int consumed = 0;
  if (std::sscanf(what.c_str() + file_head.size(), "%lu:%lu: error: %n", &line, &column, &consumed) != 2 ||
      consumed == 0) {
    violated("diagnostic is neither FILE:LINE:COL: error: nor FILE: error:", what);
  }
  if (line < 1 || line > count_lines(scene_text) || column < 1) {
    violated("diagnostic position outside the scene (" + std::to_string(count_lines(scene_text)) + " lines)", what);
  }
}

void check_scene(const pardel::app::Scene& scene) {
  const pardel::Problem& problem = scene.problem;
  if (!scene.model || problem.model != scene.model) violated("accepted scene without its model", scene.model_spec);
  const std::size_t dim = static_cast<std::size_t>(scene.model->dim);
  if (problem.q0.size() != dim || problem.qN.size() != dim) violated("boundary sizes differ from the model's dim", "");
  if (!(problem.T > 0) || problem.N < 2) violated("accepted a grid with T <= 0 or N < 2", "");
  // Every node time t0 + k T/N must be finite and distinct from its neighbours.
  if (!std::isfinite(problem.t0 + problem.T) || !(problem.T / problem.N > 0)) {
    violated("accepted a grid whose end time t0 + T is not finite or whose step T/N is zero",
             "t0 = " + std::to_string(problem.t0) + ", T = " + std::to_string(problem.T) + ", N = " +
                 std::to_string(problem.N));
  }
  // The guess allocates (N+1)*dim values: only small grids are built while fuzzing.
  if (scene.guess.kind == pardel::app::GuessKind::csv || (problem.N + 1.0) * dim > 1e6) return;
  const pardel::Trajectory guess = pardel::app::make_initial_guess(scene);
  if (guess.N != problem.N || guess.dim != scene.model->dim ||
      guess.q.size() != static_cast<std::size_t>(problem.N + 1) * dim ||
      guess.t.size() != static_cast<std::size_t>(problem.N) + 1) {
    violated("initial guess of the wrong size", "");
  }
  for (std::size_t i = 0; i < dim; ++i) {
    if (guess.node(0)[i] != problem.q0[i] || guess.node(problem.N)[i] != problem.qN[i]) {
      violated("initial guess does not start and end at the boundary values", "");
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  std::string scene_text = input;
  std::vector<std::string> overrides;
  const std::size_t separator = input.find("\n%%\n");
  if (separator != std::string::npos) {
    scene_text = input.substr(0, separator + 1);
    std::size_t start = separator + 4;
    while (start < input.size()) {
      const std::size_t nl = input.find('\n', start);
      std::string line = input.substr(start, nl == std::string::npos ? std::string::npos : nl - start);
      line = line.substr(0, line.find('\0'));  // a command-line argument ends at its first NUL
      if (!line.empty()) overrides.push_back(line);
      if (nl == std::string::npos) break;
      start = nl + 1;
    }
  }
  static const std::vector<std::string> names = pardel::bundled_model_names();
  try {
    const pardel::app::Scene scene = pardel::app::parse_scene(scene_text, kSourceName, overrides, resolve, names);
    check_scene(scene);
  } catch (const pardel::app::SceneError& error) {
    check_error(scene_text, error);
  } catch (const std::exception& error) {
    violated("parse_scene threw something other than SceneError", error.what());
  }
  return 0;
}
